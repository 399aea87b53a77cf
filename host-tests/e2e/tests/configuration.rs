//! The configuration registers end to end (PLC -> gateway, robot
//! hans-sim, all on 127.0.0.1): what CONFIG_COMMAND reports.

use hans_e2e::Rig;
use hans_gateway::registers as r;
use hans_sim::Config;

/// Finding M5: without persistent storage (the host binary without
/// `--config`), CONFIG_COMMAND = 1 reported "saved" (CONFIG_RESULT 0,
/// CONFIG_SAVES + 1) though nothing was saved. It must say "applied, not
/// saved" (3) and not count a save; the configuration is applied.
#[tokio::test]
async fn without_storage_a_configuration_is_applied_but_not_reported_saved() {
    let mut rig = Rig::start(Config::ready()).await;
    let plc = &mut rig.plc;
    let result = plc.configure(&[(r::CONFIG_POLL_MS, 40)]).await;
    assert_eq!(result, 3, "CONFIG_RESULT: applied, not saved");
    assert_eq!(plc.read1(r::CONTROL_SAVES).await, 0, "CONFIG_SAVES");
    // Applied all the same: discarding edits shows the active value.
    plc.write(r::CONFIG_POLL_MS, &[60]).await;
    plc.write(r::CONTROL_CONFIG_COMMAND, &[2]).await;
    assert_eq!(plc.read1(r::CONFIG_POLL_MS).await, 40);
    rig.stop().await;
}
