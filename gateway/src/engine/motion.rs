//! When a motion command is Done (chapter 6 of the protocol document, and
//! what real controllers do: NOTES.md).
//!
//! After the robot accepts a motion, the engine polls `ReadRobotState`
//! every [`MOTION_POLL`] and judges each reply with [`Motion::judge`]:
//!
//! 1. an error (with its code, else 39604), an emergency stop (39605) or
//!    the safety guard (39606) ends it in Error;
//! 2. moving: it runs (and has been seen moving);
//! 3. paused: it runs (Pause keeps it Busy until Continue);
//! 4. not moving, once seen moving or after the start grace period
//!    (`CFG_START_GRACE_MS`: the moving flag lags the start by ~50 ms),
//!    and blending done / in position if `CFG_MOTION_POLICY` asks: the
//!    flags say it has ended. The engine then checks the FSM
//!    ([`super::bringup::motion_under_way`]: the flag also lags the end)
//!    and reads `ReadActPos`, so that at Done the position registers are
//!    final.
//!
//! A successful `GrpContinue` restarts the grace period
//! ([`Motion::restarted`]).

use embassy_time::{Duration, Instant};
use hans_codec::response::ReadRobotState;

use crate::clock::millis;
use crate::config::Config;
use crate::error::{ErrorSource, GatewayError, Outcome};
use crate::job::Source;

/// Poll period of `ReadRobotState` while a motion runs.
pub(crate) const MOTION_POLL: Duration = Duration::from_millis(10);

/// The motion running on the robot.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub(crate) struct Motion {
    /// Whose command it is.
    pub source: Source,
    /// When the robot accepted it (the watchdog counts from here at the
    /// earliest).
    pub since: Instant,
    /// Start of the grace period: acceptance, or the last `GrpContinue`.
    pub grace_from: Instant,
    /// The robot reported it moving (since the grace period began).
    pub seen_moving: bool,
    /// The watchdog has acted on it (report only: it runs on).
    pub watchdog_fired: bool,
    /// A jog: kept alive while Execute is held ([`super::jog`]).
    pub jog: Option<super::jog::JogRun>,
}

/// What a `ReadRobotState` reply says about the running motion.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub(crate) enum Judgement {
    /// Still under way (or paused, or too early to tell).
    Running,
    /// The flags say it has ended: Done once the FSM agrees.
    FlagsEnded,
    /// It failed.
    Failed(Outcome),
}

impl Motion {
    /// A motion the robot accepted at `now`.
    pub(crate) fn new(source: Source, now: Instant) -> Self {
        Motion {
            source,
            since: now,
            grace_from: now,
            seen_moving: false,
            watchdog_fired: false,
            jog: None,
        }
    }

    /// A jog still held (not yet stopping): only its release, the
    /// heartbeat, a failure or a Stop end it.
    pub(crate) fn is_held_jog(&self) -> bool {
        self.jog.is_some_and(|j| !j.stopping)
    }

    /// Judges one `ReadRobotState` reply at `now`.
    pub(crate) fn judge(
        &mut self,
        rs: &ReadRobotState,
        config: &Config,
        now: Instant,
    ) -> Judgement {
        if rs.error != 0 {
            return Judgement::Failed(match rs.error_code {
                0 => Outcome::gateway(GatewayError::RobotErrorNoCode),
                c => Outcome::Error(ErrorSource::RobotMotion, c),
            });
        }
        if rs.emergency_stop != 0 {
            return Judgement::Failed(Outcome::gateway(GatewayError::EmergencyStop));
        }
        if rs.safety_guard != 0 {
            return Judgement::Failed(Outcome::gateway(GatewayError::SafetyGuard));
        }
        if rs.moving != 0 {
            self.seen_moving = true;
            return Judgement::Running;
        }
        if rs.paused != 0 {
            return Judgement::Running;
        }
        let grace_over =
            now.saturating_duration_since(self.grace_from) >= millis(config.start_grace_ms);
        if !(self.seen_moving || grace_over) {
            return Judgement::Running;
        }
        if self.is_held_jog() {
            // A jog standing still (at a limit) runs until it is released.
            return Judgement::Running;
        }
        let blend_ok = !config.wait_blending_done || rs.blending_done != 0;
        let pos_ok = !config.wait_in_position || rs.in_position != 0;
        if blend_ok && pos_ok {
            Judgement::FlagsEnded
        } else {
            Judgement::Running
        }
    }

    /// The FSM still shows the motion under way: the flags lagged.
    pub(crate) fn still_under_way(&mut self) {
        self.seen_moving = true;
    }

    /// A successful `GrpContinue` at `now`: the motion starts again, its
    /// moving flag lags as at the start, so the grace period starts again.
    pub(crate) fn restarted(&mut self, now: Instant) {
        self.grace_from = now;
        self.seen_moving = false;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn state(moving: i32, paused: i32) -> ReadRobotState {
        ReadRobotState {
            moving,
            enabled: 1,
            error: 0,
            error_code: 0,
            error_axis: 0,
            brake_released: 1,
            paused,
            emergency_stop: 0,
            safety_guard: 0,
            powered: 1,
            box_connected: 1,
            blending_done: 0,
            in_position: 0,
        }
    }

    fn at(ms: u64) -> Instant {
        Instant::from_millis(ms)
    }

    #[test]
    fn not_moving_counts_only_after_moving_or_the_grace_period() {
        let cfg = Config::default(); // grace 200 ms
        let mut m = Motion::new(Source::Channel(0), at(0));
        assert_eq!(m.judge(&state(0, 0), &cfg, at(50)), Judgement::Running);
        assert_eq!(m.judge(&state(0, 0), &cfg, at(200)), Judgement::FlagsEnded);
        let mut m = Motion::new(Source::Channel(0), at(0));
        assert_eq!(m.judge(&state(1, 0), &cfg, at(60)), Judgement::Running);
        assert_eq!(m.judge(&state(0, 0), &cfg, at(70)), Judgement::FlagsEnded);
        // Paused: Busy until Continue; after it, the grace period again.
        assert_eq!(m.judge(&state(0, 1), &cfg, at(80)), Judgement::Running);
        m.restarted(at(100));
        assert_eq!(m.judge(&state(0, 0), &cfg, at(150)), Judgement::Running);
    }

    #[test]
    fn faults_end_it_with_their_codes() {
        let cfg = Config::default();
        let mut m = Motion::new(Source::Raw, at(0));
        let mut rs = state(1, 0);
        rs.error = 1;
        rs.error_code = 20018;
        assert_eq!(
            m.judge(&rs, &cfg, at(10)),
            Judgement::Failed(Outcome::Error(ErrorSource::RobotMotion, 20018))
        );
        rs.error_code = 0;
        assert_eq!(
            m.judge(&rs, &cfg, at(10)),
            Judgement::Failed(Outcome::gateway(GatewayError::RobotErrorNoCode))
        );
        let mut rs = state(1, 0);
        rs.emergency_stop = 1;
        assert_eq!(
            m.judge(&rs, &cfg, at(10)),
            Judgement::Failed(Outcome::gateway(GatewayError::EmergencyStop))
        );
        let mut rs = state(0, 0);
        rs.safety_guard = 1;
        assert_eq!(
            m.judge(&rs, &cfg, at(10)),
            Judgement::Failed(Outcome::gateway(GatewayError::SafetyGuard))
        );
    }

    #[test]
    fn the_policy_waits_for_blending_and_position() {
        let cfg = Config {
            wait_blending_done: true,
            wait_in_position: true,
            ..Config::default()
        };
        let mut m = Motion::new(Source::Channel(1), at(0));
        m.seen_moving = true;
        let mut rs = state(0, 0);
        assert_eq!(m.judge(&rs, &cfg, at(10)), Judgement::Running);
        rs.blending_done = 1;
        assert_eq!(m.judge(&rs, &cfg, at(20)), Judgement::Running);
        rs.in_position = 1;
        assert_eq!(m.judge(&rs, &cfg, at(30)), Judgement::FlagsEnded);
    }
}
