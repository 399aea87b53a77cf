//! Build inputs of the NUCLEO-F767ZI firmware:
//! * this board's `memory.x` on the link search path (the top-level one
//!   belongs to the QEMU board);
//! * the network setting from `HANS_GW_NET`, checked here so a typo fails
//!   the build instead of the board:
//!     - unset: static `192.168.1.50/24`, gateway `192.168.1.1` (the default)
//!     - `dhcp`: DHCPv4 (needs the crate's `dhcp` feature)
//!     - `A.B.C.D/P` or `A.B.C.D/P,G.H.I.J`: static address, optional gateway
use std::{env, fs, net::Ipv4Addr, path::PathBuf};

const DEFAULT_NET: &str = "192.168.1.50/24,192.168.1.1";

fn main() {
    let out = PathBuf::from(env::var_os("OUT_DIR").expect("cargo sets OUT_DIR"));
    let dir = PathBuf::from(env::var_os("CARGO_MANIFEST_DIR").expect("cargo sets it"));
    fs::copy(dir.join("memory.x"), out.join("memory.x")).expect("memory.x is readable");
    println!("cargo:rustc-link-search={}", out.display());
    println!("cargo:rerun-if-changed=memory.x");
    println!("cargo:rerun-if-env-changed=HANS_GW_NET");

    let net = env::var("HANS_GW_NET").unwrap_or_else(|_| DEFAULT_NET.to_string());
    let code = match parse(net.trim()) {
        Ok(code) => code,
        Err(e) => panic!("HANS_GW_NET={net:?}: {e} (expected `dhcp` or `A.B.C.D/P[,G.H.I.J]`)"),
    };
    fs::write(out.join("net_setting.rs"), code).expect("OUT_DIR is writable");
}

fn ip_expr(ip: Ipv4Addr) -> String {
    let [a, b, c, d] = ip.octets();
    format!("Ipv4Address::new({a}, {b}, {c}, {d})")
}

fn parse(net: &str) -> Result<String, String> {
    if net.eq_ignore_ascii_case("dhcp") {
        if env::var_os("CARGO_FEATURE_DHCP").is_none() {
            return Err("DHCP needs the `dhcp` feature: add `--features dhcp`".into());
        }
        return Ok(
            "/// From `HANS_GW_NET` at build time.\nconst NET: NetSetting = NetSetting::Dhcp;\n"
                .into(),
        );
    }
    let (cidr, gateway) = match net.split_once(',') {
        Some((c, g)) => (c, Some(g)),
        None => (net, None),
    };
    let (addr, prefix) = cidr.split_once('/').ok_or("missing /prefix")?;
    let addr: Ipv4Addr = addr.parse().map_err(|_| "bad address")?;
    let prefix: u8 = prefix.parse().map_err(|_| "bad prefix")?;
    if !(1..=32).contains(&prefix) {
        return Err("prefix must be 1-32".into());
    }
    let gateway = match gateway {
        Some(g) => {
            let g: Ipv4Addr = g.trim().parse().map_err(|_| "bad gateway address")?;
            format!("Some({})", ip_expr(g))
        }
        None => "None".into(),
    };
    Ok(format!(
        "/// From `HANS_GW_NET` at build time.\nconst NET: NetSetting = NetSetting::Static {{ address: {}, prefix: {prefix}, gateway: {gateway} }};\n",
        ip_expr(addr)
    ))
}
