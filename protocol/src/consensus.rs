//! Consensus notes for the run record (filled in by the consensus work).

use serde::{Deserialize, Serialize};

/// A consensus event a robot reports about itself.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ConsensusNote {
    /// This robot became leader of `term`.
    Leader {
        /// The term.
        term: u64,
    },
}

impl ConsensusNote {
    /// True when the robot says it is the leader now.
    pub fn claims_leadership(&self) -> bool {
        matches!(self, ConsensusNote::Leader { .. })
    }
}
