//! Fault injection on the command port.
//!
//! A [`Fault`] changes how the simulator answers; a [`FaultRule`] says which
//! requests it applies to (a command name or all) and how many times (or
//! forever). Every rule that matches a request applies, in the order the
//! rules were added: delays add up, and for the reply itself the last
//! matching rule wins.
//!
//! Whether the request is still *executed* depends on the fault:
//!
//! | fault | executed? | what the client sees |
//! |---|---|---|
//! | [`Fault::Delay`] | yes | the normal reply, late |
//! | [`Fault::Split`] | yes | the normal reply in several TCP segments |
//! | [`Fault::NoReply`] | yes | nothing (the reply is lost) |
//! | [`Fault::DropConnection`] | yes | the connection closes instead of the reply |
//! | [`Fault::GarbageBefore`] | yes | garbage bytes, then the normal reply |
//! | [`Fault::Garbage`] | no | garbage bytes instead of the reply |
//! | [`Fault::Fail`] | no | `Name,Fail,code,;` or `Name,Fail,code,detail,;` |
//! | [`Fault::ErrorCmd`] | no | `errorcmd,20007,;` |
//!
//! Rules are kept in a bounded list ([`MAX_RULES`]); adding more replaces
//! the oldest.

use std::collections::VecDeque;
use std::fmt;
use std::sync::Mutex;
use std::time::Duration;

/// Most rules kept at once; the oldest is dropped when a new one would
/// exceed it.
pub const MAX_RULES: usize = 64;

/// One way of misbehaving.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Fault {
    /// Reply after this much real time.
    Delay(Duration),
    /// Write the reply in chunks of `chunk` bytes with `pause` between them
    /// (each chunk is its own TCP segment).
    Split {
        /// Bytes per chunk (at least 1).
        chunk: usize,
        /// Pause between chunks.
        pause: Duration,
    },
    /// Execute the request but send no reply.
    NoReply,
    /// Execute the request, then close the connection without replying.
    DropConnection,
    /// Send these bytes instead of the reply (the request is not executed).
    Garbage(Vec<u8>),
    /// Send these bytes, then the normal reply.
    GarbageBefore(Vec<u8>),
    /// Answer `Name,Fail,code,;` (or `...,code,detail,;` when `detail` is not
    /// empty) without executing the request.
    Fail {
        /// The error code.
        code: i32,
        /// The explanation text (printable ASCII without `;`), may be empty.
        detail: String,
    },
    /// Answer `errorcmd,20007,;` without executing the request.
    ErrorCmd,
}

/// A fault and the requests it applies to.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct FaultRule {
    /// The fault.
    pub fault: Fault,
    /// Only requests with this command name (as sent); `None` = all.
    pub command: Option<String>,
    /// How many more requests it applies to; `None` = until cleared.
    pub times: Option<u32>,
}

impl FaultRule {
    /// A rule applying `fault` to every request until cleared.
    pub fn new(fault: Fault) -> Self {
        FaultRule {
            fault,
            command: None,
            times: None,
        }
    }

    /// Restricts the rule to requests named `command`.
    pub fn only(mut self, command: &str) -> Self {
        self.command = Some(command.to_string());
        self
    }

    /// Applies the rule to `n` matching requests, then drops it.
    pub fn times(mut self, n: u32) -> Self {
        self.times = Some(n);
        self
    }

    /// Parses the command-line form `KIND[=ARG][@COMMAND][*TIMES]`:
    ///
    /// | KIND | ARG |
    /// |---|---|
    /// | `delay` | milliseconds |
    /// | `split` | chunk bytes (default 3), pause 20 ms |
    /// | `noreply`, `drop`, `errorcmd` | none |
    /// | `garbage`, `garbage-before` | text (default bytes `FF 00 garbage`) |
    /// | `fail` | `CODE` or `CODE:DETAIL` |
    ///
    /// Examples: `delay=300`, `fail=20018:robot busy@WayPoint`, `noreply*1`.
    pub fn parse(spec: &str) -> Result<FaultRule, String> {
        let (spec, times) = match spec.rsplit_once('*') {
            Some((s, n)) => (
                s,
                Some(
                    n.trim()
                        .parse::<u32>()
                        .map_err(|_| format!("bad count {n:?} in fault {spec:?}"))?,
                ),
            ),
            None => (spec, None),
        };
        let (spec, command) = match spec.split_once('@') {
            Some((s, c)) if !c.trim().is_empty() => (s, Some(c.trim().to_string())),
            Some(_) => return Err(format!("empty command name in fault {spec:?}")),
            None => (spec, None),
        };
        let (kind, arg) = match spec.split_once('=') {
            Some((k, a)) => (k.trim(), Some(a)),
            None => (spec.trim(), None),
        };
        let ms = |a: Option<&str>, default: u64| -> Result<u64, String> {
            match a {
                None => Ok(default),
                Some(a) => a
                    .trim()
                    .parse()
                    .map_err(|_| format!("bad number {a:?} in fault {kind:?}")),
            }
        };
        let fault = match kind {
            "delay" => Fault::Delay(Duration::from_millis(ms(arg, 200)?)),
            "split" => Fault::Split {
                chunk: usize::try_from(ms(arg, 3)?.max(1)).unwrap_or(3),
                pause: Duration::from_millis(20),
            },
            "noreply" => Fault::NoReply,
            "drop" => Fault::DropConnection,
            "errorcmd" => Fault::ErrorCmd,
            "garbage" => {
                Fault::Garbage(arg.map_or_else(default_garbage, |a| a.as_bytes().to_vec()))
            }
            "garbage-before" => {
                Fault::GarbageBefore(arg.map_or_else(default_garbage, |a| a.as_bytes().to_vec()))
            }
            "fail" => {
                let a = arg.ok_or("fail needs a code: fail=20018 or fail=20018:detail")?;
                let (code, detail) = a.split_once(':').unwrap_or((a, ""));
                let code = code
                    .trim()
                    .parse::<i32>()
                    .map_err(|_| format!("bad error code {code:?}"))?;
                if detail
                    .bytes()
                    .any(|b| !(0x20..0x7f).contains(&b) || b == b';')
                {
                    return Err("the detail must be printable ASCII without ';'".into());
                }
                Fault::Fail {
                    code,
                    detail: detail.to_string(),
                }
            }
            other => return Err(format!("unknown fault kind {other:?}")),
        };
        Ok(FaultRule {
            fault,
            command,
            times,
        })
    }
}

/// The default garbage: a non-ASCII byte, a NUL and some text.
pub fn default_garbage() -> Vec<u8> {
    b"\xff\x00garbage".to_vec()
}

impl fmt::Display for Fault {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Fault::Delay(d) => write!(f, "delay {} ms", d.as_millis()),
            Fault::Split { chunk, pause } => {
                write!(
                    f,
                    "split into {chunk}-byte chunks every {} ms",
                    pause.as_millis()
                )
            }
            Fault::NoReply => f.write_str("no reply"),
            Fault::DropConnection => f.write_str("drop the connection"),
            Fault::Garbage(g) => write!(f, "garbage ({} bytes) instead of the reply", g.len()),
            Fault::GarbageBefore(g) => write!(f, "garbage ({} bytes) before the reply", g.len()),
            Fault::Fail { code, detail } => write!(f, "Fail,{code} {detail:?}"),
            Fault::ErrorCmd => f.write_str("errorcmd"),
        }
    }
}

/// What to do with one request, after all matching rules.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub(crate) struct Plan {
    pub delay: Duration,
    pub split: Option<(usize, Duration)>,
    pub action: Action,
}

/// How the reply is replaced, if at all.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub(crate) enum Action {
    #[default]
    Reply,
    NoReply,
    Drop,
    Replace(Vec<u8>),
    Prefix(Vec<u8>),
    Fail(i32, String),
    ErrorCmd,
}

impl Action {
    /// `false` when the request must not be executed.
    pub fn executes(&self) -> bool {
        !matches!(
            self,
            Action::Replace(_) | Action::Fail(..) | Action::ErrorCmd
        )
    }
}

/// The fault rules of one simulator. Get it with `Sim::faults()`.
#[derive(Debug, Default)]
pub struct Faults {
    rules: Mutex<VecDeque<FaultRule>>,
}

impl Faults {
    fn lock(&self) -> std::sync::MutexGuard<'_, VecDeque<FaultRule>> {
        self.rules.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// Applies `fault` to every request until [`Faults::clear`].
    pub fn set(&self, fault: Fault) {
        self.add(FaultRule::new(fault));
    }

    /// Applies `fault` to the next request only.
    pub fn once(&self, fault: Fault) {
        self.add(FaultRule::new(fault).times(1));
    }

    /// Adds a rule (see [`FaultRule`]).
    pub fn add(&self, rule: FaultRule) {
        let mut g = self.lock();
        if g.len() >= MAX_RULES {
            g.pop_front();
        }
        g.push_back(rule);
    }

    /// Removes every rule.
    pub fn clear(&self) {
        self.lock().clear();
    }

    /// The rules in force.
    pub fn rules(&self) -> Vec<FaultRule> {
        self.lock().iter().cloned().collect()
    }

    /// Consumes the rules that match a request named `name`.
    pub(crate) fn plan_for(&self, name: &str) -> Plan {
        let mut g = self.lock();
        let mut plan = Plan::default();
        for rule in g.iter_mut() {
            if rule.times == Some(0) {
                continue;
            }
            if rule.command.as_deref().is_some_and(|c| c != name) {
                continue;
            }
            if let Some(n) = rule.times.as_mut() {
                *n -= 1;
            }
            match &rule.fault {
                Fault::Delay(d) => plan.delay += *d,
                Fault::Split { chunk, pause } => plan.split = Some(((*chunk).max(1), *pause)),
                Fault::NoReply => plan.action = Action::NoReply,
                Fault::DropConnection => plan.action = Action::Drop,
                Fault::Garbage(g) => plan.action = Action::Replace(g.clone()),
                Fault::GarbageBefore(g) => plan.action = Action::Prefix(g.clone()),
                Fault::Fail { code, detail } => plan.action = Action::Fail(*code, detail.clone()),
                Fault::ErrorCmd => plan.action = Action::ErrorCmd,
            }
        }
        g.retain(|r| r.times != Some(0));
        plan
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rules_match_count_and_combine() {
        let f = Faults::default();
        f.set(Fault::Delay(Duration::from_millis(10)));
        f.add(FaultRule::new(Fault::NoReply).only("WayPoint").times(1));
        f.once(Fault::Delay(Duration::from_millis(5)));
        let p = f.plan_for("ReadRobotState");
        assert_eq!(p.delay, Duration::from_millis(15));
        assert_eq!(p.action, Action::Reply);
        let p = f.plan_for("WayPoint");
        assert_eq!(
            (p.delay, p.action),
            (Duration::from_millis(10), Action::NoReply)
        );
        let p = f.plan_for("WayPoint");
        assert_eq!(p.action, Action::Reply);
        assert_eq!(f.rules().len(), 1);
        f.clear();
        assert_eq!(f.plan_for("X"), Plan::default());
    }

    #[test]
    fn command_line_specs() {
        let r = FaultRule::parse("fail=20018:robot busy@WayPoint*2").unwrap();
        assert_eq!(
            r,
            FaultRule::new(Fault::Fail {
                code: 20018,
                detail: "robot busy".into()
            })
            .only("WayPoint")
            .times(2)
        );
        assert_eq!(
            FaultRule::parse("delay=300").unwrap().fault,
            Fault::Delay(Duration::from_millis(300))
        );
        assert!(FaultRule::parse("explode").is_err());
        assert!(FaultRule::parse("fail=abc").is_err());
        assert!(FaultRule::parse("fail=1:a;b").is_err());
        assert!(FaultRule::parse("noreply*x").is_err());
    }

    #[test]
    fn the_rule_list_is_bounded() {
        let f = Faults::default();
        for _ in 0..MAX_RULES + 10 {
            f.set(Fault::NoReply);
        }
        assert_eq!(f.rules().len(), MAX_RULES);
    }
}
