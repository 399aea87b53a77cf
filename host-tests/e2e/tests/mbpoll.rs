//! The scripted PLC session with `mbpoll` (Debian; `scripts/setup.sh`
//! installs it) against the gateway and hans-sim.

use std::process::Command;

use hans_e2e::{code, Rig};
use hans_gateway::registers as r;
use hans_sim::Config;

/// The longest the scenario may take (it waits up to 20 s for each
/// command's end itself).
const SCENARIO_TIMEOUT_S: u32 = 60;

/// The addresses, bits and codes the scenario script uses, from the map
/// itself (the script's defaults are copies).
fn map_env() -> Vec<(&'static str, String)> {
    let ch0 = r::channel_base(0);
    let v = |x: u16| x.to_string();
    vec![
        ("STATUS_VERSION", v(r::STATUS_VERSION)),
        ("VERSION", v(hans_gateway::registers::MAP_VERSION)),
        ("STATUS_LINK_STATE", v(r::STATUS_LINK_STATE)),
        ("CH0", v(ch0 + r::CH_CONTROL)),
        ("CH0_PARAMS", v(ch0 + r::CH_PARAMS)),
        ("CH0_STATUS", v(ch0 + r::CH_STATUS)),
        ("RAW_CONTROL", v(r::RAW_CONTROL)),
        ("RAW_STATUS", v(r::RAW_STATUS)),
        ("RAW_REPLY", v(r::RAW_REPLY)),
        ("ST_DONE", v(r::ST_DONE)),
        ("ST_ENDED", v(r::ST_DONE | r::ST_ERROR | r::ST_ABORTED)),
        ("CODE_SET_BOX_DO", v(code::SET_BOX_DO)),
        ("CODE_MOVE_REL_J", v(code::MOVE_REL_J)),
    ]
}

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
            .envs(map_env())
            .args([
                &SCENARIO_TIMEOUT_S.to_string(),
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
