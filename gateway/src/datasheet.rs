//! The status mirror's second source: the controller's DataSheet port
//! (chapter 5, JSON packets at 20/10/5 Hz on 10004/10005/10006), read with
//! the codec's deframer and JSON reader. It spares the command port: with
//! `CFG_STATUS_SOURCE = 1` the engine stops its polling rounds (motion
//! completion still polls `ReadRobotState`, which is exact).
//!
//! The DataSheet connection goes to the robot's address (connect mode) or
//! to the address the controller connected from (listen mode), on
//! `CFG_DATASHEET_PORT`, and follows that address: a new robot address, or
//! a controller reconnecting from another one in listen mode, moves it.
//! When it fails it is retried every [`RETRY_DELAY`]; [`SILENCE_TIMEOUT`]
//! without data ends it. A packet that cannot be read (a bad header, more
//! than [`PAYLOAD_MAX`] bytes, JSON the codec rejects) is dropped; the first
//! one on each connection is logged, and the count when it ends. The status
//! age register shows how fresh the data is.

use core::convert::Infallible;
use core::net::{Ipv4Addr, SocketAddrV4};

use embassy_time::{with_timeout, Duration, Instant, Timer};
use hans_codec::datasheet::{DataSheet, Deframer};
use hans_codec::FsmState;

use crate::config::{LinkMode, StatusSource, WordOrder};
use crate::gateway::Ctx;
use crate::link::CONNECT_TIMEOUT;
use crate::net::Socket;
use crate::registers::{self as r, RegisterFile};
use crate::status::{self, Io};

/// Largest DataSheet payload accepted (a controller's is ~3 KiB). A larger
/// packet is dropped.
pub const PAYLOAD_MAX: usize = 6144;

/// Silence that ends the connection: the slowest port (10006) sends every
/// 200 ms, so a controller quiet this long is gone or stuck.
pub const SILENCE_TIMEOUT: Duration = Duration::from_secs(2);

/// Pause after a failed connection attempt (connect refused, or no answer
/// within [`CONNECT_TIMEOUT`]).
pub const RETRY_DELAY: Duration = Duration::from_secs(1);

/// Pause after a connection ended, and between looks at the configuration
/// while the DataSheet is not the status source (or has no address yet).
pub const IDLE_DELAY: Duration = Duration::from_millis(200);

/// Copies a DataSheet into the status registers.
///
/// `ROBOT_FLAGS` is rebuilt from this sheet alone (nothing of the polled
/// flags stays): moving, enabled, paused, blending done, in position and
/// error from their fields; emergency stop, safety guard, powered and box
/// connected from `robotState` (see [`fsm_flags`]); brakes released when
/// `BrakeState` shows all six axes released.
pub fn apply(sheet: &DataSheet, regs: &mut RegisterFile, order: WordOrder) {
    let st = &sheet.state;
    if let Some(fsm) = st.robot_state {
        status::set_fsm(regs, fsm);
    }
    let mut flags = r::FLAG_VALID | st.robot_state.map_or(0, fsm_flags);
    let mut set = |on: Option<bool>, bit: u16| {
        if on == Some(true) {
            flags |= bit;
        }
    };
    set(st.moving, r::FLAG_MOVING);
    set(st.enabled, r::FLAG_ENABLED);
    set(st.paused, r::FLAG_PAUSED);
    set(st.blending_done, r::FLAG_BLENDING_DONE);
    set(st.in_pos, r::FLAG_IN_POSITION);
    set(st.error_code.map(|c| c != 0), r::FLAG_ERROR);
    set(
        st.brake_state.map(|b| b.iter().all(|&axis| axis != 0)),
        r::FLAG_BRAKE_RELEASED,
    );
    regs.set(r::STATUS_FLAGS, flags);
    if let Some(c) = st.error_code {
        regs.set_i32(r::STATUS_ERROR_CODE, c, order);
    }
    if let Some(a) = st.error_axis_id {
        regs.set(r::STATUS_ERROR_AXIS, u16::try_from(a).unwrap_or(u16::MAX));
    }
    let pv = &sheet.pos_and_vel;
    if let Some(p) = &pv.position {
        status::set_joints(regs, &p.joints, order);
    }
    if let Some(pose) = pv.pcs_tcp.or(pv.position.and_then(|p| p.pose)) {
        status::set_pose(regs, &pose, order);
    }
    if let Some(o) = pv.override_ratio {
        regs.set_f32(r::STATUS_OVERRIDE, o.to_f32(), order);
    }
    let io = [
        (&sheet.box_io.box_di[..], Io::BoxDi),
        (&sheet.box_io.box_do[..], Io::BoxDo),
        (&sheet.box_io.box_ci[..], Io::BoxCi),
        (&sheet.box_io.box_co[..], Io::BoxCo),
        (&sheet.end_io.end_di[..], Io::EndDi),
        (&sheet.end_io.end_do[..], Io::EndDo),
    ];
    for (values, group) in io {
        if !values.is_empty() {
            status::set_io(regs, group, values);
        }
    }
}

/// The `ROBOT_FLAGS` bits a state of the controller's state machine implies,
/// where `ReadRobotState` would give them but the DataSheet does not: the
/// states come in the order of bring-up (box, emergency stop, 48 V, safety
/// guard, controller), so every state past a stage has passed it.
///
/// | `robotState` | bits |
/// |---|---|
/// | 0-3 (not initialised, box not connected), unknown | none |
/// | 4-5 emergency stop | emergency stop, box connected |
/// | 6-8 (48 V off, switching) | box connected |
/// | 9-12 safety guard | safety guard, powered, box connected |
/// | 13-46 | powered, box connected |
pub fn fsm_flags(state: FsmState) -> u16 {
    let boxed = r::FLAG_BOX_CONNECTED;
    let powered = boxed | r::FLAG_POWERED;
    match i32::from(state) {
        4..=5 => boxed | r::FLAG_EMERGENCY_STOP,
        6..=8 => boxed,
        9..=12 => powered | r::FLAG_SAFETY_GUARD,
        13..=46 => powered,
        _ => 0,
    }
}

/// Counts a dropped packet; true for the first of the connection (the one
/// logged, so that a controller sending bad data cannot flood the log).
fn first_drop(dropped: &mut u32) -> bool {
    *dropped = dropped.saturating_add(1);
    *dropped == 1
}

/// Where to read the DataSheet now, if configured.
fn target(ctx: &Ctx<'_>) -> Option<SocketAddrV4> {
    ctx.with(|s| {
        if s.config.status_source != StatusSource::DataSheet {
            return None;
        }
        let ip = match s.config.link_mode {
            LinkMode::Connect => s.config.robot_ip,
            LinkMode::Listen => s.robot_peer.unwrap_or(Ipv4Addr::UNSPECIFIED),
        };
        (!ip.is_unspecified()).then(|| SocketAddrV4::new(ip, s.config.datasheet_port))
    })
}

/// Reads the DataSheet whenever it is the configured status source.
pub(crate) async fn run<S: Socket>(ctx: &Ctx<'_>, mut sock: S) -> Infallible {
    let mut deframer = Deframer::<PAYLOAD_MAX>::new();
    let mut buf = [0u8; 512];
    loop {
        let Some(addr) = target(ctx) else {
            Timer::after(IDLE_DELAY).await;
            continue;
        };
        match with_timeout(CONNECT_TIMEOUT, sock.connect(addr)).await {
            Ok(Ok(())) => info!("datasheet: connected to port {}", addr.port()),
            _ => {
                sock.close().await;
                Timer::after(RETRY_DELAY).await;
                continue;
            }
        }
        deframer.reset();
        let discarded = deframer.discarded();
        let mut dropped = 0u32;
        // Another address (a new robot address or port, or a controller
        // reconnected from elsewhere), or another status source, ends it.
        while target(ctx) == Some(addr) {
            let n = match with_timeout(SILENCE_TIMEOUT, sock.read(&mut buf)).await {
                Ok(Ok(n)) if n > 0 => n,
                _ => break,
            };
            // Each sheet is applied where it is parsed: a DataSheet is ~2 KiB,
            // one on the stack is enough.
            deframer.feed(buf.get(..n).unwrap_or(&[]), |item| {
                match item.map(DataSheet::parse) {
                    Ok(Ok(sheet)) => ctx.with(|s| {
                        let order = s.config.word_order;
                        apply(&sheet, s.regs, order);
                        s.status_time = Some(Instant::now());
                    }),
                    Ok(Err(e)) => {
                        if first_drop(&mut dropped) {
                            warn!("datasheet: payload dropped: {}", e);
                        }
                    }
                    Err(e) => {
                        if first_drop(&mut dropped) {
                            warn!("datasheet: packet dropped: {}", e);
                        }
                    }
                }
            });
        }
        let garbage = deframer.discarded().saturating_sub(discarded);
        info!(
            "datasheet: connection ended ({} packets dropped, {} bytes skipped)",
            dropped, garbage
        );
        sock.close().await;
        Timer::after(IDLE_DELAY).await;
    }
}

#[cfg(test)]
mod tests {
    use hans_codec::{Reply, ReplyExpect};

    use super::*;

    const ORDER: WordOrder = WordOrder::HighFirst;

    /// Registers as the command-port poll left them: moving, enabled, brakes
    /// released, emergency stop, safety guard, powered, box connected.
    fn polled() -> RegisterFile {
        let mut regs = RegisterFile::new();
        let exp = ReplyExpect::of(hans_codec::CommandId::ReadRobotState);
        let rep = Reply::parse("ReadRobotState,OK,1,1,0,0,0,1,0,1,1,1,1,0,0,;", exp).unwrap();
        status::PollStep::RobotState.apply(&rep, &mut regs, ORDER);
        assert_eq!(
            regs.get(r::STATUS_FLAGS),
            r::FLAG_VALID
                | r::FLAG_MOVING
                | r::FLAG_ENABLED
                | r::FLAG_BRAKE_RELEASED
                | r::FLAG_EMERGENCY_STOP
                | r::FLAG_SAFETY_GUARD
                | r::FLAG_POWERED
                | r::FLAG_BOX_CONNECTED
        );
        regs
    }

    #[test]
    fn switching_to_the_datasheet_leaves_no_polled_flag_standing() {
        // A sheet that says nothing about the state: only VALID.
        let mut regs = polled();
        apply(&DataSheet::default(), &mut regs, ORDER);
        assert_eq!(regs.get(r::STATUS_FLAGS), r::FLAG_VALID);

        // 48 V off, one brake applied, standing still: the polled
        // emergency stop, safety guard, powered, brake and moving bits go.
        let mut regs = polled();
        let mut sheet = DataSheet::default();
        sheet.state.robot_state = Some(FsmState::Blackout48V);
        sheet.state.brake_state = Some([1, 1, 1, 1, 1, 0]);
        sheet.state.moving = Some(false);
        sheet.state.enabled = Some(false);
        apply(&sheet, &mut regs, ORDER);
        assert_eq!(
            regs.get(r::STATUS_FLAGS),
            r::FLAG_VALID | r::FLAG_BOX_CONNECTED
        );
        assert_eq!(regs.get(r::STATUS_FSM), 7);
    }

    #[test]
    fn the_state_machine_and_brakes_fill_the_flags_the_sheet_lacks() {
        let mut regs = RegisterFile::new();
        let mut sheet = DataSheet::default();
        sheet.state.robot_state = Some(FsmState::EmergencyStop);
        sheet.state.brake_state = Some([1; 6]);
        apply(&sheet, &mut regs, ORDER);
        assert_eq!(
            regs.get(r::STATUS_FLAGS),
            r::FLAG_VALID | r::FLAG_EMERGENCY_STOP | r::FLAG_BOX_CONNECTED | r::FLAG_BRAKE_RELEASED
        );
        sheet.state.robot_state = Some(FsmState::StandBy);
        sheet.state.enabled = Some(true);
        sheet.state.in_pos = Some(true);
        sheet.state.error_code = Some(0);
        apply(&sheet, &mut regs, ORDER);
        assert_eq!(
            regs.get(r::STATUS_FLAGS),
            r::FLAG_VALID
                | r::FLAG_ENABLED
                | r::FLAG_IN_POSITION
                | r::FLAG_POWERED
                | r::FLAG_BOX_CONNECTED
                | r::FLAG_BRAKE_RELEASED
        );
        sheet.state.robot_state = Some(FsmState::SafetyGuard);
        sheet.state.error_code = Some(20018);
        apply(&sheet, &mut regs, ORDER);
        assert_eq!(
            regs.get(r::STATUS_FLAGS) & !r::FLAG_BRAKE_RELEASED,
            r::FLAG_VALID
                | r::FLAG_ENABLED
                | r::FLAG_IN_POSITION
                | r::FLAG_ERROR
                | r::FLAG_SAFETY_GUARD
                | r::FLAG_POWERED
                | r::FLAG_BOX_CONNECTED
        );
        assert_eq!(regs.get_u32(r::STATUS_ERROR_CODE, ORDER), 20018);
        // Before the box is connected, and for states this gateway does
        // not know, no state flag is claimed.
        for s in [FsmState::ElectricBoxConnecting, FsmState::Unknown(99)] {
            assert_eq!(fsm_flags(s), 0, "{s:?}");
        }
    }

    #[test]
    fn the_connection_follows_the_address_not_every_configuration_change() {
        let mut storage = crate::RamStorage::new();
        let mut regs = RegisterFile::new();
        let ctx = Ctx::new(&mut storage, &mut regs);
        let peer = |ip: [u8; 4]| Ipv4Addr::from(ip);
        ctx.with(|s| {
            s.config.status_source = StatusSource::DataSheet;
            s.config.link_mode = LinkMode::Listen;
            s.config.datasheet_port = 10004;
        });
        // Listen mode, no controller yet: nowhere to go.
        assert_eq!(target(&ctx), None);
        ctx.with(|s| s.robot_peer = Some(peer([127, 0, 0, 2])));
        let first = Some(SocketAddrV4::new(peer([127, 0, 0, 2]), 10004));
        assert_eq!(target(&ctx), first);
        // Another applied setting (the poll period) keeps the connection.
        ctx.with(|s| {
            s.config.poll_ms = s.config.poll_ms.wrapping_add(10);
            s.config_gen = s.config_gen.wrapping_add(1);
        });
        assert_eq!(target(&ctx), first);
        // The controller reconnecting from elsewhere moves it.
        ctx.with(|s| s.robot_peer = Some(peer([127, 0, 0, 3])));
        assert_eq!(
            target(&ctx),
            Some(SocketAddrV4::new(peer([127, 0, 0, 3]), 10004))
        );
        // So does another port, and polling as the source ends it.
        ctx.with(|s| s.config.datasheet_port = 10005);
        assert_eq!(
            target(&ctx),
            Some(SocketAddrV4::new(peer([127, 0, 0, 3]), 10005))
        );
        ctx.with(|s| s.config.status_source = StatusSource::Polling);
        assert_eq!(target(&ctx), None);
    }

    #[test]
    fn positions_and_io_go_where_the_poll_puts_them() {
        let mut regs = RegisterFile::new();
        let mut sheet = DataSheet::default();
        let d = hans_codec::Decimal::from_int;
        sheet.pos_and_vel.position = Some(hans_codec::datasheet::Position {
            joints: [d(1), d(2), d(3), d(4), d(5), d(6)],
            pose: None,
        });
        sheet.pos_and_vel.pcs_tcp = Some([d(420), d(0), d(445), d(180), d(0), d(180)]);
        sheet.box_io.box_do.extend([1, 0, 0, 1]);
        sheet.end_io.end_di.extend([0, 1]);
        apply(&sheet, &mut regs, ORDER);
        assert_eq!(status::joints(&regs, ORDER), [1.0, 2.0, 3.0, 4.0, 5.0, 6.0]);
        assert_eq!(regs.get_f32(r::STATUS_POSE + 4, ORDER), 445.0);
        assert_eq!(regs.get_f32(r::STATUS_POSE + 10, ORDER), 180.0);
        assert_eq!(regs.get(r::STATUS_BOX_DO), 0b1001);
        assert_eq!(regs.get(r::STATUS_END_DI), 0b10);
        assert_eq!(
            regs.get(r::STATUS_IO_VALID),
            Io::BoxDo.valid_bit() | Io::EndDi.valid_bit()
        );
    }
}
