//! Section 4.3: scripts. A script "runs" for [`Timing::script`] (FSM 34);
//! pausing and stopping take [`Timing::script_transition`] (35 → 36, 37 →
//! 33). Only the functions of `Config::script_functions` exist.
//!
//! [`Timing::script`]: super::Timing::script
//! [`Timing::script_transition`]: super::Timing::script_transition

use hans_codec::{request as rq, response as rs};

use super::dispatch::{done, values, Outcome, STATE};
use super::{Robot, Script};

/// `RunFunc` of a function the script does not have.
const NO_SUCH_FUNCTION: i32 = 20601;

impl Robot {
    fn script_start(&mut self, now: f64) {
        self.script = Some(Script::Running {
            until: now + self.timing.script.as_secs_f64(),
        });
    }

    pub(super) fn run_func<'s>(&mut self, c: &rq::RunFunc<'s>, now: f64) -> Outcome<'s> {
        self.need_standby(now)?;
        if !self.script_functions.iter().any(|f| f == c.func_name) {
            return Err(NO_SUCH_FUNCTION);
        }
        self.script_start(now);
        values(rs::RunFunc {
            func_name: c.func_name,
        })
    }

    pub(super) fn start_script(&mut self, now: f64) -> Outcome<'_> {
        self.need_standby(now)?;
        self.script_start(now);
        done()
    }

    pub(super) fn stop_script(&mut self, now: f64) -> Outcome<'_> {
        if matches!(
            self.script,
            Some(Script::Running { .. } | Script::Pausing { .. } | Script::Held { .. })
        ) {
            self.script = Some(Script::Stopping {
                until: now + self.timing.script_transition.as_secs_f64(),
            });
        }
        done()
    }

    pub(super) fn pause_script(&mut self, now: f64) -> Outcome<'_> {
        match self.script {
            Some(Script::Running { until }) => {
                self.script = Some(Script::Pausing {
                    until: now + self.timing.script_transition.as_secs_f64(),
                    remaining: until - now,
                });
                done()
            }
            _ => Err(STATE),
        }
    }

    pub(super) fn continue_script(&mut self, now: f64) -> Outcome<'_> {
        match self.script {
            Some(Script::Held { remaining }) => {
                self.script = Some(Script::Running {
                    until: now + remaining,
                });
                done()
            }
            _ => Err(STATE),
        }
    }

    // ------------------------------------------------ V6 document 4.3

    /// `SwitchScript`: not while a script runs.
    pub(super) fn switch_script(&mut self, c: &rq::SwitchScript) -> Outcome<'_> {
        if self.script.is_some() {
            return Err(STATE);
        }
        self.stored.script_file = c.script.to_string();
        done()
    }

    pub(super) fn read_default_script(&self) -> Outcome<'_> {
        values(rs::ReadDefaultScript {
            script: &self.stored.script_file,
        })
    }
}
