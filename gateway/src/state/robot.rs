//! The robot's status as the gateway last saw it, typed: from the replies to
//! its polls on the command port, or from DataSheet packets.
//!
//! Everything unknown is `None`: at start and from the moment the link is
//! lost ([`RobotStatus::invalidate`]) nothing of an earlier link survives, so
//! no old value can pass for a current one.

use embassy_time::Instant;
#[cfg(feature = "datasheet")]
use hans_codec::datasheet::DataSheet;
use hans_codec::{response, FsmState, Response};

/// The flags of `ReadRobotState`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct RobotFlags {
    /// Moving.
    pub moving: bool,
    /// Enabled.
    pub enabled: bool,
    /// An error is active.
    pub error: bool,
    /// Paused.
    pub paused: bool,
    /// Emergency stop.
    pub emergency_stop: bool,
    /// Safety guard.
    pub safety_guard: bool,
    /// Powered (48 V).
    pub powered: bool,
    /// Electric box connected.
    pub box_connected: bool,
    /// Blending (way-point motion) done.
    pub blending_done: bool,
    /// In position.
    pub in_position: bool,
    /// Brakes released.
    pub brake_released: bool,
}

impl RobotFlags {
    /// The flags of a `ReadRobotState` reply.
    pub fn of(s: &response::ReadRobotState) -> Self {
        RobotFlags {
            moving: s.moving != 0,
            enabled: s.enabled != 0,
            error: s.error != 0,
            paused: s.paused != 0,
            emergency_stop: s.emergency_stop != 0,
            safety_guard: s.safety_guard != 0,
            powered: s.powered != 0,
            box_connected: s.box_connected != 0,
            blending_done: s.blending_done != 0,
            in_position: s.in_position != 0,
            brake_released: s.brake_released != 0,
        }
    }

    /// The flags a state of the controller's state machine implies, where
    /// `ReadRobotState` would give them but the DataSheet does not: the
    /// states come in the order of bring-up (box, emergency stop, 48 V,
    /// safety guard, controller), so every state past a stage has passed it.
    ///
    /// | `robotState` | flags |
    /// |---|---|
    /// | 0-3 (not initialised, box not connected), unknown | none |
    /// | 4-5 emergency stop | emergency stop, box connected |
    /// | 6-8 (48 V off, switching) | box connected |
    /// | 9-12 safety guard | safety guard, powered, box connected |
    /// | 13-46 | powered, box connected |
    pub fn implied_by(state: FsmState) -> Self {
        let n = i32::from(state);
        RobotFlags {
            box_connected: (4..=46).contains(&n),
            emergency_stop: (4..=5).contains(&n),
            powered: (9..=46).contains(&n),
            safety_guard: (9..=12).contains(&n),
            ..RobotFlags::default()
        }
    }
}

/// One of the I/O groups the gateway mirrors.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Io {
    /// The box's digital inputs DI0-DI7.
    BoxDi = 0,
    /// The box's digital outputs DO0-DO7.
    BoxDo = 1,
    /// The box's configurable inputs CI0-CI7.
    BoxCi = 2,
    /// The box's configurable outputs CO0-CO7.
    BoxCo = 3,
    /// The tool flange's digital inputs 0-2.
    EndDi = 4,
    /// The tool flange's digital outputs 0-2.
    EndDo = 5,
}

impl Io {
    /// Every group, in register order.
    pub const ALL: [Io; 6] = [
        Io::BoxDi,
        Io::BoxDo,
        Io::BoxCi,
        Io::BoxCo,
        Io::EndDi,
        Io::EndDo,
    ];
}

/// Packs I/O values (0 off, anything else on), value `i` in bit `i`. Values
/// beyond the sixteenth have no bit and are left out.
fn bits(values: &[i32]) -> u16 {
    values
        .iter()
        .take(16)
        .enumerate()
        .filter(|(_, v)| **v != 0)
        .fold(0, |acc, (i, _)| acc | (1 << i))
}

fn floats(v: &[hans_codec::Decimal; 6]) -> [f32; 6] {
    v.map(|d| d.to_f32())
}

/// The robot's status.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct RobotStatus {
    /// The FSM state (`ReadCurFSM`, DataSheet `robotState`).
    pub fsm: Option<FsmState>,
    /// The flags; `None` while there is no robot state on the current link.
    pub flags: Option<RobotFlags>,
    /// The error code (`nErrorCode`), 0 when none or unknown.
    pub error_code: i32,
    /// The error axis (`nErrorAxis`), 0 when none or unknown.
    pub error_axis: u16,
    /// Speed override ratio: the last one set through the gateway, or the
    /// DataSheet's.
    pub override_ratio: Option<f32>,
    /// Actual joints J1-J6 [°].
    pub joints: Option<[f32; 6]>,
    /// Actual TCP pose X, Y, Z (mm), Rx, Ry, Rz (°) in the user frame.
    pub pose: Option<[f32; 6]>,
    /// The I/O groups, indexed by [`Io`]: bit `n` = channel `n`.
    pub io: [Option<u16>; 6],
    /// When a full status was last refreshed (a poll round, a DataSheet
    /// packet).
    pub updated: Option<Instant>,
}

impl RobotStatus {
    /// Nothing known.
    pub const UNKNOWN: RobotStatus = RobotStatus {
        fsm: None,
        flags: None,
        error_code: 0,
        error_axis: 0,
        override_ratio: None,
        joints: None,
        pose: None,
        io: [None; 6],
        updated: None,
    };

    /// Forgets everything (at start, and when the link is lost).
    pub fn invalidate(&mut self) {
        *self = RobotStatus::UNKNOWN;
    }

    /// One I/O group.
    pub fn io(&self, group: Io) -> Option<u16> {
        self.io.get(group as usize).copied().flatten()
    }

    fn set_io(&mut self, group: Io, values: Option<&[i32]>) {
        if let Some(slot) = self.io.get_mut(group as usize) {
            *slot = values.map(bits);
        }
    }

    /// Copies a `ReadRobotState` reply.
    pub fn apply_robot_state(&mut self, s: &response::ReadRobotState) {
        self.flags = Some(RobotFlags::of(s));
        self.error_code = s.error_code;
        self.error_axis = u16::try_from(s.error_axis).unwrap_or(u16::MAX);
    }

    /// Copies what a successful reply says about the status (the replies of
    /// the polls, and the same reads sent from RAW or a trigger entry).
    pub fn apply_response(&mut self, resp: &Response<'_>) {
        match resp {
            Response::ReadRobotState(s) => self.apply_robot_state(s),
            Response::ReadCurFSM(f) => self.fsm = Some(f.state),
            Response::ReadActPos(p) => {
                self.joints = Some(floats(&p.joints));
                self.pose = Some(floats(&p.pose));
            }
            Response::ReadBoxDI(v) => self.set_io(Io::BoxDi, Some(&v.values)),
            Response::ReadBoxDO(v) => self.set_io(Io::BoxDo, Some(&v.values)),
            Response::ReadBoxCI(v) => self.set_io(Io::BoxCi, Some(&v.values)),
            Response::ReadBoxCO(v) => self.set_io(Io::BoxCo, Some(&v.values)),
            Response::ReadEI(v) => self.set_io(Io::EndDi, Some(&v.values)),
            Response::ReadEO(v) => self.set_io(Io::EndDo, Some(&v.values)),
            _ => {}
        }
    }

    /// The robot refused the read of an I/O group (it lacks it, say): the
    /// group is unknown.
    pub fn io_refused(&mut self, group: Io) {
        self.set_io(group, None);
    }

    /// Copies a DataSheet packet.
    #[cfg(feature = "datasheet")]
    ///
    /// The flags are rebuilt from this sheet alone (nothing of the polled
    /// flags stays): moving, enabled, paused, blending done, in position and
    /// error from their fields; emergency stop, safety guard, powered and box
    /// connected from `robotState` ([`RobotFlags::implied_by`]); brakes
    /// released when `BrakeState` shows all six axes released. A flag the
    /// packet does not carry reads false.
    pub fn apply_sheet(&mut self, sheet: &DataSheet, now: Instant) {
        let st = &sheet.state;
        if let Some(fsm) = st.robot_state {
            self.fsm = Some(fsm);
        }
        let mut f = st
            .robot_state
            .map(RobotFlags::implied_by)
            .unwrap_or_default();
        let on = |v: Option<bool>| v == Some(true);
        f.moving = on(st.moving);
        f.enabled = on(st.enabled);
        f.paused = on(st.paused);
        f.blending_done = on(st.blending_done);
        f.in_position = on(st.in_pos);
        f.error = on(st.error_code.map(|c| c != 0));
        f.brake_released = on(st.brake_state.map(|b| b.iter().all(|&axis| axis != 0)));
        self.flags = Some(f);
        if let Some(c) = st.error_code {
            self.error_code = c;
        }
        if let Some(a) = st.error_axis_id {
            self.error_axis = u16::try_from(a).unwrap_or(u16::MAX);
        }
        let pv = &sheet.pos_and_vel;
        if let Some(p) = &pv.position {
            self.joints = Some(floats(&p.joints));
        }
        if let Some(pose) = pv.pcs_tcp.or(pv.position.and_then(|p| p.pose)) {
            self.pose = Some(floats(&pose));
        }
        if let Some(o) = pv.override_ratio {
            self.override_ratio = Some(o.to_f32());
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
                self.set_io(group, Some(values));
            }
        }
        self.updated = Some(now);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use hans_codec::{CommandId, Reply, ReplyExpect};

    fn reply(text: &str, id: CommandId) -> Response<'_> {
        match Reply::parse(text, ReplyExpect::of(id)).unwrap() {
            Reply::Ok(r) => r,
            other => panic!("{other:?}"),
        }
    }

    #[test]
    fn replies_fill_the_status() {
        let mut s = RobotStatus::UNKNOWN;
        s.apply_response(&reply(
            "ReadRobotState,OK,1,1,0,0,0,0,0,0,0,1,1,0,0,;",
            CommandId::ReadRobotState,
        ));
        let f = s.flags.unwrap();
        assert!(f.moving && f.enabled && f.powered && f.box_connected && !f.error);
        s.apply_response(&reply(
            "ReadBoxDO,OK,1,0,0,1,0,0,0,1,;",
            CommandId::ReadBoxDO,
        ));
        assert_eq!(s.io(Io::BoxDo), Some(0b1000_1001));
        s.io_refused(Io::BoxDo);
        assert_eq!(s.io(Io::BoxDo), None);
        s.apply_response(&reply(
            "ReadActPos,OK,1,2,3,4,5,6,420,0,445,180,0,180,0,0,0,0,0,0,0,0,0,0,0,0,;",
            CommandId::ReadActPos,
        ));
        assert_eq!(s.joints, Some([1.0, 2.0, 3.0, 4.0, 5.0, 6.0]));
        assert_eq!(s.pose.unwrap()[2], 445.0);
        s.invalidate();
        assert_eq!(s, RobotStatus::UNKNOWN);
    }

    #[test]
    #[cfg(feature = "datasheet")]
    fn a_sheet_rebuilds_the_flags_from_itself_alone() {
        let mut s = RobotStatus::UNKNOWN;
        s.apply_response(&reply(
            "ReadRobotState,OK,1,1,0,0,0,1,0,1,1,1,1,0,0,;",
            CommandId::ReadRobotState,
        ));
        // A sheet that says nothing about the state: no flag.
        s.apply_sheet(&DataSheet::default(), Instant::from_millis(5));
        assert_eq!(s.flags, Some(RobotFlags::default()));
        assert_eq!(s.updated, Some(Instant::from_millis(5)));
        // 48 V off, one brake applied, standing still.
        let mut sheet = DataSheet::default();
        sheet.state.robot_state = Some(FsmState::Blackout48V);
        sheet.state.brake_state = Some([1, 1, 1, 1, 1, 0]);
        sheet.state.moving = Some(false);
        s.apply_sheet(&sheet, Instant::from_millis(6));
        assert_eq!(
            s.flags,
            Some(RobotFlags {
                box_connected: true,
                ..RobotFlags::default()
            })
        );
        assert_eq!(s.fsm, Some(FsmState::Blackout48V));
    }

    #[test]
    fn the_state_machine_implies_the_flags_the_sheet_lacks() {
        let f = RobotFlags::implied_by(FsmState::EmergencyStop);
        assert!(f.emergency_stop && f.box_connected && !f.powered);
        let f = RobotFlags::implied_by(FsmState::SafetyGuard);
        assert!(f.safety_guard && f.powered && f.box_connected);
        let f = RobotFlags::implied_by(FsmState::StandBy);
        assert!(f.powered && f.box_connected && !f.safety_guard && !f.emergency_stop);
        for s in [FsmState::ElectricBoxConnecting, FsmState::Unknown(99)] {
            assert_eq!(RobotFlags::implied_by(s), RobotFlags::default(), "{s:?}");
        }
    }
}
