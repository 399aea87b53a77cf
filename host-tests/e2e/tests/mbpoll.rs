//! The scripted PLC session with `mbpoll` (Debian; `scripts/setup.sh`
//! installs it) against the gateway and hans-sim.

use std::process::Command;

use hans_e2e::Rig;
use hans_sim::Config;

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn mbpoll_scenario() {
    assert!(
        Command::new("mbpoll").arg("-V").output().is_ok(),
        "mbpoll is not installed (run scripts/setup.sh)"
    );
    let rig = Rig::start(Config::ready()).await;
    let addr = rig.gw.modbus_addr();
    let script = concat!(env!("CARGO_MANIFEST_DIR"), "/scripts/mbpoll-scenario.sh");
    let out = tokio::task::spawn_blocking(move || {
        Command::new("timeout")
            .args([
                "60",
                "bash",
                script,
                &addr.ip().to_string(),
                &addr.port().to_string(),
            ])
            .output()
            .expect("run the scenario")
    })
    .await
    .expect("join");
    let text =
        String::from_utf8_lossy(&out.stdout).into_owned() + &String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "scenario failed: {text}");
    assert!(text.contains("mbpoll scenario: ok"));
    assert_eq!(rig.received("SetBoxDO"), ["SetBoxDO,4,1,;"]);
    assert_eq!(rig.received("MoveRelJ"), ["MoveRelJ,0,0,1,2.000,;"]);
    assert!(rig
        .received("ReadActPos")
        .iter()
        .any(|m| m == "ReadActPos,0,;"));
    assert!(rig.sim.io().do_[4]);
    rig.stop().await;
}
