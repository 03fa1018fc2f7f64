//! What a robot tells the run record about its own decisions, carried in
//! [`crate::Command::report`]. The world checks the encoding and writes every note to
//! `events.jsonl`; it never acts on them. Metrics and the consensus checker read them back
//! from the record, so both modes give the same numbers.

use serde::{Deserialize, Serialize};

use crate::consensus::ConsensusNote;

/// Bytes a robot may report per tick.
pub const MAX_REPORT: usize = 256;

/// One note from a robot about itself.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Note {
    /// The observer role this robot believes it holds changed (seed 000, eq. 4-5):
    /// 0 none, 1 middle, 2 left, 3 right.
    Role {
        /// The new role.
        role: u8,
    },
    /// The turn this robot decided for the swarm changed: -1 right, 0 straight, +1 left.
    Turn {
        /// The new direction.
        dir: i8,
    },
    /// Epsilon-greedy chose the opposite turn this tick (seed 000, section 5.3).
    EpsilonFlip,
    /// Consensus state changes and log events.
    Consensus(ConsensusNote),
}

impl Note {
    /// True when the robot says it is the leader now (the target of a `"leader"` fault).
    pub fn claims_leadership(&self) -> bool {
        matches!(self, Note::Consensus(c) if c.claims_leadership())
    }
}
