//! Every rule of REGISTERS.md's handshake and "Behaviour and bounds"
//! sections, one test each, in virtual time: the real gateway future on a
//! simulated network with a scripted robot (`hans_gateway::testkit`). No
//! sockets, no sleeps: a test of minutes of robot time runs in
//! milliseconds, and runs the same every time.

use core::net::Ipv4Addr;

use embassy_time::{Duration, Instant};
use hans_gateway::config::Config;
use hans_gateway::error::GatewayError;
use hans_gateway::job::code;
use hans_gateway::registers as r;
use hans_gateway::state::LinkState;
use hans_gateway::testkit::plc::{pdu, Answer};
use hans_gateway::testkit::robot::{Fault, Model};
use hans_gateway::testkit::world::{World, WorldConfig, ROBOT_IP, ROBOT_PORT};

const CH0: u16 = r::CHANNEL_BASE;
const CH1: u16 = r::CHANNEL_BASE + r::CHANNEL_STRIDE;

fn ms(v: u64) -> Duration {
    Duration::from_millis(v)
}

/// A world whose gateway is connected and has its first status round.
fn world_with(config: WorldConfig) -> World {
    let mut w = World::new(config);
    w.run_for(ms(300));
    w
}

fn world() -> World {
    world_with(WorldConfig::default())
}

fn f32_words(v: f32) -> [u16; 2] {
    let b = v.to_bits();
    [(b >> 16) as u16, b as u16]
}

/// Writes a channel's code, sequence and parameters, then raises Execute
/// (two writes, as most PLCs do it).
fn fire(w: &mut World, ch: u16, code: u16, seq: u16, params: &[f32]) {
    let mut words = vec![0, code, seq, 0];
    for p in params {
        words.extend(f32_words(*p));
    }
    w.set(ch, &words);
    w.set(ch, &[1]);
}

fn status(w: &mut World, ch: u16) -> u16 {
    w.reg(ch + r::CH_STATUS)
}

/// (ErrorID, error source) of a channel.
fn error(w: &mut World, ch: u16) -> (i32, u16) {
    let v = w.read(ch + r::CH_ERROR_ID, 3).expect("read");
    ((((v[0] as u32) << 16) | v[1] as u32) as i32, v[2])
}

/// Runs until the channel's command is no longer Busy; its status.
fn wait_end(w: &mut World, ch: u16, limit: Duration) -> u16 {
    let ended = w.run_until_cond(limit, |w| {
        let s = w.reg(ch + r::CH_STATUS);
        s != 0 && s & r::ST_BUSY == 0
    });
    assert!(ended, "channel {ch}: still busy after {limit:?}");
    status(w, ch)
}

fn sent(w: &World, name: &str) -> usize {
    w.robot
        .log
        .iter()
        .filter(|m| m.text.starts_with(name))
        .count()
}

fn gateway_err(e: GatewayError) -> (i32, u16) {
    (e.code(), 3)
}

const MOVE: [f32; 2] = [0.0, 5.0]; // MoveRelJ: axis 0, +5°

// ------------------------------------------------------------- handshake

#[test]
fn busy_is_visible_on_the_first_read_after_the_execute_write() {
    let mut w = world();
    w.robot.model.motion_time = ms(500);
    fire(&mut w, CH0, code::MOVE_REL_J, 7, &MOVE);
    // No time passes between the write's answer and this read.
    let s = status(&mut w, CH0);
    assert_ne!(s & r::ST_BUSY, 0, "status {s:#x}");
    assert_eq!(w.reg(CH0 + r::CH_SEQ_ECHO), 7);
}

#[test]
fn outputs_stay_until_execute_falls_and_echoes_until_the_next_edge() {
    let mut w = world();
    fire(&mut w, CH0, code::READ_ACT_POS, 3, &[]);
    assert_eq!(wait_end(&mut w, CH0, ms(500)), r::ST_DONE);
    w.run_for(ms(1000));
    assert_eq!(
        status(&mut w, CH0),
        r::ST_DONE,
        "Done stays while Execute is high"
    );
    let r0 = w.read(CH0 + r::CH_RESULTS + 4, 2).unwrap();
    assert_eq!(r0, f32_words(90.0), "R2 = J3");
    w.set(CH0, &[0]);
    assert_eq!(status(&mut w, CH0), 0);
    assert_eq!(w.reg(CH0 + r::CH_SEQ_ECHO), 3, "the echo stays");
    assert_eq!(w.read(CH0 + r::CH_RESULTS + 4, 2).unwrap(), f32_words(90.0));
    // The next rising edge clears the results (NaN until its results come).
    w.robot.script.push_back(Fault::NoReply);
    fire(&mut w, CH0, code::READ_ACT_POS, 4, &[]);
    assert_eq!(w.read(CH0 + r::CH_RESULTS, 2).unwrap(), [0x7FC0, 0]);
}

#[test]
fn a_rising_edge_while_busy_is_ignored() {
    let mut w = world();
    w.robot.model.motion_time = ms(500);
    fire(&mut w, CH0, code::MOVE_REL_J, 1, &MOVE);
    w.set(CH0, &[0]);
    fire(&mut w, CH0, code::MOVE_REL_J, 2, &MOVE);
    assert_eq!(w.reg(CH0 + r::CH_SEQ_ECHO), 1);
    wait_end(&mut w, CH0, ms(2000));
    assert_eq!(sent(&w, "MoveRelJ"), 1, "the second edge sent nothing");
}

#[test]
fn execute_falling_while_busy_keeps_the_outcome_until_the_next_edge() {
    let mut w = world();
    fire(&mut w, CH0, code::MOVE_REL_J, 1, &MOVE);
    w.set(CH0, &[0]);
    assert_eq!(wait_end(&mut w, CH0, ms(2000)), r::ST_DONE);
    w.run_for(ms(500));
    assert_eq!(status(&mut w, CH0), r::ST_DONE);
}

// ----------------------------------------------------------------- motion

#[test]
fn a_motion_is_done_when_the_robot_has_finished_it_with_final_positions() {
    let mut w = world();
    w.robot.model.motion_time = ms(400);
    let t0 = w.now();
    fire(&mut w, CH0, code::MOVE_REL_J, 1, &MOVE);
    w.run_for(ms(5));
    assert_ne!(
        status(&mut w, CH0) & r::ST_ACTIVE,
        0,
        "Active while it moves"
    );
    w.robot.model.joints = [1, 2, 3, 4, 5, 6];
    assert_eq!(wait_end(&mut w, CH0, ms(2000)), r::ST_DONE);
    let took = w.now().saturating_duration_since(t0);
    assert!(took >= ms(400), "Done before the motion ended ({took:?})");
    // Done within one motion poll and a few round trips of the moment the
    // robot's flag says the motion ended (400 ms, and its 30 ms lag).
    assert!(
        took < ms(400 + 30 + 10 + 5),
        "Done {took:?} after the start of a 400 ms motion"
    );
    assert_eq!(
        w.read(r::STATUS_JOINTS, 2).unwrap(),
        f32_words(1.0),
        "ACT_JOINTS final at Done"
    );
    // The last messages: the FSM checked, then the position read.
    let tail: Vec<&str> = w
        .robot
        .log
        .iter()
        .rev()
        .take(2)
        .map(|m| m.text.as_str())
        .collect();
    assert_eq!(tail, ["ReadActPos,0,;", "ReadCurFSM,0,;"]);
}

#[test]
fn a_lagging_moving_flag_does_not_end_the_motion_early() {
    let mut w = world();
    w.robot.model.flag_lag = ms(150); // longer than some polls, shorter than the grace
    w.robot.model.motion_time = ms(600);
    let t0 = w.now();
    fire(&mut w, CH0, code::MOVE_REL_J, 1, &MOVE);
    assert_eq!(wait_end(&mut w, CH0, ms(3000)), r::ST_DONE);
    assert!(w.now().saturating_duration_since(t0) >= ms(600));
}

#[test]
fn pause_keeps_the_motion_busy_until_continue() {
    let mut w = world();
    w.robot.model.motion_time = ms(400);
    fire(&mut w, CH0, code::MOVE_REL_J, 1, &MOVE);
    w.run_for(ms(100));
    fire(&mut w, CH1, code::PAUSE, 1, &[]);
    w.run_for(ms(2000));
    assert_ne!(status(&mut w, CH0) & r::ST_BUSY, 0, "paused: still Busy");
    w.set(CH1, &[0]);
    fire(&mut w, CH1, code::CONTINUE, 2, &[]);
    assert_eq!(wait_end(&mut w, CH0, ms(2000)), r::ST_DONE);
}

#[test]
fn a_refused_motion_ends_in_error_with_the_robots_code() {
    let mut w = world();
    w.robot.script.push_back(Fault::Fail(20018));
    fire(&mut w, CH0, code::MOVE_REL_J, 1, &MOVE);
    assert_eq!(wait_end(&mut w, CH0, ms(500)), r::ST_ERROR);
    assert_eq!(error(&mut w, CH0), (20018, 1));
}

#[test]
fn robot_faults_during_a_motion_end_it_with_their_codes() {
    let mut w = world();
    w.robot.model.motion_time = ms(1000);
    fire(&mut w, CH0, code::MOVE_REL_J, 1, &MOVE);
    w.run_for(ms(200));
    w.robot.model.error = Some(10005);
    w.robot.model.fsm = 22;
    assert_eq!(wait_end(&mut w, CH0, ms(500)), r::ST_ERROR);
    assert_eq!(error(&mut w, CH0), (10005, 2));
    for (fault, code) in [
        (1, GatewayError::EmergencyStop),
        (2, GatewayError::SafetyGuard),
    ] {
        let mut w = world();
        fire(&mut w, CH0, code::MOVE_REL_J, 1, &MOVE);
        w.run_for(ms(100));
        if fault == 1 {
            w.robot.model.estop = true;
        } else {
            w.robot.model.guard = true;
        }
        assert_eq!(wait_end(&mut w, CH0, ms(500)), r::ST_ERROR);
        assert_eq!(error(&mut w, CH0), gateway_err(code));
    }
}

// ------------------------------------------------------------ stop, queue

#[test]
fn stop_aborts_the_running_and_the_waiting_motions_and_none_is_sent() {
    let mut w = world();
    w.robot.model.motion_time = ms(1000);
    fire(&mut w, CH0, code::MOVE_REL_J, 1, &MOVE);
    w.run_for(ms(5)); // the motion runs
                      // An output goes out during the motion; a RAW motion waits behind it.
    fire(&mut w, CH1, code::SET_BOX_DO, 1, &[1.0, 1.0]);
    let raw = "MoveRelJ,0,1,1,5,;";
    w.set(r::RAW_REQUEST, &text_words(raw, r::RAW_REQUEST_REGS));
    w.set(r::RAW_CONTROL, &[1]);
    w.run_for(ms(5));
    assert_eq!(status(&mut w, CH1), r::ST_DONE, "the output went out");
    assert_eq!(w.reg(r::STATUS_QUEUE_USED), 1, "the motion waits");
    w.set(CH1, &[0]);
    fire(&mut w, CH1, code::STOP, 2, &[]);
    assert_eq!(wait_end(&mut w, CH1, ms(500)), r::ST_DONE);
    assert_eq!(status(&mut w, CH0), r::ST_ABORTED);
    assert_eq!(w.reg(r::RAW_STATUS), r::ST_ABORTED);
    w.run_for(ms(2000));
    assert_eq!(sent(&w, "MoveRelJ"), 1, "the waiting motion was never sent");
    // A motion fired after the Stop runs normally.
    w.set(CH0, &[0]);
    fire(&mut w, CH0, code::MOVE_REL_J, 2, &MOVE);
    assert_eq!(wait_end(&mut w, CH0, ms(3000)), r::ST_DONE);
}

/// `t` as registers (two characters each, NUL-terminated), at most `regs`.
fn text_words(t: &str, regs: u16) -> Vec<u16> {
    let b = t.as_bytes();
    (0..usize::from(regs).min(b.len() / 2 + 1))
        .map(|i| {
            let at = |k: usize| u16::from(b.get(k).copied().unwrap_or(0));
            (at(2 * i) << 8) | at(2 * i + 1)
        })
        .collect()
}

/// Fills trigger entries 0..n with `text` and fires them all at once.
fn fire_triggers(w: &mut World, n: u16, text: &str) {
    for i in 0..n {
        w.set(r::trigger_text(usize::from(i)), &text_words(text, 32));
    }
    w.set(r::TRIG_BITS, &[((1u32 << n) - 1) as u16]);
}

#[test]
fn the_queue_holds_eight_and_the_ninth_ends_at_once_in_39600() {
    let mut w = world();
    w.robot.model.motion_time = ms(5000);
    fire(&mut w, CH0, code::MOVE_REL_J, 1, &MOVE);
    w.run_for(ms(5)); // the motion runs
                      // Nine motions behind the running one: eight wait, the ninth is refused.
    fire_triggers(&mut w, 9, "MoveRelJ,0,1,1,5,;");
    assert_eq!(w.reg(r::STATUS_QUEUE_USED), 8);
    assert_eq!(w.reg(r::TRIG_BUSY), 0xFF);
    assert_eq!(w.reg(r::TRIG_ERROR), 1 << 8);
    let id = w.read(r::TRIG_ERROR_ID + 16, 2).unwrap();
    assert_eq!(id, [0, 39600]);
}

#[test]
fn urgent_commands_pass_a_full_queue_in_the_order_fired() {
    let mut w = world();
    w.robot.model.motion_time = ms(5000);
    fire(&mut w, CH0, code::MOVE_REL_J, 1, &MOVE);
    w.run_for(ms(5)); // the motion runs
    fire_triggers(&mut w, 8, "SetBoxDO,1,1,;");
    // Hold the robot's reply to the first output so the queue stays full.
    w.robot.script.clear();
    // Pause from RAW (with blanks: sent canonical), then Continue from CH1.
    w.set(
        r::RAW_REQUEST,
        &text_words("GrpInterrupt, 0 ,;", r::RAW_REQUEST_REGS),
    );
    w.set(r::RAW_CONTROL, &[1]);
    fire(&mut w, CH1, code::CONTINUE, 1, &[]);
    w.run_for(ms(200));
    assert_eq!(w.reg(r::RAW_STATUS), r::ST_DONE);
    assert_eq!(status(&mut w, CH1), r::ST_DONE);
    let order: Vec<&str> = w
        .robot
        .log
        .iter()
        .map(|m| m.text.as_str())
        .filter(|t| t.starts_with("Grp"))
        .collect();
    assert_eq!(order, ["GrpInterrupt,0,;", "GrpContinue,0,;"]);
}

#[test]
fn while_a_motion_runs_other_commands_go_out_but_a_motion_waits() {
    let mut w = world();
    w.robot.model.motion_time = ms(500);
    fire(&mut w, CH0, code::MOVE_REL_J, 1, &MOVE);
    w.run_for(ms(5)); // the motion runs
    fire_triggers(&mut w, 2, "SetBoxDO,2,1,;");
    w.set(
        r::RAW_REQUEST,
        &text_words("MoveRelJ,0,1,1,5,;", r::RAW_REQUEST_REGS),
    );
    w.set(r::RAW_CONTROL, &[1]);
    w.run_for(ms(50));
    assert_eq!(
        w.reg(r::TRIG_DONE),
        0b11,
        "outputs went out during the motion"
    );
    assert_ne!(
        w.reg(r::RAW_STATUS) & r::ST_QUEUED,
        0,
        "the second motion waits"
    );
    assert_eq!(wait_end(&mut w, CH0, ms(2000)), r::ST_DONE);
    w.run_until_cond(ms(2000), |w| w.reg(r::RAW_STATUS) == r::ST_DONE);
    assert_eq!(w.reg(r::RAW_STATUS), r::ST_DONE);
}

// -------------------------------------------------------------- bring-up

#[test]
fn power_on_and_enable_are_done_when_the_robot_reaches_their_states() {
    let mut w = world_with(WorldConfig::default());
    w.robot.model = Model::powered_off();
    w.robot.model.step_time = ms(400);
    fire(&mut w, CH0, code::POWER_ON, 1, &[]);
    assert_eq!(wait_end(&mut w, CH0, ms(5000)), r::ST_DONE);
    assert_eq!(w.reg(r::STATUS_FSM), 24, "Disable: controller connected");
    let steps: Vec<&str> = w
        .robot
        .log
        .iter()
        .map(|m| m.text.as_str())
        .filter(|t| !t.starts_with("Read") && !t.starts_with("PackageVersion"))
        .collect();
    assert_eq!(steps, ["ConnectToBox,;", "Electrify,;", "StartMaster,;"]);
    w.set(CH0, &[0]);
    fire(&mut w, CH0, code::ENABLE, 2, &[]);
    assert_eq!(wait_end(&mut w, CH0, ms(5000)), r::ST_DONE);
    assert_eq!(w.reg(r::STATUS_FSM), 33);
    assert_ne!(
        w.reg(r::STATUS_FLAGS) & r::FLAG_ENABLED,
        0,
        "flags agree at Done"
    );
}

#[test]
fn a_bring_up_step_that_never_arrives_ends_in_39607_after_30_s_and_only_urgent_passes() {
    let mut w = world();
    w.robot.model = Model::powered_off();
    w.robot.model.step_time = ms(60_000);
    fire(&mut w, CH0, code::POWER_ON, 1, &[]);
    w.run_for(ms(1000));
    // An ordinary command waits; an urgent one goes.
    fire(&mut w, CH1, code::SET_BOX_DO, 1, &[1.0, 1.0]);
    w.run_for(ms(500));
    assert_ne!(status(&mut w, CH1) & r::ST_QUEUED, 0);
    w.set(
        r::RAW_REQUEST,
        &text_words("GrpReset,0,;", r::RAW_REQUEST_REGS),
    );
    w.set(r::RAW_CONTROL, &[1]);
    w.run_for(ms(100));
    assert_eq!(w.reg(r::RAW_STATUS), r::ST_DONE);
    assert_eq!(wait_end(&mut w, CH0, Duration::from_secs(40)), r::ST_ERROR);
    assert_eq!(
        error(&mut w, CH0),
        gateway_err(GatewayError::StateNotReached)
    );
    assert_eq!(wait_end(&mut w, CH1, ms(500)), r::ST_DONE);
}

// ------------------------------------------------------------------- link

#[test]
fn a_reply_timeout_fails_the_command_resets_the_link_and_nothing_is_resent() {
    let mut w = world();
    w.robot.script.push_back(Fault::NoReply);
    fire(&mut w, CH0, code::SET_BOX_DO, 1, &[1.0, 1.0]);
    fire_triggers(&mut w, 2, "SetBoxDO,3,1,;");
    assert_eq!(wait_end(&mut w, CH0, ms(2000)), r::ST_ERROR);
    assert_eq!(error(&mut w, CH0), gateway_err(GatewayError::ReplyTimeout));
    assert_eq!(w.reg(r::TRIG_ERROR), 0b11, "the queued ones: link lost");
    assert_eq!(w.read(r::TRIG_ERROR_ID, 2).unwrap(), [0, 39601]);
    assert_eq!(w.reg(r::STATUS_LINK_LAST_ERROR), 39503);
    w.run_for(ms(2000));
    assert_eq!(sent(&w, "SetBoxDO,1,1"), 1);
    assert_eq!(sent(&w, "SetBoxDO,3,1"), 0);
    assert_eq!(w.reg(r::STATUS_LINK_STATE), 3, "reconnected");
    assert_eq!(w.reg(r::STATUS_LINK_CONNECTS), 2);
}

#[test]
fn a_reply_that_names_another_command_resets_the_link() {
    let mut w = world();
    w.robot.script.push_back(Fault::WrongName);
    fire(&mut w, CH0, code::SET_BOX_DO, 1, &[1.0, 1.0]);
    assert_eq!(wait_end(&mut w, CH0, ms(500)), r::ST_ERROR);
    assert_eq!(error(&mut w, CH0), gateway_err(GatewayError::ReplyMismatch));
    assert_eq!(w.reg(r::STATUS_LINK_LAST_ERROR), 39505);
}

#[test]
fn an_unreadable_reply_is_39502_and_the_link_stays() {
    let mut w = world();
    w.robot.script.push_back(Fault::Garbage);
    fire(&mut w, CH0, code::SET_BOX_DO, 1, &[1.0, 1.0]);
    assert_eq!(wait_end(&mut w, CH0, ms(500)), r::ST_ERROR);
    assert_eq!(error(&mut w, CH0), gateway_err(GatewayError::BadReply));
    assert_eq!(w.reg(r::STATUS_LINK_CONNECTS), 1);
}

#[test]
fn a_dropped_connection_fails_the_motion_and_the_gateway_backs_off_and_reconnects() {
    let mut w = world();
    w.robot.model.motion_time = ms(2000);
    fire(&mut w, CH0, code::MOVE_REL_J, 1, &MOVE);
    w.run_for(ms(100));
    w.robot.set_offline(true);
    w.robot.drop_connections();
    assert_eq!(wait_end(&mut w, CH0, ms(500)), r::ST_ERROR);
    assert_eq!(error(&mut w, CH0), gateway_err(GatewayError::LinkLost));
    // Unknown status without a link; 39500 for what is fired meanwhile.
    assert_eq!(w.reg(r::STATUS_FSM), 0xFFFF);
    assert_eq!(w.reg(r::STATUS_AGE_MS), 0xFFFF);
    assert_eq!(w.read(r::STATUS_POSE, 2).unwrap(), [0x7FC0, 0]);
    w.set(CH0, &[0]);
    fire(&mut w, CH0, code::SET_BOX_DO, 2, &[1.0, 1.0]);
    assert_eq!(error(&mut w, CH0), gateway_err(GatewayError::NotConnected));
    // Backoff 0.2 s doubling to 5 s: count the attempts over 20 s.
    let robot = std::net::SocketAddrV4::new(ROBOT_IP, ROBOT_PORT);
    let before = w.net.attempts(robot);
    w.run_for(Duration::from_secs(20));
    let attempts = w.net.attempts(robot) - before;
    assert_eq!(w.reg(r::STATUS_LINK_LAST_ERROR), 39504);
    assert_eq!(w.model(|m| m.link.state), LinkState::Down);
    // 0.2 + 0.4 + 0.8 + 1.6 + 3.2 + 5 + 5 + 5 = 21.2 s: 7 or 8 attempts.
    assert!((6..=8).contains(&attempts), "{attempts} attempts in 20 s");
    w.robot.set_offline(false);
    assert!(w.run_until_cond(Duration::from_secs(6), |w| w.reg(r::STATUS_LINK_STATE) == 3));
}

#[test]
fn listen_mode_a_new_controller_connection_replaces_the_old() {
    let mut w = world_with(WorldConfig {
        listen_mode: true,
        ..WorldConfig::default()
    });
    assert_eq!(w.reg(r::STATUS_LINK_STATE), 3);
    let now = w.now();
    w.robot.reconnect_now(now);
    w.run_for(ms(200));
    assert_eq!(w.reg(r::STATUS_LINK_CONNECTS), 2);
    assert_eq!(
        w.robot.open_connections(),
        1,
        "the old connection is closed"
    );
    fire(&mut w, CH0, code::SET_BOX_DO, 1, &[1.0, 1.0]);
    assert_eq!(wait_end(&mut w, CH0, ms(500)), r::ST_DONE);
}

// ----------------------------------------------------------------- status

#[test]
fn status_is_polled_once_per_period_and_a_refused_io_read_clears_its_valid_bit() {
    let mut w = world();
    let before = sent(&w, "ReadRobotState");
    w.run_for(ms(1000));
    let rounds = sent(&w, "ReadRobotState") - before;
    assert!(
        (9..=11).contains(&rounds),
        "{rounds} rounds in 1 s at 100 ms"
    );
    assert!(w.reg(r::STATUS_AGE_MS) <= 100);
    assert_eq!(w.reg(r::STATUS_IO_VALID), 0b11_1111);
    // The round's 5th read is ReadBoxDO: refuse it once.
    w.run_until_cond(ms(200), |w| {
        w.robot
            .log
            .last()
            .is_some_and(|m| m.text.starts_with("ReadBoxDI"))
    });
    w.robot.script.push_back(Fault::Fail(20009));
    w.run_for(ms(20));
    assert_eq!(w.reg(r::STATUS_IO_VALID) & 0b10, 0);
}

// --------------------------------------------------------------- watchdog

fn watchdog_world(action: u16) -> World {
    let config = Config {
        watchdog_ms: 200,
        watchdog_action: match action {
            0 => hans_gateway::config::WatchdogAction::ReportOnly,
            1 => hans_gateway::config::WatchdogAction::Stop,
            _ => hans_gateway::config::WatchdogAction::Pause,
        },
        ..Config::default()
    };
    let mut w = world_with(WorldConfig {
        config,
        ..WorldConfig::default()
    });
    w.robot.model.motion_time = ms(1000);
    w
}

#[test]
fn the_watchdog_stops_a_motion_without_heartbeat_and_aborts_the_waiting_ones() {
    let mut w = watchdog_world(1);
    fire(&mut w, CH0, code::MOVE_REL_J, 1, &MOVE);
    w.run_for(ms(5)); // the motion runs
    fire_triggers(&mut w, 1, "MoveRelJ,0,1,1,5,;");
    assert_eq!(w.reg(r::STATUS_WATCHDOG), 1, "armed");
    // Heartbeats keep it running ...
    for beat in 1..4 {
        w.run_for(ms(150));
        w.set(r::CONTROL_HEARTBEAT, &[beat]);
    }
    assert_ne!(status(&mut w, CH0) & r::ST_BUSY, 0);
    // ... until they stop.
    assert_eq!(wait_end(&mut w, CH0, ms(400)), r::ST_ERROR);
    assert_eq!(error(&mut w, CH0), gateway_err(GatewayError::Watchdog));
    assert_eq!(w.reg(r::TRIG_ABORTED), 1);
    assert_eq!(w.reg(r::STATUS_WATCHDOG), 0b10, "tripped, no longer armed");
    assert_eq!(w.reg(r::STATUS_WATCHDOG_TRIPS), 1);
    assert_eq!(sent(&w, "GrpStop"), 1);
    assert_eq!(sent(&w, "MoveRelJ"), 1);
    // The trip bit stays until the heartbeat changes.
    w.run_for(ms(500));
    assert_eq!(w.reg(r::STATUS_WATCHDOG), 0b10);
    w.set(r::CONTROL_HEARTBEAT, &[9]);
    assert_eq!(w.reg(r::STATUS_WATCHDOG), 0);
}

#[test]
fn watchdog_action_0_only_reports_and_the_motion_runs_to_done() {
    let mut w = watchdog_world(0);
    fire(&mut w, CH0, code::MOVE_REL_J, 1, &MOVE);
    assert_eq!(wait_end(&mut w, CH0, ms(3000)), r::ST_DONE);
    assert_eq!(w.reg(r::STATUS_WATCHDOG_TRIPS), 1);
    assert_eq!(sent(&w, "GrpStop") + sent(&w, "GrpInterrupt"), 0);
}

#[test]
fn watchdog_action_2_pauses() {
    let mut w = watchdog_world(2);
    fire(&mut w, CH0, code::MOVE_REL_J, 1, &MOVE);
    assert_eq!(wait_end(&mut w, CH0, ms(1000)), r::ST_ERROR);
    assert_eq!(sent(&w, "GrpInterrupt"), 1);
}

// ----------------------------------------------------------------- modbus

#[test]
fn modbus_limits_and_exceptions() {
    let mut w = world();
    assert_eq!(w.read(0, 126), Err(3), "more than 125 registers");
    assert_eq!(w.read(64, 1), Err(2), "a gap");
    assert_eq!(w.read(0, 65), Err(2), "partly in a gap");
    assert_eq!(w.write(0, &[1]), Err(2), "read-only");
    assert_eq!(w.write(r::CONTROL_CONFIG_COMMAND, &[4]), Err(3));
    // FC 5 with a value other than 0x0000 / 0xFF00: exception 03.
    let mut p = pdu::coil(16 * CH0, true);
    p[3] = 0x12;
    assert_eq!(w.request(0, &p), Answer::Exception(3));
    // Coil 16 x 200 is Execute of channel 0.
    w.robot.model.motion_time = ms(100);
    w.set(CH0, &[0, code::STOP]);
    assert!(matches!(
        w.request(0, &pdu::coil(16 * CH0, true)),
        Answer::Pdu(_)
    ));
    w.run_for(ms(50));
    assert_eq!(status(&mut w, CH0), r::ST_DONE);
    // A coil write to bit 0 of CONFIG_COMMAND applies the configuration.
    assert!(matches!(
        w.request(0, &pdu::coil(16 * r::CONTROL_CONFIG_COMMAND, true)),
        Answer::Pdu(_)
    ));
    assert_eq!(w.reg(r::CONTROL_CONFIG_RESULT), 0);
    assert_eq!(w.reg(r::CONTROL_SAVES), 1);
}

#[test]
fn a_frame_that_is_not_modbus_closes_only_that_client_and_a_silent_one_goes_after_120_s() {
    let mut w = world_with(WorldConfig {
        plcs: 3,
        ..WorldConfig::default()
    });
    assert_eq!(w.reg(r::STATUS_SESSIONS), 3);
    w.plcs[1].send_raw(&[0, 1, 0x12, 0x34, 0, 6, 1, 3, 0, 0, 0, 1]);
    w.run_for(ms(10));
    assert!(!w.plcs[1].is_open());
    assert_eq!(w.reg(r::STATUS_SESSIONS), 2);
    // PLC 0 keeps talking; PLC 2 is silent.
    for _ in 0..13 {
        w.run_for(Duration::from_secs(10));
        w.reg(0);
    }
    assert!(!w.plcs[2].is_open());
    assert!(w.plcs[0].is_open());
    assert_eq!(w.reg(r::STATUS_SESSIONS), 1);
}

// ------------------------------------------------------------------ texts

#[test]
fn raw_replies_are_cut_at_512_and_flagged_and_over_1024_are_39502() {
    let mut w = world();
    w.set(
        r::RAW_REQUEST,
        &text_words("LongReply,;", r::RAW_REQUEST_REGS),
    );
    let long = format!("LongReply,OK,{},;", "x".repeat(600));
    w.robot
        .script
        .push_back(Fault::Reply(long.clone().into_bytes()));
    w.set(r::RAW_CONTROL, &[1]);
    w.run_for(ms(20));
    assert_eq!(w.reg(r::RAW_STATUS), r::ST_DONE);
    assert_eq!(w.reg(r::RAW_REPLY_LEN), long.len() as u16);
    assert_eq!(w.reg(r::RAW_REPLY_TRUNCATED), 1);
    let last = w.read(r::RAW_REPLY + r::RAW_REPLY_REGS - 1, 1).unwrap();
    assert_eq!(last, [u16::from_be_bytes([b'x', b'x'])]);
    w.set(r::RAW_CONTROL, &[0]);
    let too_long = format!("LongReply,OK,{},;", "x".repeat(1100));
    w.robot
        .script
        .push_back(Fault::Reply(too_long.into_bytes()));
    w.set(r::RAW_CONTROL, &[1]);
    w.run_for(ms(20));
    assert_eq!(w.reg(r::RAW_STATUS), r::ST_ERROR);
    assert_eq!(w.read(r::RAW_ERROR_ID, 3).unwrap(), [0, 39502, 3]);
}

// ---------------------------------------------------------- configuration

#[test]
fn an_applied_configuration_is_saved_and_survives_a_restart() {
    let mut w = world();
    w.set(r::CONFIG_POLL_MS, &[50]);
    w.set(r::trigger_text(3), &text_words("GrpStop,0,;", 8));
    w.set(r::CONTROL_CONFIG_COMMAND, &[1]);
    assert_eq!(w.reg(r::CONTROL_CONFIG_RESULT), 0);
    assert_eq!(w.reg(r::CONTROL_SAVES), 1);
    w.restart();
    w.run_for(ms(300));
    assert_eq!(w.reg(r::CONFIG_POLL_MS), 50);
    assert_eq!(
        w.read(r::trigger_text(3), 2).unwrap(),
        text_words("GrpS", 2)
    );
    // A failing medium: applied anyway, exception 04, CONFIG_RESULT 2.
    w.config.storage.fail.set(true);
    w.set(r::CONFIG_POLL_MS, &[60]);
    assert_eq!(w.write(r::CONTROL_CONFIG_COMMAND, &[1]), Err(4));
    assert_eq!(w.reg(r::CONTROL_CONFIG_RESULT), 2);
    assert_eq!(w.model(|m| m.config.active.poll_ms), 60);
}

#[test]
fn factory_defaults_keep_the_robot_address_given_at_start() {
    let mut w = world();
    w.set(r::CONTROL_CONFIG_COMMAND, &[3]);
    let ip = w.read(r::CONFIG_ROBOT_IP, 3).unwrap();
    let [a, b, c, d] = ROBOT_IP.octets();
    assert_eq!(
        ip,
        [
            u16::from_be_bytes([a, b]),
            u16::from_be_bytes([c, d]),
            ROBOT_PORT
        ]
    );
    let _ = Instant::from_ticks(0);
}

// ------------------------------------------------------------- access

fn ip_words(ip: Ipv4Addr) -> [u16; 2] {
    let [a, b, c, d] = ip.octets();
    [u16::from_be_bytes([a, b]), u16::from_be_bytes([c, d])]
}

#[test]
fn the_modbus_allow_list_refuses_other_clients_at_once_and_counts_them() {
    let mut w = world();
    // A commissioned device (access settings are locked before one).
    w.add_admin();
    w.allow_modbus_config();
    // PLC 0 connects from 10.0.0.10; allow that address only.
    let [a, b] = ip_words(Ipv4Addr::new(10, 0, 0, 10));
    w.set(r::MODBUS_ALLOW, &[a, b, 32]);
    w.set(r::CONTROL_CONFIG_COMMAND, &[1]);
    let other = w.connect_plc(Ipv4Addr::new(10, 0, 0, 11));
    assert!(!w.plc_open(other), "closed at once");
    assert_eq!(w.reg(r::STATUS_MODBUS_REFUSED), 1);
    assert_eq!(w.reg(r::STATUS_SESSIONS), 1, "PLC 0 stays connected");
    let again = w.connect_plc(Ipv4Addr::new(10, 0, 0, 10));
    assert!(w.plc_open(again));
    assert!(matches!(
        w.request(again, &pdu::read(r::STATUS_VERSION, 1)),
        Answer::Pdu(_)
    ));
    // A /24 entry admits the neighbour.
    let [c, d] = ip_words(Ipv4Addr::new(10, 0, 0, 0));
    w.set(r::MODBUS_ALLOW + 3, &[c, d, 24]);
    w.set(r::CONTROL_CONFIG_COMMAND, &[1]);
    let neighbour = w.connect_plc(Ipv4Addr::new(10, 0, 0, 11));
    assert!(w.plc_open(neighbour));
    assert_eq!(w.reg(r::STATUS_MODBUS_REFUSED), 1);
    // Emptying the list lets everyone in again.
    w.set(r::MODBUS_ALLOW, &[0; 12]);
    w.set(r::CONTROL_CONFIG_COMMAND, &[1]);
    let anyone = w.connect_plc(Ipv4Addr::new(172, 16, 0, 1));
    assert!(w.plc_open(anyone));
}

#[test]
fn write_protection_refuses_configuration_writes_but_not_commands() {
    let mut w = world();
    w.add_admin();
    w.allow_modbus_config();
    w.set(r::CONFIG_WRITE_PROTECT, &[1]);
    w.set(r::CONTROL_CONFIG_COMMAND, &[1]);
    assert_eq!(
        w.reg(r::STATUS_ACCESS) & r::ACCESS_WRITE_PROTECTED,
        r::ACCESS_WRITE_PROTECTED
    );
    let before = w.reg(r::CONFIG_POLL_MS);
    // Settings, CONFIG_COMMAND, trigger texts, and a block write that only
    // touches one protected register: exception 01, nothing written.
    assert_eq!(w.write(r::CONFIG_POLL_MS, &[50]), Err(1));
    assert_eq!(w.write(r::CONFIG_WRITE_PROTECT, &[0]), Err(1));
    assert_eq!(w.write(r::CONTROL_CONFIG_COMMAND, &[3]), Err(1));
    assert_eq!(
        w.write(r::trigger_text(0), &text_words("GrpStop,0,;", 8)),
        Err(1)
    );
    assert_eq!(w.write(r::CONTROL_HEARTBEAT, &[7, 1]), Err(1));
    assert_eq!(w.reg(r::CONFIG_POLL_MS), before);
    assert_eq!(w.reg(r::CONTROL_HEARTBEAT), 0);
    assert_eq!(w.reg(r::STATUS_WRITES_REFUSED), 5);
    // The heartbeat, commands and trigger bits are still the PLC's.
    w.set(r::CONTROL_HEARTBEAT, &[7]);
    assert_eq!(w.reg(r::CONTROL_HEARTBEAT), 7);
    w.set(CH0 + r::CH_COMMAND, &[code::STOP, 1]);
    w.set(CH0, &[1]);
    assert_eq!(wait_end(&mut w, CH0, ms(500)), r::ST_DONE);
    w.set(r::TRIG_BITS, &[0]);
    // Reads are not affected.
    assert!(w.read(r::CONFIG_ROBOT_IP, r::CONFIG_LEN).is_ok());
}

// ------------------------------------- points REGISTERS.md makes explicit

#[test]
fn a_trigger_entry_gets_the_missing_terminator_as_raw_does() {
    let mut w = world();
    w.set(r::trigger_text(2), &text_words("SetBoxDO,1,1", 8));
    w.set(r::TRIG_BITS, &[1 << 2]);
    w.run_for(ms(20));
    assert_eq!(w.reg(r::TRIG_DONE), 1 << 2);
    assert_eq!(sent(&w, "SetBoxDO,1,1,;"), 1);
}

#[test]
fn a_trigger_bit_that_rises_while_its_entry_is_busy_is_ignored() {
    let mut w = world();
    w.robot.model.motion_time = ms(500);
    w.set(r::trigger_text(0), &text_words("MoveRelJ,0,1,1,5,;", 10));
    w.set(r::TRIG_BITS, &[1]);
    w.run_for(ms(50));
    w.set(r::TRIG_BITS, &[0]);
    w.set(r::TRIG_BITS, &[1]);
    w.run_for(ms(2000));
    assert_eq!(w.reg(r::TRIG_DONE), 1);
    assert_eq!(sent(&w, "MoveRelJ"), 1, "the second rise was ignored");
}

#[test]
fn a_command_fired_while_the_link_is_connecting_ends_in_39500() {
    let mut w = world();
    // The robot drops off and no longer answers connects: after the first
    // backoff (0.2 s) the link stays "connecting" (3 s at most).
    w.net.blackhole(ROBOT_IP, true);
    w.robot.drop_connections();
    w.run_for(ms(400));
    assert_eq!(w.reg(r::STATUS_LINK_STATE), 1);
    fire(&mut w, CH0, code::SET_BOX_DO, 1, &[1.0, 1.0]);
    assert_eq!(status(&mut w, CH0), r::ST_ERROR);
    assert_eq!(error(&mut w, CH0), gateway_err(GatewayError::NotConnected));
    // After 3 s the attempt fails (39504) and the link backs off.
    w.run_for(ms(3000));
    assert_eq!(w.reg(r::STATUS_LINK_LAST_ERROR), 39504);
}

#[test]
fn robot_flags_bit_10_is_read_from_nbreaking_when_polled() {
    let mut w = world();
    // The testkit robot reports its brakes released while enabled.
    assert_ne!(w.reg(r::STATUS_FLAGS) & r::FLAG_BRAKE_RELEASED, 0);
    w.set(CH0, &[0, code::DISABLE]);
    w.set(CH0, &[1]);
    w.run_for(ms(300));
    assert_eq!(w.reg(r::STATUS_FLAGS) & r::FLAG_BRAKE_RELEASED, 0);
}

#[test]
fn raw_parameters_are_the_robots_to_judge() {
    let mut w = world();
    // A field the document says is a number: sent, and the robot refuses it.
    w.set(r::RAW_REQUEST, &text_words("MoveRelJ,0,abc,1,5,;", 12));
    w.set(r::RAW_CONTROL, &[1]);
    w.run_for(ms(20));
    assert_eq!(sent(&w, "MoveRelJ,0,abc"), 1);
    assert_eq!(w.reg(r::RAW_STATUS), r::ST_ERROR);
    assert_eq!(w.read(r::RAW_ERROR_ID, 3).unwrap(), [0, 20006, 1]);
    // Text that is no message at all is the gateway's to refuse.
    w.set(r::RAW_CONTROL, &[0]);
    w.set(r::RAW_REQUEST, &text_words("Move RelJ,0,;", 8));
    w.set(r::RAW_CONTROL, &[1]);
    assert_eq!(w.read(r::RAW_ERROR_ID, 3).unwrap(), [0, 39501, 3]);
}
