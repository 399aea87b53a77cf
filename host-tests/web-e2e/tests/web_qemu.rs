//! The web page from the QEMU board's field-device firmware (`mps2-an386`,
//! `--features field-device`), in headless Chromium, with hans-sim as the
//! robot: the same page as on Linux, served by the firmware over its own
//! TCP stack, shows the live status and follows a move; a configuration
//! edit through the form is read back over Modbus. The page's load time is
//! printed (not asserted). Needs the firmware built first
//! ([`hans_web_e2e::field_device_elf`]); `scripts/firmware-tests.sh` runs
//! it (`cargo test -p hans-web-e2e --features qemu --test web_qemu`).

use hans_gateway::registers as r;
use hans_web_e2e::{field_device_elf, WebRig};

#[test]
fn the_page_from_the_qemu_field_device_shows_the_live_status_and_takes_a_form_edit() {
    let elf = field_device_elf();
    let mut rig = WebRig::start_qemu("qemu-field-device", &elf);
    let t = rig.load_times();
    println!("page load from the QEMU field-device firmware (ms from navigation start): {t}");
    rig.wait_live();
    rig.wait_data("fsm", "code", "33");
    assert_eq!(rig.text("link-state"), "connected");
    assert_eq!(rig.text("link-robot"), "10.0.2.100:10003");
    let start = rig.modbus(async |p| p.joints().await);
    rig.wait_text("j0", "J1 on the page", |t| {
        t.parse::<f32>().is_ok_and(|v| (v - start[0]).abs() < 0.001)
    });
    rig.shot("standby");

    // A move from the PLC shows on the page served by the firmware.
    let target = rig.modbus(async |p| p.start_move(0, 30.0, 20.0, 100.0, 1).await);
    rig.wait_data("fsm", "code", "25");
    rig.wait_data("flags-moving", "on", "1");
    rig.shot("moving");
    let end = rig.modbus(async |p| p.wait_end(hans_e2e::Plc::ch_status(0)).await);
    assert!(end.done(), "{end:?}");
    rig.wait_data("hs-ch0", "phase", "done");
    rig.wait_text("j0", "J1 at the target on the page", |t| {
        t.parse::<f32>().is_ok_and(|v| (v - target[0]).abs() < 0.01)
    });

    // First password and a form edit, read back over Modbus; the network
    // settings are the board's own here (restart pending once changed).
    rig.set_first_password("commission-2026");
    rig.type_in("f-link.poll_ms", "40");
    rig.type_in("f-network.web_port", "8080");
    rig.click("cfg-apply");
    rig.wait_data("cfg-msg", "result", "ok");
    let (poll, web_port) = rig.modbus(async |p| {
        (
            p.read1(r::CONFIG_POLL_MS).await,
            p.read1(r::NET_WEB_PORT).await,
        )
    });
    assert_eq!((poll, web_port), (40, 8080));
    rig.wait_for("the restart note", |r| {
        r.visible("restart-note").then_some(())
    });
    assert!(rig.visible("restart-btn"), "the board can restart itself");
    rig.shot("applied");
    rig.finish();
}
