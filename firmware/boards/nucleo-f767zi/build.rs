//! Build inputs of the NUCLEO-F767ZI firmware:
//! * this board's `memory.x` on the link search path (the top-level one
//!   belongs to the QEMU board);
//! * the factory network settings (`FACTORY_NET`) from `HANS_GW_NET`,
//!   checked here so a typo fails the build instead of the board. They are
//!   what the board runs with until a configuration is stored (and in a
//!   recovery start); the address is then set at run time (`NET_*`
//!   registers, web page), so one binary serves every plant:
//!     - unset: static `192.168.1.50/24`, gateway `192.168.1.1` (the default)
//!     - `dhcp`: DHCPv4 (needs the crate's `dhcp` or `field-device` feature),
//!       with 192.168.1.50/24 as the static setting shown in the form
//!     - `A.B.C.D/P` or `A.B.C.D/P,G.H.I.J`: static address, optional gateway
use std::{env, fs, net::Ipv4Addr, path::PathBuf};

const DEFAULT_NET: &str = "192.168.1.50/24,192.168.1.1";

fn main() {
    let out = PathBuf::from(env::var_os("OUT_DIR").expect("cargo sets OUT_DIR"));
    let dir = PathBuf::from(env::var_os("CARGO_MANIFEST_DIR").expect("cargo sets it"));
    // Each binary gets the memory map of its own (cortex-m-rt's `link.x`
    // includes the `memory.x` found on the search path): the core firmware
    // runs alone from the flash's start (`memory.x`); the field device is
    // started by the bootloader from the active slot (`memory-slot.x`).
    let _ = fs::remove_file(out.join("memory.x"));
    for (map, bin) in [
        ("memory.x", "nucleo-f767zi"),
        ("memory-slot.x", "nucleo-f767zi-field-device"),
    ] {
        let search = out.join(bin);
        fs::create_dir_all(&search).expect("OUT_DIR is writable");
        fs::copy(dir.join(map), search.join("memory.x")).expect("the memory map is readable");
        println!("cargo:rustc-link-arg-bin={bin}=-L{}", search.display());
        println!("cargo:rerun-if-changed={map}");
    }
    println!("cargo:rerun-if-env-changed=HANS_GW_NET");

    let net = env::var("HANS_GW_NET").unwrap_or_else(|_| DEFAULT_NET.to_string());
    let code = match parse(net.trim()) {
        Ok(code) => code,
        Err(e) => panic!("HANS_GW_NET={net:?}: {e} (expected `dhcp` or `A.B.C.D/P[,G.H.I.J]`)"),
    };
    fs::write(out.join("factory_net.rs"), code).expect("OUT_DIR is writable");
}

fn ip_expr(ip: Ipv4Addr) -> String {
    let [a, b, c, d] = ip.octets();
    format!("::core::net::Ipv4Addr::new({a}, {b}, {c}, {d})")
}

/// The `FACTORY_NET` constant for `HANS_GW_NET`'s value.
fn parse(net: &str) -> Result<String, String> {
    let (cidr, gateway, dhcp) = if net.eq_ignore_ascii_case("dhcp") {
        if env::var_os("CARGO_FEATURE_DHCP").is_none() {
            return Err("DHCP needs the `dhcp` feature: add `--features dhcp`".into());
        }
        ("192.168.1.50/24", Some("192.168.1.1"), true)
    } else {
        match net.split_once(',') {
            Some((c, g)) => (c, Some(g), false),
            None => (net, None, false),
        }
    };
    let (addr, prefix) = cidr.split_once('/').ok_or("missing /prefix")?;
    let addr: Ipv4Addr = addr.parse().map_err(|_| "bad address")?;
    let prefix: u32 = prefix.parse().map_err(|_| "bad prefix")?;
    if !(1..=32).contains(&prefix) {
        return Err("prefix must be 1-32".into());
    }
    let mask = Ipv4Addr::from(u32::MAX << (32 - prefix));
    let gateway = match gateway {
        Some(g) => g.trim().parse().map_err(|_| "bad gateway address")?,
        None => Ipv4Addr::UNSPECIFIED,
    };
    Ok(format!(
        "/// The factory network settings: `{net}` (`HANS_GW_NET` at build time;\n\
         /// default 192.168.1.50/24 via 192.168.1.1); Modbus on 502, the web page on 80.\n\
         pub const FACTORY_NET: NetConfig = NetConfig {{\n    \
         ip: {},\n    mask: {},\n    gateway: {},\n    dhcp: {dhcp},\n    ..NetConfig::DEFAULT\n}};\n",
        ip_expr(addr),
        ip_expr(mask),
        ip_expr(gateway),
    ))
}
