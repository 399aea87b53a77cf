//! The field-device firmware under QEMU (web page, DHCP client, DataSheet
//! reader): its web page and JSON API over HTTP through QEMU's port
//! forward, the live status of the simulated robot, the page's load time
//! (printed, not asserted), the Modbus allow-list on the board, and the
//! address from QEMU's DHCP server.
//!
//! What the firmware sees of a forwarded client: QEMU's user-mode network
//! (slirp) presents every connection that comes in through a `hostfwd` from
//! a loopback address (all of 127.0.0.0/8) as coming from its host alias
//! 10.0.2.2 (slirp's `sotranslate_accept`). So a client from 127.0.0.2 and
//! one from 127.0.0.1 are the same address to the firmware, and "refused
//! from 127.0.0.2, served from 127.0.0.1" cannot be shown through QEMU. The
//! test here shows what can be: the firmware sees 10.0.2.2 for both, an
//! allow-list that holds 127.0.0.1 only refuses both (counted), and one
//! that holds 10.0.2.2 serves them again. The distinction by loopback
//! source address is tested on the host, where the gateway sees the real
//! addresses (`host-tests/e2e/tests/allow_list.rs`).
//!
//! Register addresses are the gateway's (`gateway/REGISTERS.md`), repeated
//! on purpose as in `gateway.rs`.

use std::net::{Ipv4Addr, SocketAddr, TcpStream};
use std::time::{Duration, Instant};

use qemu_tests::{http_get, must, HttpClient, Plc};
use serde_json::Value;

const STATUS_FSM: u16 = 6;
const CONFIG_COMMAND: u16 = 141;
const CONFIG_RESULT: u16 = 142;
const MODBUS_ALLOW: u16 = 170;
/// CONFIG_RESULT: applied and saved (the field device keeps its
/// configuration in its flash file).
const APPLIED_AND_SAVED: u16 = 0;

// Command channel 0 (see gateway.rs).
const CH0: u16 = 200;
const CH_STATUS: u16 = 60;
const ST_DONE: u16 = 1 << 1;
const ST_ERROR: u16 = 1 << 2;
const CMD_POWER_ON: u16 = 1;
const CMD_ENABLE: u16 = 3;
const FSM_STANDBY: u64 = 33;

mod common;
use common::{wait_for, Rig, STEP};

/// The setup code the host hands the firmware (`setup=` on its command
/// line), as it hands in the seed.
const SETUP_CODE: &str = "ABCD-EFGH-JKMN";

impl Rig {
    fn field_device(name: &'static str) -> Rig {
        Rig::start("field-device", name, &format!("setup={SETUP_CODE}"))
    }

    /// Creates the first administrator with the setup code: until one
    /// exists, the access settings do not change over Modbus.
    fn create_admin(&self) {
        let body =
            format!(r#"{{"code":"{SETUP_CODE}","name":"admin","password":"commission-2026"}}"#);
        let r = qemu_tests::HttpClient::connect(self.web(), STEP)
            .and_then(|mut c| c.post_json("/api/setup", &body))
            .unwrap_or_else(|e| panic!("POST /api/setup: {e}"));
        assert_eq!(r.status, 200, "POST /api/setup: {}", r.text());
    }

    /// The administrator (created with [`Self::create_admin`], logged in
    /// again here) allows configuration over Modbus: the protected
    /// settings (the allow-lists among them) change over Modbus only then
    /// (issue 25, register map 1.5).
    fn allow_modbus_config(&self) {
        let login = r#"{"name":"admin","password":"commission-2026"}"#;
        let r = qemu_tests::HttpClient::connect(self.web(), STEP)
            .and_then(|mut c| c.post_json("/api/login", login))
            .unwrap_or_else(|e| panic!("POST /api/login: {e}"));
        assert_eq!(r.status, 200, "POST /api/login: {}", r.text());
        let cookie = r
            .header("Set-Cookie")
            .and_then(|c| c.split(';').next())
            .unwrap_or_else(|| panic!("a session cookie: {:?}", r.headers))
            .to_string();
        let origin = format!("http://127.0.0.1:{}", self.web());
        let headers = [
            ("Origin", origin.as_str()),
            ("Content-Type", "application/json"),
            ("Cookie", cookie.as_str()),
        ];
        let body = br#"{"settings":{"access.modbus_config":"true"}}"#;
        let r = qemu_tests::HttpClient::connect(self.web(), STEP)
            .and_then(|mut c| c.send("POST", "/api/config", &headers, body, STEP))
            .map(|(r, _took)| r)
            .unwrap_or_else(|e| panic!("POST /api/config: {e}"));
        assert_eq!(r.status, 200, "POST /api/config: {}", r.text());
    }

    fn web(&self) -> u16 {
        self.qemu.ports.web
    }

    /// `GET path`, which must answer 200.
    fn get(&self, path: &str) -> qemu_tests::HttpResponse {
        let r = http_get(self.web(), path, STEP).unwrap_or_else(|e| panic!("GET {path}: {e}"));
        assert_eq!(r.status, 200, "GET {path}: {}", r.text());
        r
    }

    /// `/api/status` as JSON.
    fn status(&self) -> Value {
        let r = self.get("/api/status");
        serde_json::from_slice(&r.body)
            .unwrap_or_else(|e| panic!("/api/status is not JSON ({e}): {}", r.text()))
    }
}

/// Channel 0 runs `code` (no parameters) with sequence `seq`; its status
/// bits at the end.
fn execute(plc: &mut Plc, code: u16, seq: u16) -> u16 {
    must(plc.write_single_register(CH0, 0), "Execute low");
    must(
        plc.write_multiple_registers(CH0 + 1, &[code, seq]),
        "command and sequence",
    );
    must(plc.write_single_register(CH0, 1), "Execute");
    let st = wait_for(&format!("command {code}"), STEP, || {
        let r = must(
            plc.read_holding_registers(CH0 + CH_STATUS, 2),
            "channel status",
        );
        (r[1] == seq && r[0] & (ST_DONE | ST_ERROR) != 0).then_some(r[0])
    });
    must(plc.write_single_register(CH0, 0), "Execute low");
    st
}

fn ms(d: Duration) -> f64 {
    d.as_secs_f64() * 1000.0
}

#[test]
fn the_field_device_serves_its_page_and_the_live_status_of_the_robot() {
    let rig = Rig::field_device("field-device-web");

    // The live status shows the simulator's robot: link connected, its FSM.
    let status = wait_for("the robot in /api/status", STEP, || {
        let s = rig.status();
        let up = s["link"]["state"] == "connected" && s["robot"]["fsm"]["name"].is_string();
        up.then_some(s)
    });
    // No broker handed in (`mqtt=`): the Sparkplug edge node stays off
    // (tests/mqtt.rs runs it).
    assert_eq!(status["mqtt"]["on"], false, "MQTT off: {}", status["mqtt"]);
    let fsm = &status["robot"]["fsm"];
    println!(
        "field-device-web: /api/status: link {}, FSM {} ({}), status age {} ms",
        status["link"]["state"], fsm["name"], fsm["code"], status["robot"]["age_ms"]
    );
    assert!(
        status["robot"]["age_ms"]
            .as_u64()
            .is_some_and(|a| a <= 1000),
        "status at most 1 s old: {status}"
    );
    // The same FSM as the registers show (both are views of one state).
    let mut plc = rig.modbus();
    let reg_fsm = must(plc.read_input_registers(STATUS_FSM, 1), "FSM_STATE")[0];
    let web_fsm = rig.status()["robot"]["fsm"]["code"].as_u64();
    assert_eq!(
        web_fsm,
        Some(u64::from(reg_fsm)),
        "FSM over HTTP and Modbus"
    );

    // Live: powering on and enabling the robot through Modbus shows on the
    // page.
    for (seq, code) in [(1, CMD_POWER_ON), (2, CMD_ENABLE)] {
        let st = execute(&mut plc, code, seq);
        assert_eq!(
            st & (ST_DONE | ST_ERROR),
            ST_DONE,
            "command {code}: {st:#06x}"
        );
    }
    let s = wait_for("the page to show the robot enabled", STEP, || {
        let s = rig.status();
        let flags = &s["robot"]["flags"];
        (flags["powered"] == true
            && flags["enabled"] == true
            && s["robot"]["fsm"]["code"] == FSM_STANDBY)
            .then_some(s)
    });
    println!(
        "field-device-web: after power-on and enable: FSM {} ({}), powered {}, enabled {}",
        s["robot"]["fsm"]["name"],
        s["robot"]["fsm"]["code"],
        s["robot"]["flags"]["powered"],
        s["robot"]["flags"]["enabled"]
    );
    drop(plc);

    // The page: gzip-compressed HTML.
    let page = rig.get("/");
    assert_eq!(page.header("Content-Encoding"), Some("gzip"));
    assert!(
        page.header("Content-Type")
            .is_some_and(|t| t.starts_with("text/html")),
        "{:?}",
        page.headers
    );
    assert_eq!(&page.body[..2], &[0x1f, 0x8b], "gzip magic");

    // Load time, as a browser loads the page: one kept-alive connection,
    // the page, then what its script reads at start. Three rounds; the
    // first connects cold. Reported, not asserted.
    let start_reads = [
        "/api/session",
        "/api/fields",
        "/api/config",
        "/api/status",
        "/api/log",
    ];
    for round in 1..=3 {
        let t0 = Instant::now();
        let mut c = HttpClient::connect(rig.web(), STEP).expect("connect to the page");
        let page = c.get("/").expect("GET /");
        let t_page = t0.elapsed();
        let mut bytes = page.body.len();
        for path in start_reads {
            let r = c.get(path).unwrap_or_else(|e| panic!("GET {path}: {e}"));
            assert_eq!(r.status, 200, "GET {path}");
            bytes += r.body.len();
        }
        let t_all = t0.elapsed();
        println!(
            "field-device-web: page load round {round}: / ({} bytes gzip) in {:.1} ms; with its start-up reads ({}; {bytes} bytes in all) {:.1} ms",
            page.body.len(),
            ms(t_page),
            start_reads.join(", "),
            ms(t_all)
        );
    }

    let _ = rig.exit();
}

/// A Modbus client whose connection comes from `local` (127.0.0.x).
fn connect_from(local: Ipv4Addr, port: u16) -> std::io::Result<TcpStream> {
    // std has no bind-then-connect: tokio's TcpSocket does, blocking here
    // on a small runtime of its own.
    let rt = tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .build()?;
    rt.block_on(async {
        let s = tokio::net::TcpSocket::new_v4()?;
        s.bind(SocketAddr::from((local, 0)))?;
        let stream = tokio::time::timeout(
            Duration::from_secs(5),
            s.connect(SocketAddr::from((Ipv4Addr::LOCALHOST, port))),
        )
        .await
        .map_err(|_| std::io::Error::new(std::io::ErrorKind::TimedOut, "connect"))??;
        stream.into_std()
    })
    .and_then(|s| {
        s.set_nonblocking(false)?;
        Ok(s)
    })
}

/// One attempt at a Modbus session from `local`: `true` if served.
fn served_from(local: Ipv4Addr, port: u16) -> bool {
    let Ok(stream) = connect_from(local, port) else {
        return false;
    };
    let Ok(mut plc) = Plc::new(stream, Duration::from_secs(5)) else {
        return false;
    };
    matches!(plc.read_holding_registers(0, 1), Ok(Ok(_)))
}

/// The Modbus clients' addresses the firmware shows on its page.
fn clients(rig: &Rig) -> Vec<String> {
    rig.status()["modbus"]["clients"]
        .as_array()
        .map(|a| {
            a.iter()
                .filter_map(|c| c.as_str().map(str::to_string))
                .collect()
        })
        .unwrap_or_default()
}

#[test]
fn the_modbus_allow_list_on_the_board_refuses_and_serves_by_the_address_it_sees() {
    let rig = Rig::field_device("field-device-allow");
    let port = rig.qemu.ports.modbus;
    // A fresh device refuses access-setting changes over Modbus
    // (CONFIG_RESULT 4): they are protected settings, changed over Modbus
    // only once an administrator allows configuration over Modbus.
    {
        let mut plc = rig.modbus();
        must(
            plc.write_multiple_registers(MODBUS_ALLOW, &[0x0a00, 0x0202, 32]),
            "MODBUS_ALLOW 10.0.2.2/32",
        );
        assert!(
            matches!(plc.write_single_register(CONFIG_COMMAND, 1), Ok(Err(_))),
            "locked: a Modbus exception"
        );
        let result = must(plc.read_holding_registers(CONFIG_RESULT, 1), "result")[0];
        assert_eq!(result, 4, "CONFIG_RESULT: access settings locked");
        must(
            plc.write_single_register(CONFIG_COMMAND, 2),
            "discard the edit",
        );
    }
    rig.create_admin();
    rig.allow_modbus_config();
    let local2 = Ipv4Addr::new(127, 0, 0, 2);

    // The address the firmware sees for forwarded clients: 10.0.2.2, from
    // 127.0.0.1 and from 127.0.0.2 alike.
    let mut admin = rig.modbus();
    let seen = wait_for("one client on the page", STEP, || {
        let c = clients(&rig);
        (c.len() == 1).then_some(c)
    });
    let stream = connect_from(local2, port).expect("connect from 127.0.0.2");
    let mut second = Plc::new(stream, Duration::from_secs(5)).expect("client");
    must(second.read_holding_registers(0, 1), "client from 127.0.0.2");
    let both = wait_for("two clients on the page", STEP, || {
        let c = clients(&rig);
        (c.len() == 2).then_some(c)
    });
    println!(
        "field-device-allow: the firmware sees 127.0.0.1 as {seen:?}; with 127.0.0.2: {both:?}"
    );
    for c in &both {
        assert!(c.starts_with("10.0.2.2:"), "slirp's host alias: {both:?}");
    }
    drop(second);

    // MODBUS_ALLOW = 10.0.2.2/32, the address the firmware sees: served,
    // from 127.0.0.1 as from 127.0.0.2, and the session that applied it
    // stays.
    must(
        admin.write_multiple_registers(MODBUS_ALLOW, &[0x0a00, 0x0202, 32]),
        "MODBUS_ALLOW 10.0.2.2/32",
    );
    must(admin.write_single_register(CONFIG_COMMAND, 1), "apply");
    let result = must(admin.read_holding_registers(CONFIG_RESULT, 1), "result")[0];
    assert_eq!(result, APPLIED_AND_SAVED, "CONFIG_RESULT");
    assert!(served_from(local2, port), "127.0.0.2 (as 10.0.2.2) served");
    assert!(served_from(Ipv4Addr::LOCALHOST, port), "127.0.0.1 served");

    // MODBUS_ALLOW = 127.0.0.1/32 only: every forwarded client (10.0.2.2)
    // is refused, from 127.0.0.1 as from 127.0.0.2, and counted; and the
    // session that applied it is closed too (applying an allow-list closes
    // the sessions it no longer permits), so the counts are read from the
    // page.
    let refused_before = rig.status()["modbus"]["refused"].as_u64().unwrap_or(0);
    must(
        admin.write_multiple_registers(MODBUS_ALLOW, &[0x7f00, 0x0001, 32]),
        "MODBUS_ALLOW 127.0.0.1/32",
    );
    let _ = admin.write_single_register(CONFIG_COMMAND, 1);
    assert!(
        !matches!(admin.read_holding_registers(0, 1), Ok(Ok(_))),
        "the session that applied it is closed"
    );
    assert!(!served_from(Ipv4Addr::LOCALHOST, port), "127.0.0.1 refused");
    assert!(!served_from(local2, port), "127.0.0.2 refused");
    wait_for("both refusals counted on the page", STEP, || {
        let r = rig.status()["modbus"]["refused"].as_u64()?;
        (r.wrapping_sub(refused_before) >= 2).then_some(r)
    });

    drop(admin);
    let _ = rig.exit();
}

#[test]
fn the_field_device_takes_its_address_from_dhcp() {
    // DHCP as the factory network setting (as HANS_GW_NET=dhcp on the
    // NUCLEO); QEMU's user network has a DHCP server that leases 10.0.2.15,
    // the address the ports are forwarded to.
    let rig = Rig::start("field-device", "field-device-dhcp", "dhcp");
    let config = wait_for("/api/config", STEP, || {
        let r = http_get(rig.web(), "/api/config", STEP).ok()?;
        serde_json::from_slice::<Value>(&r.body).ok()
    });
    assert_eq!(config["settings"]["network.dhcp"], "true", "{config}");
    // The page answers at the leased address, and the robot link is up
    // over it.
    wait_for("the robot link over the leased address", STEP, || {
        (rig.status()["link"]["state"] == "connected").then_some(())
    });
    let log = rig.exit();
    if !log.starts_with("(raw defmt") {
        assert!(log.contains("network: DHCP"), "DHCP asked for");
        assert!(
            log.contains("network: address 10.0.2.15/24"),
            "the lease logged"
        );
    }
}
