//! The command log: the last [`LOG_LEN`] commands and link events, for
//! the web page and `/api/log`.
//!
//! A command's entry opens at its rising edge (or trigger bit) and is
//! filled as it goes: the text sent to the robot, the reply, the outcome
//! and the time from the edge to the outcome. When the log is full the
//! oldest entry is dropped (a command still running whose entry was
//! dropped gets a new one when it ends, without its text). Texts are cut
//! at [`LOG_TEXT`] bytes.

use core::net::Ipv4Addr;

use embassy_time::Instant;
use heapless::{Deque, Vec};

use crate::error::{GatewayError, Outcome};
use crate::job::Source;

/// Entries kept: 32 in builds with the web page (feature `web`), else 1
/// (nothing reads it).
pub const LOG_LEN: usize = if cfg!(feature = "web") { 32 } else { 1 };
/// Bytes kept of a request or reply text.
pub const LOG_TEXT: usize = 64;

/// One event.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum LogEvent {
    /// A PLC command.
    Command(CommandEntry),
    /// The robot link came up (the controller's address).
    LinkUp(Option<Ipv4Addr>),
    /// The robot link went down, and why.
    LinkDown(GatewayError),
}

/// A command's course.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct CommandEntry {
    /// Who fired it.
    pub source: Source,
    /// The channel's command code (0 for RAW and triggers).
    pub code: u16,
    /// The last request sent to the robot (empty if none was).
    pub sent: Vec<u8, LOG_TEXT>,
    /// The robot's last reply (empty if none came).
    pub reply: Vec<u8, LOG_TEXT>,
    /// The outcome; `None` while it runs.
    pub outcome: Option<Outcome>,
    /// Milliseconds from the edge to the outcome.
    pub took_ms: u32,
}

/// An event and when it happened.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct LogEntry {
    /// When (the gateway's clock).
    pub at: Instant,
    /// What.
    pub event: LogEvent,
}

/// The log (oldest first).
#[derive(Default)]
pub struct CommandLog {
    entries: Deque<LogEntry, LOG_LEN>,
    /// Events logged since start (the page tells new ones by it).
    pub total: u32,
}

fn cut(text: &[u8]) -> Vec<u8, LOG_TEXT> {
    let mut v = Vec::new();
    let _ = v.extend_from_slice(text.get(..LOG_TEXT).unwrap_or(text));
    v
}

impl CommandLog {
    /// The entries, oldest first.
    pub fn iter(&self) -> impl Iterator<Item = &LogEntry> {
        self.entries.iter()
    }

    fn push(&mut self, at: Instant, event: LogEvent) {
        if self.entries.is_full() {
            self.entries.pop_front();
        }
        let _ = self.entries.push_back(LogEntry { at, event });
        self.total = self.total.wrapping_add(1);
    }

    fn open(&mut self, source: Source) -> Option<(&mut CommandEntry, Instant)> {
        self.entries
            .iter_mut()
            .rev()
            .find_map(|e| match &mut e.event {
                LogEvent::Command(c) if c.source == source && c.outcome.is_none() => {
                    Some((c, e.at))
                }
                _ => None,
            })
    }

    /// A command started at `at`.
    pub fn started(&mut self, source: Source, code: u16, at: Instant) {
        // A command of this source still open was ended without a word
        // (cannot happen: one command per source at a time); close it.
        if let Some((c, _)) = self.open(source) {
            c.outcome = Some(Outcome::Aborted);
        }
        self.push(
            at,
            LogEvent::Command(CommandEntry {
                source,
                code,
                sent: Vec::new(),
                reply: Vec::new(),
                outcome: None,
                took_ms: 0,
            }),
        );
    }

    /// The command's request `text` went to the robot.
    pub fn sent(&mut self, source: Source, text: &[u8]) {
        if let Some((c, _)) = self.open(source) {
            c.sent = cut(text);
        }
    }

    /// The robot replied `text` to the command's request.
    pub fn replied(&mut self, source: Source, text: &[u8]) {
        if let Some((c, _)) = self.open(source) {
            c.reply = cut(text);
        }
    }

    /// The command ended at `now`.
    pub fn ended(&mut self, source: Source, outcome: Outcome, now: Instant) {
        match self.open(source) {
            Some((c, at)) => {
                c.outcome = Some(outcome);
                c.took_ms = u32::try_from(now.saturating_duration_since(at).as_millis())
                    .unwrap_or(u32::MAX);
            }
            None => self.push(
                now,
                LogEvent::Command(CommandEntry {
                    source,
                    code: 0,
                    sent: Vec::new(),
                    reply: Vec::new(),
                    outcome: Some(outcome),
                    took_ms: 0,
                }),
            ),
        }
    }

    /// The link came up or went down at `now`.
    pub fn link(&mut self, event: LogEvent, now: Instant) {
        self.push(now, event);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::error::ErrorSource;

    fn t(ms: u64) -> Instant {
        Instant::from_millis(ms)
    }

    #[test]
    fn a_command_is_followed_from_edge_to_outcome() {
        let mut log = CommandLog::default();
        log.started(Source::Channel(0), 12, t(100));
        log.started(Source::Raw, 0, t(110));
        log.sent(Source::Channel(0), b"MoveL,0,1,2,3,;");
        log.replied(Source::Channel(0), b"MoveL,OK,;");
        log.ended(
            Source::Raw,
            Outcome::Error(ErrorSource::Gateway, 39500),
            t(111),
        );
        log.ended(Source::Channel(0), Outcome::Done, t(350));
        let e: std::vec::Vec<_> = log.iter().collect();
        assert_eq!(e.len(), 2);
        let LogEvent::Command(c) = &e[0].event else {
            panic!("not a command")
        };
        assert_eq!(
            (c.code, &c.sent[..], &c.reply[..], c.outcome, c.took_ms),
            (
                12,
                &b"MoveL,0,1,2,3,;"[..],
                &b"MoveL,OK,;"[..],
                Some(Outcome::Done),
                250
            )
        );
        assert_eq!(log.total, 2);
    }

    #[test]
    fn the_log_keeps_the_newest_entries_and_cuts_long_texts() {
        let mut log = CommandLog::default();
        for i in 0..(LOG_LEN as u64 + 5) {
            log.link(LogEvent::LinkDown(GatewayError::LinkLost), t(i));
        }
        assert_eq!(log.iter().count(), LOG_LEN);
        assert_eq!(log.iter().next().map(|e| e.at), Some(t(5)));
        log.started(Source::Trigger(3), 0, t(1000));
        log.sent(Source::Trigger(3), &[b'x'; 200]);
        let last = log.iter().last().cloned();
        let Some(LogEntry {
            event: LogEvent::Command(c),
            ..
        }) = last
        else {
            panic!("not a command")
        };
        assert_eq!(c.sent.len(), LOG_TEXT);
        // Ending a command whose entry is gone logs it anew.
        log.ended(Source::Channel(1), Outcome::Aborted, t(2000));
        assert!(matches!(
            log.iter().last().map(|e| &e.event),
            Some(LogEvent::Command(CommandEntry {
                source: Source::Channel(1),
                outcome: Some(Outcome::Aborted),
                ..
            }))
        ));
    }
}
