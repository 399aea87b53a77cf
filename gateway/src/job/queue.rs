//! The command queue: ordinary commands in FIFO order, and an urgent lane
//! that goes first.
//!
//! Bounds: [`QUEUE_DEPTH`] ordinary jobs (a command fired when they are all
//! taken ends in Error 39600 at once, nothing is dropped silently) and
//! [`URGENT_DEPTH`] urgent ones: one per source, and a source has at most
//! one job at a time (a rising edge while Busy is ignored), so the urgent
//! lane cannot fill up.

use super::{Job, JobKind, Source, Urgent};
use super::{CHANNELS, TRIGGERS};

/// Ordinary jobs the queue holds.
pub const QUEUE_DEPTH: usize = 8;
/// Room of the urgent lane: one job per source (two channels, RAW, sixteen
/// trigger entries).
pub const URGENT_DEPTH: usize = CHANNELS + 1 + TRIGGERS;

/// An urgent job: small, so that the lane that is never full costs little.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct UrgentJob {
    source: Source,
    seq: u16,
    robot: u8,
    urgent: Urgent,
}

impl UrgentJob {
    fn job(self) -> Job {
        Job {
            source: self.source,
            seq: self.seq,
            robot: self.robot,
            kind: JobKind::Urgent(self.urgent),
        }
    }
}

/// What may leave the queue now.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Gate {
    /// Anything (nothing runs on the robot).
    Open,
    /// A motion runs: ordinary commands go on, but a motion at the head of
    /// the ordinary queue waits (and so does everything behind it).
    MotionRunning,
    /// Only urgent commands (a bring-up step waits for its state).
    UrgentOnly,
}

/// The queue.
#[derive(Default)]
pub struct JobQueue {
    ordinary: heapless::Deque<Job, QUEUE_DEPTH>,
    urgent: heapless::Deque<UrgentJob, URGENT_DEPTH>,
}

impl JobQueue {
    /// An empty queue.
    pub const fn new() -> Self {
        JobQueue {
            ordinary: heapless::Deque::new(),
            urgent: heapless::Deque::new(),
        }
    }

    /// Queues a job; gives it back when there is no room (as heapless'
    /// pushes do: nothing is lost, the caller reports it).
    #[allow(clippy::result_large_err)] // the job itself, moved back, no copy kept
    pub fn push(&mut self, job: Job) -> Result<(), Job> {
        if let JobKind::Urgent(urgent) = job.kind {
            let u = UrgentJob {
                source: job.source,
                seq: job.seq,
                robot: job.robot,
                urgent,
            };
            return self.urgent.push_back(u).map_err(UrgentJob::job);
        }
        self.ordinary.push_back(job)
    }

    /// Takes the next job allowed through `gate`: urgent jobs first.
    pub fn take(&mut self, gate: Gate) -> Option<Job> {
        if let Some(u) = self.urgent.pop_front() {
            return Some(u.job());
        }
        if self.can_take(gate) {
            self.ordinary.pop_front()
        } else {
            None
        }
    }

    /// `true` if [`Self::take`] would give a job now.
    pub fn can_take(&self, gate: Gate) -> bool {
        if !self.urgent.is_empty() {
            return true;
        }
        self.ordinary.front().is_some_and(|head| match gate {
            Gate::Open => true,
            Gate::MotionRunning => !head.is_motion(),
            Gate::UrgentOnly => false,
        })
    }

    /// `true` if an urgent job waits.
    pub fn has_urgent(&self) -> bool {
        !self.urgent.is_empty()
    }

    /// Jobs waiting.
    pub fn len(&self) -> usize {
        self.ordinary.len() + self.urgent.len()
    }

    /// `true` when nothing waits.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// `true` when the ordinary queue is full.
    pub fn is_full(&self) -> bool {
        self.ordinary.is_full()
    }

    /// Removes every waiting motion job and returns their sources, oldest
    /// first (a stop ends them all).
    pub fn take_motions(&mut self) -> heapless::Vec<Source, QUEUE_DEPTH> {
        let mut taken = heapless::Vec::new();
        let mut kept = heapless::Deque::<Job, QUEUE_DEPTH>::new();
        while let Some(j) = self.ordinary.pop_front() {
            if j.is_motion() {
                // At most QUEUE_DEPTH: always fits.
                let _ = taken.push(j.source);
            } else {
                let _ = kept.push_back(j);
            }
        }
        self.ordinary = kept;
        taken
    }

    /// Removes every job and returns their sources (urgent lane first).
    pub fn drain_sources(&mut self) -> heapless::Vec<Source, { QUEUE_DEPTH + URGENT_DEPTH }> {
        let mut out = heapless::Vec::new();
        while let Some(u) = self.urgent.pop_front() {
            // Both lanes together fit.
            let _ = out.push(u.source);
        }
        while let Some(j) = self.ordinary.pop_front() {
            let _ = out.push(j.source);
        }
        out
    }

    /// The jobs waiting, urgent lane first, in the order they go out (for
    /// views).
    pub fn sources(&self) -> impl Iterator<Item = Source> + '_ {
        self.urgent
            .iter()
            .map(|u| u.source)
            .chain(self.ordinary.iter().map(|j| j.source))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::job::text;

    fn job(source: Source, t: &str) -> Job {
        let (kind, robot) = text::build(t.as_bytes()).unwrap();
        Job {
            source,
            seq: 0,
            robot: robot.unwrap_or(0),
            kind,
        }
    }

    fn text_of(j: &Job) -> String {
        let mut buf = [0u8; 300];
        let m = j.encode(0, &mut buf).unwrap();
        String::from_utf8(buf[..m.len].to_vec()).unwrap()
    }

    #[test]
    fn urgent_commands_pass_a_full_queue_and_stop_finds_the_motions() {
        let mut q = JobQueue::new();
        q.push(job(Source::Trigger(0), "MoveRelJ,0,1,1,5,;"))
            .unwrap();
        for i in 1..QUEUE_DEPTH as u8 {
            q.push(job(Source::Trigger(i), "SetBoxDO,1,1,;")).unwrap();
        }
        assert!(q.is_full());
        let refused = q.push(job(Source::Raw, "SetBoxDO,2,1,;")).unwrap_err();
        assert_eq!(refused.source, Source::Raw);
        // Every source may queue an urgent command at once, all accepted.
        let urgent = ["GrpStop,0,;", "GrpInterrupt,0,;", "GrpContinue,0,;"];
        for (i, t) in urgent.iter().enumerate() {
            q.push(job(Source::Trigger(10 + i as u8), t)).unwrap();
        }
        // Blanks or not, the canonical form goes out.
        q.push(job(Source::Raw, "GrpReset,  0 ,;")).unwrap();
        assert_eq!(q.len(), QUEUE_DEPTH + 4);
        // Urgent first, in order, even while a motion blocks the queue.
        for t in urgent {
            let j = q.take(Gate::UrgentOnly).unwrap();
            assert_eq!(text_of(&j), t);
        }
        assert_eq!(
            text_of(&q.take(Gate::MotionRunning).unwrap()),
            "GrpReset,0,;"
        );
        assert!(!q.has_urgent());
        // The motion at the head waits, and everything behind it.
        assert!(q.take(Gate::MotionRunning).is_none());
        assert!(q.take(Gate::UrgentOnly).is_none());
        // A stop takes the waiting motions out; the rest goes on.
        assert_eq!(q.take_motions().as_slice(), [Source::Trigger(0)]);
        assert!(q.take_motions().is_empty());
        assert_eq!(
            q.take(Gate::MotionRunning).unwrap().source,
            Source::Trigger(1)
        );
        let rest = q.drain_sources();
        assert_eq!(rest.len(), QUEUE_DEPTH - 2);
        assert!(q.is_empty());
    }
}
