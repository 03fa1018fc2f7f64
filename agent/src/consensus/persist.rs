//! What of a robot's Raft state must survive a crash, and what of it changed in one tick.
//!
//! Shaped after raft-rs's `Ready`: a step hands over only what changed since the last hand-over
//! ([`Persist`]: the hard state if it moved, the log from the first index touched), and the
//! caller makes that durable before the tick's messages leave. [`Persistent`] is the whole
//! state, as stable storage holds it and a restarted robot is built from.

use super::log::Log;
use super::messages::Entry;

/// What a robot must keep across a crash (Figure 2: "persistent state on all servers", plus
/// the commit index as raft-rs's `HardState` does).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Persistent {
    /// Current term.
    pub term: u64,
    /// Vote in that term.
    pub vote: Option<u32>,
    /// Commit index.
    pub commit: u64,
    /// The log.
    pub log: Log,
}

/// The persistent state besides the log (raft-rs's `HardState`).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct HardState {
    /// Current term.
    pub term: u64,
    /// Vote in that term.
    pub vote: Option<u32>,
    /// Commit index.
    pub commit: u64,
}

/// The log from index `first` on, replacing whatever the stored log held there (entries
/// past the new end were truncated).
#[derive(Debug, Clone, PartialEq)]
pub struct LogSuffix {
    /// Index of the first entry of `entries` (1-based).
    pub first: u64,
    /// The entries at `first`, `first + 1`, ...
    pub entries: Vec<Entry>,
}

/// What changed in a robot's persistent state since it was last handed over; it must be
/// durable before the command of the tick that produced it leaves (write-ahead).
#[derive(Debug, Clone, PartialEq)]
pub struct Persist {
    /// The hard state, when it changed.
    pub hard: Option<HardState>,
    /// The log's changed tail, when the log changed.
    pub log: Option<LogSuffix>,
}

impl Persist {
    /// The change that turns an empty state into `state` (for a store written whole).
    pub fn whole(state: &Persistent) -> Persist {
        Persist {
            hard: Some(state.hard_state()),
            log: Some(LogSuffix {
                first: 1,
                entries: state.log.entries().to_vec(),
            }),
        }
    }
}

impl Persistent {
    /// Its hard state.
    pub fn hard_state(&self) -> HardState {
        HardState {
            term: self.term,
            vote: self.vote,
            commit: self.commit,
        }
    }

    /// Applies a change handed over by a step.
    pub fn apply(&mut self, change: &Persist) {
        if let Some(h) = change.hard {
            (self.term, self.vote, self.commit) = (h.term, h.vote, h.commit);
        }
        if let Some(tail) = &change.log {
            self.log.truncate_from(tail.first);
            for e in &tail.entries {
                self.log.push(*e);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::consensus::Item;

    fn e(term: u64) -> Entry {
        Entry {
            term,
            item: Item::Noop,
        }
    }

    #[test]
    fn a_change_replaces_the_tail_and_the_hard_state() {
        let mut s = Persistent {
            term: 2,
            vote: Some(1),
            commit: 1,
            log: Log::from_entries(vec![e(1), e(1), e(2)]),
        };
        s.apply(&Persist {
            hard: Some(HardState {
                term: 3,
                vote: None,
                commit: 2,
            }),
            log: Some(LogSuffix {
                first: 2,
                entries: vec![e(3)],
            }),
        });
        assert_eq!((s.term, s.vote, s.commit), (3, None, 2));
        assert_eq!(s.log.entries(), &[e(1), e(3)]);
        // A change without a hard state leaves it; `whole` rebuilds the state from nothing.
        s.apply(&Persist {
            hard: None,
            log: None,
        });
        assert_eq!(s.hard_state().term, 3);
        let mut rebuilt = Persistent::default();
        rebuilt.apply(&Persist::whole(&s));
        assert_eq!(rebuilt, s);
    }
}
