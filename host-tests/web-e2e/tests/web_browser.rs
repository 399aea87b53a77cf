//! The gateway's web page in headless Chromium (Debian's), against the host
//! gateway and hans-sim on 127.0.0.1: what a plant engineer sees and does
//! on it, checked over Modbus and the JSON API. Screenshots of each state
//! go to `<target>/screenshots/<test>-<step>.png` (paths printed; run with
//! `--nocapture` to see them).

use hans_gateway::registers as r;
use hans_web_e2e::{WebRig, PHONE};

/// A password the tests set.
const PW: &str = "commission-2026";

/// The page's colours (its CSS variables), as the browser computes them.
const RED: &str = "rgb(168, 7, 26)";
const GREEN: &str = "rgb(22, 107, 44)";
const WHITE: &str = "rgb(255, 255, 255)";
const GREY: &str = "rgb(85, 85, 85)";

/// What the page must do at once (its own periodic reload of the audit log
/// comes every 15 s).
const AT_ONCE: std::time::Duration = std::time::Duration::from_secs(4);

/// The joints shown on the page (J1-J6), `None` while unknown.
fn page_joints(rig: &WebRig) -> Option<[f32; 6]> {
    let mut j = [0.0; 6];
    for (i, v) in j.iter_mut().enumerate() {
        *v = rig.text(&format!("j{i}")).parse().ok()?;
    }
    Some(j)
}

/// A rig whose page has its first administrator and its configuration
/// form enabled.
fn form_ready(test: &'static str) -> WebRig {
    let mut rig = WebRig::start(test);
    rig.wait_live();
    rig.set_first_password(PW);
    rig.wait_js(
        "the form enabled",
        "!document.getElementById('cfg-fs').disabled",
    );
    rig
}

/// The text of the form's label of setting `key`: its name in words, then
/// the key.
fn label(rig: &WebRig, key: &str) -> String {
    rig.js(&format!(
        "document.querySelector('label[for=\"f-{key}\"]').textContent"
    ))
    .as_str()
    .unwrap_or_default()
    .to_string()
}

#[test]
fn the_page_shows_the_live_status_and_follows_a_move() {
    let mut rig = WebRig::start("live-status");
    let t = rig.load_times();
    println!("page load from the host gateway (ms from navigation start): {t}");
    rig.wait_live();
    rig.wait_data("fsm", "code", "33");
    assert_eq!(rig.text("fsm"), "StandBy (33)");
    assert_eq!(rig.text("link-state"), "connected");
    assert_eq!(rig.text("robot-error"), "none");
    // The simulator is a V6 controller: the level detected at connection.
    rig.wait_text("link-protocol", "the protocol level", |t| {
        t.starts_with("HR6.")
    });
    assert_eq!(rig.data("flags-enabled", "on"), "1", "flag 'enabled'");
    assert!(rig.text("mb-clients").starts_with("127.0.0.1:"));
    // The telemetry is off in the factory state, and the page says so.
    assert_eq!(rig.text("mqtt-state"), "off");
    // One version line in the header: the software's (Linux runs no
    // firmware image: `image` is null, and the line names none).
    let status: serde_json::Value =
        serde_json::from_str(&rig.http("GET", "/api/status", "").body).expect("JSON");
    assert_eq!(status["image"], serde_json::Value::Null);
    let version = status["version"].as_str().expect("a version");
    assert_eq!(rig.text("version"), format!("software {version}"));
    // The joints on the page are those the PLC reads.
    let start = rig.modbus(async |p| p.joints().await);
    let shown = rig.wait_for("joints on the page", page_joints);
    for (a, b) in start.iter().zip(shown) {
        assert!((a - b).abs() < 0.001, "page {shown:?}, Modbus {start:?}");
    }
    rig.shot("standby");

    // A joint move from the PLC: the page follows it.
    let target = rig.modbus(async |p| p.start_move(0, 40.0, 20.0, 100.0, 1).await);
    rig.wait_data("fsm", "code", "25");
    assert_eq!(rig.text("fsm"), "Moving (25)");
    rig.wait_data("flags-moving", "on", "1");
    rig.wait_for("J1 moving on the page", |r| {
        let j = page_joints(r)?;
        (j[0] > start[0] + 1.0 && j[0] < target[0] - 1.0).then_some(())
    });
    let phase = rig.data("hs-ch0", "phase");
    assert!(phase == "moving" || phase == "running", "{phase}");
    rig.shot("moving");
    let end = rig.modbus(async |p| p.wait_end(hans_e2e::Plc::ch_status(0)).await);
    assert!(end.done(), "{end:?}");
    rig.wait_data("hs-ch0", "phase", "done");
    rig.wait_data("fsm", "code", "33");
    rig.wait_for("J1 at the target on the page", |r| {
        let j = page_joints(r)?;
        ((j[0] - target[0]).abs() < 0.01).then_some(())
    });
    assert!(
        rig.text("hs-ch0").contains("Done"),
        "{}",
        rig.text("hs-ch0")
    );
    // The command log shows the move with its outcome and time to Done.
    rig.wait_js(
        "the move in the command log",
        "[...document.querySelectorAll('#log-body tr[data-kind=command]')].some(t => \
         t.children[2].textContent.startsWith('WayPoint') && t.children[4].textContent === 'Done' \
         && t.children[5].textContent.endsWith(' ms'))",
    );
    rig.shot("done");

    // On a phone-sized screen nothing is wider than the screen.
    rig.phone(true);
    rig.wait_js(
        "the phone viewport",
        &format!("window.innerWidth === {}", PHONE.0),
    );
    let wide = rig.js("document.documentElement.scrollWidth");
    assert_eq!(
        wide.as_u64(),
        Some(u64::from(PHONE.0)),
        "page width on a phone"
    );
    for section in ["status", "config", "triggers", "log"] {
        rig.shot_at(section, &format!("phone-{section}"));
    }
    rig.phone(false);

    // The gateway goes away: the page says so instead of showing old values
    // as live.
    rig.stop_gateway();
    rig.wait_data("conn", "state", "down");
    assert!(
        rig.text("conn").starts_with("no answer"),
        "{}",
        rig.text("conn")
    );
    assert!(rig.visible("stale-banner"));
    rig.shot("no-answer");
    rig.finish();
}

#[test]
fn a_configuration_edit_through_the_form_is_applied_and_read_back_over_modbus() {
    let mut rig = form_ready("config-edit");
    // Each setting is named in words, its key beside (issue 27: the keys
    // alone were hard for operators).
    assert_eq!(
        label(&rig, "link.reply_timeout_ms"),
        "Robot reply timeout [ms]link.reply_timeout_ms"
    );
    assert_eq!(label(&rig, "robot.address"), "Robot addressrobot.address");
    let unnamed = rig.js(
        "[...document.querySelectorAll('#cfg-groups .fld')].filter(f => \
         !f.querySelector('label code') || f.querySelector('label code').textContent !== f.dataset.field \
         || f.querySelector('label').firstChild.textContent.startsWith(f.dataset.field)).map(f => f.dataset.field)",
    );
    assert_eq!(unnamed, serde_json::json!([]), "settings without words");
    rig.shot_at("config", "labels");
    // Units, ranges and help come from /api/fields.
    let help = rig.text("h-link.poll_ms");
    assert!(
        help.contains("10–100 ms") && help.contains("register CFG_POLL_MS (105)"),
        "{help}"
    );
    rig.type_in("f-link.poll_ms", "40");
    rig.type_in("f-link.reply_timeout_ms", "2500");
    rig.type_in("f-access.modbus_allow", "127.0.0.0/8");
    rig.choose("f-access.write_protect", "true");
    rig.click("cfg-apply");
    rig.wait_data("cfg-msg", "result", "ok");
    let msg = rig.text("cfg-msg");
    assert!(msg.contains("applied"), "{msg}");
    rig.shot("applied");

    let (poll, timeout, wp, allow) = rig.modbus(async |plc| {
        (
            plc.read1(r::CONFIG_POLL_MS).await,
            plc.read1(r::CONFIG_REPLY_TIMEOUT_MS).await,
            plc.read1(r::CONFIG_WRITE_PROTECT).await,
            plc.read(r::MODBUS_ALLOW, 3).await,
        )
    });
    assert_eq!((poll, timeout, wp), (40, 2500, 1));
    assert_eq!(allow, [0x7f00, 0x0000, 8]);
    // Write-protected now: a configuration write over Modbus is refused
    // (exception 01) ...
    let refused = rig.modbus(async |plc| {
        use tokio_modbus::client::Writer;
        plc.ctx
            .write_single_register(r::CONFIG_POLL_MS, 60)
            .await
            .expect("transport")
    });
    assert_eq!(refused, Err(tokio_modbus::ExceptionCode::IllegalFunction));
    // ... until the page lifts the protection.
    rig.choose("f-access.write_protect", "false");
    rig.click("cfg-apply");
    rig.wait_text("cfg-msg", "the second apply", |t| {
        t.starts_with("access.write_protect:")
    });
    assert_eq!(rig.data("cfg-msg", "result"), "ok");
    let poll = rig.modbus(async |plc| {
        plc.write(r::CONFIG_POLL_MS, &[60]).await;
        plc.write(r::CONTROL_CONFIG_COMMAND, &[1]).await;
        plc.read1(r::CONFIG_POLL_MS).await
    });
    assert_eq!(poll, 60);
    rig.finish();
}

#[test]
fn the_form_allows_configuration_over_modbus_and_reserves_the_plcs_address() {
    let mut rig = form_ready("access-form");
    // Both settings are in the form, named in words (issue 25).
    assert_eq!(
        label(&rig, "access.modbus_config"),
        "Configuration over Modbusaccess.modbus_config"
    );
    assert_eq!(
        label(&rig, "access.plc_address"),
        "PLC address (reserved slot)access.plc_address"
    );
    // With an administrator, the PLC changes no protected setting: the
    // apply is refused (exception 01) with CONFIG_RESULT 4, and the edit is
    // discarded.
    let (refused, result, access) = rig.modbus(async |plc| {
        use tokio_modbus::client::Writer;
        plc.write(r::CONFIG_WRITE_PROTECT, &[1]).await;
        let refused = plc
            .ctx
            .write_single_register(r::CONTROL_CONFIG_COMMAND, 1)
            .await
            .expect("transport");
        let result = plc.read1(r::CONTROL_CONFIG_RESULT).await;
        plc.write(r::CONTROL_CONFIG_COMMAND, &[2]).await;
        (refused, result, plc.read1(r::STATUS_ACCESS).await)
    });
    assert_eq!(refused, Err(tokio_modbus::ExceptionCode::IllegalFunction));
    assert_eq!(result, 4, "CONFIG_RESULT: access settings locked");
    assert_eq!(access & r::ACCESS_MODBUS_CONFIG, 0, "STATUS_ACCESS");
    rig.shot("locked");

    // The administrator allows configuration over Modbus and reserves a
    // session for the PLC's address, in the form.
    rig.choose("f-access.modbus_config", "true");
    rig.type_in("f-access.plc_address", "127.0.0.1");
    rig.click("cfg-apply");
    rig.wait_data("cfg-msg", "result", "ok");
    rig.shot("allowed");
    let (access, result, protected) = rig.modbus(async |plc| {
        let access = plc.read1(r::STATUS_ACCESS).await;
        plc.write(r::CONFIG_WRITE_PROTECT, &[1]).await;
        plc.write(r::CONTROL_CONFIG_COMMAND, &[1]).await;
        let result = plc.read1(r::CONTROL_CONFIG_RESULT).await;
        (access, result, plc.read1(r::STATUS_ACCESS).await)
    });
    assert_ne!(access & r::ACCESS_MODBUS_CONFIG, 0, "STATUS_ACCESS");
    assert_ne!(result, 4, "CONFIG_RESULT after the page allowed it");
    assert_ne!(
        protected & r::ACCESS_WRITE_PROTECTED,
        0,
        "applied over Modbus"
    );
    // The reserved address is kept: the export (what a new page's form
    // reads) has both settings.
    let exported = rig.js("fetch('/api/config').then(r => r.json())");
    assert_eq!(exported["settings"]["access.plc_address"], "127.0.0.1");
    assert_eq!(exported["settings"]["access.modbus_config"], "true");
    rig.finish();
}

#[test]
fn an_invalid_value_shows_its_error_beside_the_field_and_changes_nothing() {
    let mut rig = WebRig::start("config-invalid");
    rig.wait_live();
    rig.set_first_password(PW);
    let before = rig.config_doc();
    rig.type_in("f-link.poll_ms", "5");
    rig.type_in("f-link.reply_timeout_ms", "2000");
    rig.type_in("f-network.mask", "255.0.255.0");
    rig.click("cfg-apply");
    rig.wait_data("cfg-msg", "result", "refused");
    assert_eq!(rig.text("e-link.poll_ms"), "out of range");
    assert_eq!(
        rig.text("e-network.mask"),
        "not a network mask (e.g. 255.255.255.0)"
    );
    assert_eq!(
        rig.text("e-link.reply_timeout_ms"),
        "",
        "a valid value has no error"
    );
    assert_eq!(
        rig.attr("f-link.poll_ms", "aria-invalid").as_deref(),
        Some("true")
    );
    let msg = rig.text("cfg-msg");
    assert!(
        msg.starts_with("Nothing was applied: 2 values refused"),
        "{msg}"
    );
    rig.shot("refused");

    // Nothing changed: not the valid value either, over Modbus and the API.
    let (poll, timeout, mask) = rig.modbus(async |plc| {
        (
            plc.read1(r::CONFIG_POLL_MS).await,
            plc.read1(r::CONFIG_REPLY_TIMEOUT_MS).await,
            plc.read(r::NET_MASK, 2).await,
        )
    });
    assert_eq!((poll, timeout), (100, 1000));
    assert_eq!(mask, [0xffff, 0xff00]);
    assert_eq!(rig.config_doc(), before);

    // Corrected, the same edit goes through and the errors go away.
    rig.type_in("f-link.poll_ms", "50");
    rig.type_in("f-network.mask", "255.255.0.0");
    rig.click("cfg-apply");
    rig.wait_data("cfg-msg", "result", "ok");
    assert_eq!(rig.text("e-link.poll_ms"), "");
    let (poll, timeout) = rig.modbus(async |plc| {
        (
            plc.read1(r::CONFIG_POLL_MS).await,
            plc.read1(r::CONFIG_REPLY_TIMEOUT_MS).await,
        )
    });
    assert_eq!((poll, timeout), (50, 2000));
    rig.shot("corrected");
    rig.finish();
}

#[test]
fn the_trigger_editor_stores_an_entry_that_fires_from_its_bit() {
    let mut rig = WebRig::start("trigger");
    rig.wait_live();
    rig.set_first_password(PW);
    rig.type_in("t-text-3", "SetBoxDO,2,1,;");
    rig.click("t-save-3");
    rig.wait_text("t-err-3", "entry 3 stored", |t| t.starts_with("stored"));
    // The grammar's refusal beside its entry; nothing stored there.
    rig.type_in("t-text-4", "Not a message");
    rig.click("t-save-4");
    rig.wait_text("t-err-4", "entry 4 refused", |t| !t.is_empty());
    assert_eq!(rig.text("t-err-4"), "not a protocol message: not stored");
    // Success and refusal in different colours (issue 27: both were red).
    assert_eq!(rig.style("t-err-3", "color"), GREEN);
    assert_eq!(rig.style("t-err-4", "color"), RED);
    rig.shot("edited");
    rig.shot_at("triggers", "stored-and-refused");

    let texts = rig.modbus(async |plc| {
        (
            plc.read(r::trigger_text(3), 8).await,
            plc.read(r::trigger_text(4), 1).await,
        )
    });
    assert_eq!(hans_e2e::words_text(&texts.0), "SetBoxDO,2,1,;");
    assert_eq!(texts.1, [0]);

    // Its bit fires it; Done over Modbus, the robot got it, the page shows it.
    let done = rig.modbus(async |plc| {
        plc.write(r::TRIG_BITS, &[1 << 3]).await;
        plc.wait_reg(r::TRIG_DONE, "trigger 3 Done", |v| v & (1 << 3) != 0)
            .await
    });
    assert_eq!(done & (1 << 3), 1 << 3);
    assert_eq!(
        rig.sim
            .received()
            .iter()
            .filter(|m| m.starts_with("SetBoxDO,2,1"))
            .count(),
        1
    );
    rig.wait_data("trig-3", "phase", "done");
    rig.wait_data("t-bit-3", "on", "1");
    rig.wait_text("io-box_do", "box DO2 on the page", |t| t.starts_with("○○●"));
    rig.wait_js(
        "the trigger in the command log",
        "[...document.querySelectorAll('#log-body tr[data-kind=command]')].some(t => \
         t.children[1].textContent === 'TRIG3' && t.children[4].textContent === 'Done')",
    );
    rig.shot("fired");
    rig.modbus(async |plc| plc.write(r::TRIG_BITS, &[0]).await);
    rig.wait_data("trig-3", "phase", "idle");
    rig.finish();
}

#[test]
fn export_then_import_gives_the_same_configuration() {
    let mut rig = WebRig::start("export-import");
    rig.wait_live();
    rig.set_first_password(PW);
    rig.type_in("f-link.poll_ms", "50");
    rig.type_in("f-access.modbus_allow", "127.0.0.0/8, 10.1.2.3");
    rig.click("cfg-apply");
    rig.wait_data("cfg-msg", "result", "ok");
    rig.type_in("t-text-0", "GrpStop,0,;");
    rig.click("t-save-0");
    rig.wait_text("t-err-0", "entry 0 stored", |t| t.starts_with("stored"));

    // Export: the page's link, fetched as the browser downloads it.
    assert_eq!(
        rig.attr("export", "download").as_deref(),
        Some("hans-gateway-config.json")
    );
    let exported = rig
        .js("fetch(document.getElementById('export').href).then(r => r.text())")
        .as_str()
        .expect("the export's text")
        .to_string();
    assert_eq!(exported, rig.config_doc());
    assert!(exported.contains(r#""link.poll_ms":"50""#), "{exported}");
    assert!(exported.contains(r#""GrpStop,0,;""#), "{exported}");
    let dir = hans_web_e2e::screenshot_dir().join("files");
    std::fs::create_dir_all(&dir).expect("a directory for the files");
    let file = dir.join("export-import-exported.json");
    std::fs::write(&file, &exported).expect("writing the export");
    rig.shot("exported");

    // Changed after the export ...
    rig.type_in("f-link.poll_ms", "70");
    rig.type_in("f-access.modbus_allow", "");
    rig.click("cfg-apply");
    rig.wait_text("cfg-msg", "the change after the export", |t| {
        t.starts_with("link.poll_ms, access.modbus_allow:")
    });
    rig.type_in("t-text-0", "");
    rig.click("t-save-0");
    rig.wait_for("entry 0 cleared", |r| {
        r.config_doc().contains(r#""triggers":["","#).then_some(())
    });
    assert_ne!(rig.config_doc(), exported);

    // ... and the import through the page's file input brings it back.
    rig.set_file("import-file", &file);
    rig.click("import-btn");
    rig.wait_data("import-msg", "result", "ok");
    assert_eq!(rig.config_doc(), exported);
    let (poll, trig0) = rig.modbus(async |plc| {
        (
            plc.read1(r::CONFIG_POLL_MS).await,
            plc.read(r::trigger_text(0), 8).await,
        )
    });
    assert_eq!(poll, 50);
    assert_eq!(hans_e2e::words_text(&trig0), "GrpStop,0,;");
    rig.wait_for("the form showing the import", |r| {
        (r.js("document.getElementById('f-link.poll_ms').value") == "50").then_some(())
    });
    rig.shot("imported");

    // A file with a bad value: refused with its reason, nothing applied.
    let bad = exported.replace(r#""link.poll_ms":"50""#, r#""link.poll_ms":"5""#);
    let bad_file = dir.join("export-import-bad.json");
    std::fs::write(&bad_file, bad).expect("writing the bad file");
    rig.set_file("import-file", &bad_file);
    rig.click("import-btn");
    rig.wait_data("import-msg", "result", "refused");
    assert!(rig.text("import-msg").starts_with("Nothing was applied"));
    assert_eq!(rig.text("e-link.poll_ms"), "out of range");
    assert_eq!(rig.config_doc(), exported);
    rig.shot("import-refused");
    rig.finish();
}

#[test]
fn a_fresh_device_asks_for_the_setup_code_and_wrong_passwords_show_the_wait() {
    let mut rig = WebRig::start("access");
    rig.wait_live();
    // Fresh: the page asks for the administrator first (with the setup
    // code), and nothing can change.
    // (The configuration form is drawn from /api/config, answered after
    // the status that shows the first-administrator form: waited for too.)
    rig.wait_for(
        "the first-administrator form and the configuration form",
        |r| {
            let drawn = r.js("document.getElementById('f-link.poll_ms') !== null")
                == serde_json::Value::Bool(true);
            (r.session() == "fresh" && r.visible("pw-first") && drawn).then_some(())
        },
    );
    for id in ["cfg-apply", "f-link.poll_ms", "t-save-0", "import-btn"] {
        assert!(rig.disabled(id), "#{id} usable before a password is set");
    }
    assert!(rig.text("access-flags").contains("NO ADMINISTRATOR"));
    rig.shot("fresh");
    // This gateway keeps nothing (no --config): the header says so, in
    // sight wherever the page is scrolled, and a note at the top says what
    // that means.
    assert!(rig.visible("keep"), "the storage chip");
    assert_eq!(rig.data("keep", "kept"), "no");
    assert!(rig.visible("keep-note"));
    assert!(rig.text("keep-note").contains("lost at every restart"));
    assert!(rig.text("audit-kept").starts_with("NOT kept"));
    // Whoever reaches the page first cannot claim it: a wrong code is
    // refused by the device; what was typed stays (issue 27: the page
    // cleared the fields), the code is marked.
    let value = |r: &WebRig, id: &str| {
        r.js(&format!("document.getElementById('{id}').value"))
            .as_str()
            .unwrap_or_default()
            .to_string()
    };
    rig.type_in("setup-code", "ABCD-EFGH-JKMP");
    rig.type_in("pw-new", "commission-1");
    rig.type_in("pw-new2", "commission-1");
    rig.click("pw-set");
    rig.wait_text("pw-first-msg", "the wrong code refused", |t| {
        t.contains("wrong setup code")
    });
    assert_eq!(rig.data("pw-first-msg", "result"), "refused");
    assert_eq!(value(&rig, "setup-code"), "ABCD-EFGH-JKMP");
    assert_eq!(value(&rig, "pw-new"), "commission-1");
    assert_eq!(
        rig.attr("setup-code", "aria-invalid").as_deref(),
        Some("true")
    );
    // Too short: the page says so before sending anything, and the setup
    // code typed stays.
    rig.type_in("setup-code", hans_web_e2e::SETUP_CODE);
    rig.type_in("pw-new", "short");
    rig.type_in("pw-new2", "short");
    rig.click("pw-set");
    rig.wait_text("pw-first-msg", "the length refused", |t| {
        t.contains("at least 10 characters")
    });
    assert!(
        rig.text("pw-first-msg").contains("nothing was sent"),
        "{}",
        rig.text("pw-first-msg")
    );
    assert_eq!(value(&rig, "setup-code"), hans_web_e2e::SETUP_CODE);
    assert_eq!(rig.attr("pw-new", "aria-invalid").as_deref(), Some("true"));
    assert_eq!(
        rig.attr("setup-code", "aria-invalid"),
        None,
        "the code is fine now"
    );
    rig.shot("setup-checked");
    // A code that cannot be one, and two passwords that differ: the same.
    rig.type_in("setup-code", "ABCD-EFGH");
    rig.type_in("pw-new", "commission-1");
    rig.click("pw-set");
    rig.wait_text("pw-first-msg", "the code's form refused", |t| {
        t.contains("the setup code: 12 letters")
    });
    rig.type_in("setup-code", hans_web_e2e::SETUP_CODE);
    rig.type_in("pw-new2", "commission-2");
    rig.click("pw-set");
    rig.wait_text("pw-first-msg", "the difference found", |t| {
        t.contains("differ")
    });
    assert_eq!(rig.session(), "fresh");
    // The page's checks cost no guess: the one wrong code was the only
    // one counted, and the device asks for no wait.
    let session = rig.http("GET", "/api/session", "");
    assert!(
        session.body.contains("\"retry_after_s\":0"),
        "{}",
        session.body
    );
    rig.set_first_password(PW);
    // The outcome stays in sight (issue 27: the panel vanished with it):
    // created, logged in, and not kept on this gateway.
    assert!(rig.visible("pw-first"));
    assert_eq!(rig.data("pw-first", "done"), "not-kept");
    assert_eq!(rig.data("pw-first-msg", "result"), "ok");
    assert!(rig
        .text("pw-first-msg")
        .contains("Administrator admin created"));
    assert!(rig.visible("pw-first-keep"));
    assert!(!rig.visible("pw-first-form"));
    rig.shot("setup-done");
    // The audit log is read again as the session opens (issue 27: it said
    // "log in first" until Reload was clicked; the page's own reload comes
    // every 15 s, so this must happen well before).
    let audit_rows = |r: &WebRig| {
        (r.js("document.querySelector('#audit-body tr[data-kind=account-created]') !== null")
            == serde_json::Value::Bool(true))
        .then_some(())
    };
    rig.wait_for_in("the audit log after the login", AT_ONCE, audit_rows);
    rig.shot_at("audit", "audit-after-login");
    rig.click("pw-first-close");
    rig.wait_for("the setup panel closed", |r| {
        (!r.visible("pw-first")).then_some(())
    });
    assert!(!rig.disabled("cfg-apply") && !rig.disabled("t-save-0"));
    rig.wait_text(
        "access-flags",
        "the status showing the administrator",
        |t| t.contains("administrator set"),
    );
    assert!(rig
        .text("session-text")
        .contains("Logged in as admin (admin)"));
    // The administrator adds a viewer; the list shows it.
    rig.wait_for("the accounts list", |r| {
        r.visible("accounts-box").then_some(())
    });
    rig.type_in("acc-name", "night-shift");
    rig.choose("acc-role", "viewer");
    rig.type_in("acc-pw", "read only please");
    rig.click("acc-add");
    rig.wait_data("acc-msg", "result", "ok");
    rig.wait_for("the viewer in the list", |r| {
        (r.js("document.querySelector('#accounts-body tr[data-name=\"night-shift\"]') !== null")
            == serde_json::Value::Bool(true))
        .then_some(())
    });
    rig.shot("accounts");

    // Logged out: a login form, changes locked again, the audit log gone
    // at once.
    rig.click("logout-btn");
    rig.wait_for("the login form", |r| {
        (r.session() == "login" && r.visible("login-form")).then_some(())
    });
    assert!(rig.disabled("cfg-apply"));
    rig.wait_for_in("the audit log closed", AT_ONCE, |r| {
        r.text("audit-body").contains("log in first").then_some(())
    });
    rig.type_in("login-name", "admin");
    // Wrong passwords: after three the page shows the wait and holds the
    // button until it is over.
    let mut tries = 0;
    rig.wait_for("the rate limit's wait on the page", |r| {
        if r.data("login-msg", "wait").parse::<u32>().unwrap_or(0) > 0 {
            return Some(());
        }
        if !r.disabled("login-btn") && tries < 8 {
            tries += 1;
            let before = r.data("login-msg", "answers");
            r.type_in("login-pw", "not-the-password");
            r.click("login-btn");
            // The answer takes a hash's time: wait for it (bounded).
            let start = std::time::Instant::now();
            while r.data("login-msg", "answers") == before && start.elapsed() < hans_web_e2e::WAIT {
                std::thread::sleep(hans_web_e2e::PAGE_POLL);
            }
        }
        None
    });
    assert!(tries >= 3, "the wait came after {tries} wrong passwords");
    let msg = rig.text("login-msg");
    assert!(msg.starts_with("Too many wrong attempts: wait "), "{msg}");
    assert!(rig.disabled("login-btn"));
    rig.shot_at("access", "wait");
    // Another client from the same address gets 429 with the wait: the
    // limit is the address's, not the page's. (Each wrong try after the third doubles the wait, so
    // a try that came just after a wait ended is answered 401 and the next
    // one 429.)
    let mut answers = Vec::new();
    for _ in 0..4 {
        let a = rig.http(
            "POST",
            "/api/login",
            r#"{"name":"admin","password":"not-the-password"}"#,
        );
        let limited = a.status == 429;
        answers.push(a);
        if limited {
            break;
        }
    }
    let last = answers.last().expect("an answer");
    assert_eq!(last.status, 429, "{answers:?}");
    assert!(last.body.contains("\"retry_after_s\":"), "{}", last.body);
    // Once the wait is over (the device says so, and the page lets the
    // button go), the right password opens a session.
    rig.wait_for("the device's wait to end", |r| {
        let s = r.http("GET", "/api/session", "");
        s.body.contains("\"retry_after_s\":0").then_some(())
    });
    rig.wait_for("the page's wait to end", |r| {
        (!r.disabled("login-btn")).then_some(())
    });
    rig.type_in("login-pw", PW);
    rig.click("login-btn");
    rig.wait_for("logged in", |r| (r.session() == "open").then_some(()));
    rig.wait_for_in("the audit log after the login form", AT_ONCE, audit_rows);

    // Change the password, log out, log in with the new one.
    rig.type_in("pw-cur", PW);
    rig.type_in("pw-chg-new", "commission-2027");
    rig.type_in("pw-chg-new2", "commission-2027");
    rig.click("pw-chg-btn");
    rig.wait_data("access-msg", "result", "ok");
    rig.click("logout-btn");
    rig.wait_for("the login form", |r| (r.session() == "login").then_some(()));
    rig.type_in("login-pw", "commission-2027");
    rig.click("login-btn");
    rig.wait_for("logged in with the new password", |r| {
        (r.session() == "open").then_some(())
    });
    rig.shot("logged-in");
    rig.finish();
}

/// Issue 27: the inactive "emergency stop", "safety guard" and "error"
/// chips were drawn in red (read as an active E-stop). Off they are grey
/// like every flag that is off; on they are solid red with white capitals,
/// unlike any other chip.
#[test]
fn safety_flags_are_grey_while_off_and_unmistakable_while_on() {
    let mut rig = WebRig::start("safety-flags");
    rig.wait_live();
    rig.wait_data("flags-enabled", "on", "1");
    let safety = ["flags-emergency_stop", "flags-safety_guard", "flags-error"];
    for id in safety {
        assert_eq!(rig.data(id, "on"), "0", "{id}");
        assert_eq!(rig.style(id, "color"), GREY, "{id} off");
        assert_eq!(
            rig.style(id, "background-color"),
            "rgba(0, 0, 0, 0)",
            "{id} off"
        );
    }
    // A flag that is on and is no alarm: green, as before.
    assert_eq!(rig.style("flags-enabled", "color"), GREEN);
    rig.shot_at("c-robot", "off");

    rig.sim.set_emergency_stop(true);
    rig.sim.set_safety_guard(true);
    rig.wait_data("flags-emergency_stop", "on", "1");
    rig.wait_data("flags-safety_guard", "on", "1");
    for id in ["flags-emergency_stop", "flags-safety_guard"] {
        assert_eq!(rig.style(id, "background-color"), RED, "{id} on");
        assert_eq!(rig.style(id, "color"), WHITE, "{id} on");
        assert_eq!(rig.style(id, "text-transform"), "uppercase", "{id} on");
    }
    assert_eq!(rig.style("flags-error", "color"), GREY, "error still off");
    rig.shot_at("c-robot", "on");
    rig.sim.set_emergency_stop(false);
    rig.sim.set_safety_guard(false);
    rig.wait_data("flags-emergency_stop", "on", "0");
    assert_eq!(rig.style("flags-emergency_stop", "color"), GREY);
    rig.finish();
}

/// Issue 27: a name the device does not answer to (DNS rebinding) got raw
/// JSON 421 in the browser. The browser gets a page that says why and
/// links the address to use, which then shows the live page. The browser
/// maps `gw.localhost` to 127.0.0.1 (`cdp`'s switches; no DNS involved,
/// and not ::1, where the gateway does not listen).
#[test]
fn a_refused_host_name_gets_a_page_that_links_the_address_to_use() {
    let mut rig = WebRig::start("refused-name");
    rig.wait_live();
    let port = rig.web.port();
    let refused = format!("http://gw.localhost:{port}/");
    rig.tab
        .navigate_to(&refused)
        .and_then(|t| t.wait_until_navigated())
        .unwrap_or_else(|e| panic!("opening {refused}: {e:#}"));
    let heading = rig.js("document.querySelector('h1').textContent");
    assert_eq!(heading, "Open this gateway by its address");
    let body = rig.js("document.body.textContent");
    let body = body.as_str().unwrap_or_default();
    assert!(
        body.contains("does not answer to the name gw.localhost"),
        "{body}"
    );
    let link = rig.js("document.querySelector('a').href");
    let to = format!("http://127.0.0.1:{port}/");
    assert_eq!(link, serde_json::Value::String(to.clone()));
    rig.shot("page");
    // Followed, the link opens the gateway's page, live.
    rig.js("document.querySelector('a').click()");
    rig.wait_js(
        "the gateway's page",
        &format!(
            "location.href === {:?} && document.getElementById('conn') !== null",
            to
        ),
    );
    rig.wait_live();
    rig.finish();
}

/// Issue 27: whether a device keeps what is changed must be in sight.
/// Kept (a configuration file): no chip, no note, the audit log says kept,
/// and creating the administrator says nothing of losing it.
#[test]
fn a_gateway_that_keeps_its_configuration_shows_no_warning() {
    let mut rig = WebRig::start_kept("kept");
    rig.wait_live();
    rig.wait_for("the status read", |r| {
        (!r.data("keep", "kept").is_empty()).then_some(())
    });
    assert_eq!(rig.data("keep", "kept"), "yes");
    assert!(!rig.visible("keep"), "no chip where everything is kept");
    assert!(!rig.visible("keep-note"));
    assert_eq!(rig.text("audit-kept"), "Kept across restarts");
    rig.set_first_password(PW);
    assert_eq!(rig.data("pw-first", "done"), "kept");
    assert!(rig.visible("pw-first-msg"));
    assert!(!rig.visible("pw-first-keep"));
    rig.shot("setup-done");
    rig.finish();
}

/// The audit panel's rows shown (their sequence numbers, top to bottom).
fn audit_seqs(rig: &WebRig) -> Vec<u64> {
    let v = rig.js(
        "Array.from(document.querySelectorAll('#audit-body tr[data-seq]')).map(tr => Number(tr.dataset.seq))",
    );
    v.as_array()
        .map(|a| a.iter().filter_map(|s| s.as_u64()).collect())
        .unwrap_or_default()
}

/// Issue 25: the audit panel showed the newest records only (the RAM
/// ring's 64). Now "Older" pages back through what the gateway keeps (its
/// audit file here), to the first record: each record once, newest first,
/// and the panel says when the first is shown.
#[test]
fn the_audit_panel_pages_back_to_the_first_record() {
    let mut rig = WebRig::start_kept("audit-older");
    rig.wait_live();
    rig.set_first_password(PW);
    // Seven changes of nine settings (between two sets of values): a
    // record per setting, 63 in all.
    for change in 0..7u32 {
        let round = change % 2;
        let settings = [
            ("link.poll_ms", (50 + round * 10).to_string()),
            ("link.reply_timeout_ms", (900 + round * 100).to_string()),
            ("watchdog.period_ms", (700 + round * 100).to_string()),
            ("mqtt.keep_alive_s", (45 + round).to_string()),
            ("mqtt.period_ms", (300 + round * 100).to_string()),
            ("mqtt.group_id", format!("plant{round}")),
            ("mqtt.edge_id", format!("gw{round}")),
            ("mqtt.primary_host", format!("scada{round}")),
            ("motion.start_grace_ms", (400 + round * 100).to_string()),
        ];
        let body = settings
            .iter()
            .map(|(k, v)| format!("\"{k}\":\"{v}\""))
            .collect::<Vec<_>>()
            .join(",");
        let status = rig.js(&format!(
            "api('POST', '/api/config', JSON.stringify({{settings: {{{body}}}}})).then(r => r.status)"
        ));
        assert_eq!(status, serde_json::json!(200), "change {change}");
    }
    rig.click("audit-reload");
    rig.wait_for_in("the newest page, with Older", AT_ONCE, |r| {
        (r.visible("audit-older") && audit_seqs(r).len() >= 32).then_some(())
    });
    assert!(!rig.visible("audit-end"));
    let newest = audit_seqs(&rig);
    assert!(newest.windows(2).all(|w| w[0] > w[1]), "{newest:?}");
    rig.shot_at("audit", "audit-newest");
    let mut pages = 1;
    while rig.visible("audit-older") {
        let shown = audit_seqs(&rig).len();
        rig.click("audit-older");
        rig.wait_for_in("an older page below", AT_ONCE, |r| {
            (audit_seqs(r).len() > shown).then_some(())
        });
        pages += 1;
        assert!(pages < 10, "no end after {pages} pages");
    }
    rig.wait_for_in("the end said", AT_ONCE, |r| {
        r.visible("audit-end").then_some(())
    });
    assert!(pages >= 3, "{pages} pages");
    let all = audit_seqs(&rig);
    // Every record once, newest first, down to the first.
    assert_eq!(all.last(), Some(&1), "{all:?}");
    assert!(all.windows(2).all(|w| w[0] == w[1] + 1), "{all:?}");
    assert!(all.len() > 63, "{}", all.len());
    assert_eq!(
        rig.js("document.querySelector('#audit-body tr[data-seq=\"1\"]').dataset.kind"),
        serde_json::json!("start")
    );
    // The whole page: every page walked, down to record 1 and the note.
    rig.shot("audit-oldest");
    rig.finish();
}
