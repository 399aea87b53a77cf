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

/// Finding (doc): CONFIG_COMMAND = 0 was accepted though REGISTERS.md said
/// every value but 1-3 gives exception 03. 0 is "no action" (a block write
/// over 140-141 carries it); 4 and above are refused and change nothing.
#[tokio::test]
async fn config_command_0_does_nothing_and_4_is_refused() {
    use tokio_modbus::client::Writer;
    use tokio_modbus::ExceptionCode;

    let mut rig = Rig::start(Config::ready()).await;
    let plc = &mut rig.plc;
    let before = plc.read(r::CONTROL_CONFIG_RESULT, 3).await;
    plc.write(r::CONFIG_POLL_MS, &[70]).await;
    // Heartbeat and command in one write.
    plc.write(r::CONTROL_HEARTBEAT, &[5, 0]).await;
    assert_eq!(plc.read(r::CONTROL_CONFIG_RESULT, 3).await, before);
    assert_eq!(
        plc.read1(r::CONFIG_POLL_MS).await,
        70,
        "edit not applied nor discarded"
    );
    let e = plc
        .ctx
        .write_multiple_registers(r::CONTROL_HEARTBEAT, &[6, 4])
        .await
        .expect("transport");
    assert_eq!(e, Err(ExceptionCode::IllegalDataValue));
    assert_eq!(
        plc.read1(r::CONTROL_HEARTBEAT).await,
        5,
        "nothing of the write done"
    );
    rig.stop().await;
}
