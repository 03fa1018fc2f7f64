//! The notes a robot reports about its own consensus state (within
//! [`swarmrt_protocol::MAX_REPORT`] bytes per tick, postcard-encoded like the messages).

use serde::{Deserialize, Serialize};

use super::messages::{ConsensusMsg, Decision};

/// A Raft role.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Role {
    /// Follows a leader (or waits for one).
    Follower,
    /// Asking for pre-votes; its term has not changed yet (thesis section 9.6).
    PreCandidate,
    /// Campaigning in its term.
    Candidate,
    /// Leader of its term.
    Leader,
}

/// Messages sent per kind, cumulative since the robot (re)started.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct SentCounts {
    /// [`ConsensusMsg::PreVote`] frames.
    pub pre_vote: u32,
    /// [`ConsensusMsg::PreVoteResp`] frames.
    pub pre_vote_resp: u32,
    /// [`ConsensusMsg::Vote`] frames.
    pub vote: u32,
    /// [`ConsensusMsg::VoteResp`] frames.
    pub vote_resp: u32,
    /// [`ConsensusMsg::Append`] frames.
    pub append: u32,
    /// [`ConsensusMsg::AppendResp`] frames.
    pub append_resp: u32,
    /// [`ConsensusMsg::QuadClaim`] frames.
    pub quad_claim: u32,
    /// [`ConsensusMsg::QuadLeader`] frames.
    pub quad_leader: u32,
}

impl SentCounts {
    /// Counts one frame of `msg`'s kind.
    pub fn count(&mut self, msg: &ConsensusMsg) {
        let c = match msg {
            ConsensusMsg::PreVote { .. } => &mut self.pre_vote,
            ConsensusMsg::PreVoteResp { .. } => &mut self.pre_vote_resp,
            ConsensusMsg::Vote { .. } => &mut self.vote,
            ConsensusMsg::VoteResp { .. } => &mut self.vote_resp,
            ConsensusMsg::Append { .. } => &mut self.append,
            ConsensusMsg::AppendResp { .. } => &mut self.append_resp,
            ConsensusMsg::QuadClaim { .. } => &mut self.quad_claim,
            ConsensusMsg::QuadLeader { .. } => &mut self.quad_leader,
        };
        *c = c.saturating_add(1);
    }

    /// `(kind, count)` pairs in a fixed order, kinds named as [`ConsensusMsg::kind`].
    pub fn pairs(&self) -> [(&'static str, u32); 8] {
        [
            ("pre_vote", self.pre_vote),
            ("pre_vote_resp", self.pre_vote_resp),
            ("vote", self.vote),
            ("vote_resp", self.vote_resp),
            ("append", self.append),
            ("append_resp", self.append_resp),
            ("quad_claim", self.quad_claim),
            ("quad_leader", self.quad_leader),
        ]
    }
}

/// A consensus event a robot reports about itself, written to `events.jsonl` as
/// `{"event":"note","tick":T,"robot":R,"note":{"consensus":{"<variant>":{...}}}}`.
///
/// The notes are complete: from them alone a checker rebuilds every robot's term, role, vote,
/// log (index, term, digest), commit and apply sequence. A robot emits a note only when
/// something changed, and never more than fits its report in one tick: it leaves a message
/// unprocessed (as if the radio had lost it) rather than change state it cannot report.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ConsensusNote {
    /// The robot (re)started with this persistent state (all zero for a fresh start).
    Boot {
        /// Current term.
        term: u64,
        /// Vote in that term.
        vote: Option<u32>,
        /// Last log index.
        last_index: u64,
        /// Commit index.
        commit: u64,
    },
    /// Term, role or vote changed (at most one note per tick: the state at the end of it).
    State {
        /// Current term.
        term: u64,
        /// Current role.
        role: Role,
        /// Who this robot voted for in `term`.
        vote: Option<u32>,
    },
    /// An entry was appended at `index`.
    Append {
        /// Its index.
        index: u64,
        /// Its term.
        term: u64,
        /// [`super::messages::Entry::digest`].
        digest: u32,
    },
    /// Entries from `index` on were removed (a conflict with the leader, Raft section 5.3).
    Truncate {
        /// First removed index.
        index: u64,
    },
    /// The commit index advanced to `index`.
    Commit {
        /// New commit index.
        index: u64,
    },
    /// The entry at `index` was applied (acted on).
    Apply {
        /// Its index.
        index: u64,
        /// Its term.
        term: u64,
        /// [`super::messages::Entry::digest`].
        digest: u32,
    },
    /// As leader, the robot put scheduled decision `id` into its log at `index`.
    Propose {
        /// Its index.
        index: u64,
        /// Its term.
        term: u64,
        /// Position in `consensus.propose`.
        id: u16,
        /// The decision.
        decision: Decision,
    },
    /// Radio messages sent so far, per kind (emitted every `consensus.stats_every` ticks when
    /// changed).
    Sent(SentCounts),
    /// Quadrant leader choice: the leader this robot believes in changed.
    Quadrant {
        /// The believed leader (itself when it declared itself leader).
        leader: u32,
        /// True when that is this robot: it declared itself leader of its group.
        leads: bool,
        /// This robot's own score (most group members seen in one quadrant).
        score: u8,
    },
}

impl ConsensusNote {
    /// True when the robot says it is the leader now: it became Raft leader of its term, or
    /// declared itself quadrant leader (the target of a `"leader"` fault).
    pub fn claims_leadership(&self) -> bool {
        matches!(
            self,
            ConsensusNote::State {
                role: Role::Leader,
                ..
            } | ConsensusNote::Quadrant { leads: true, .. }
        )
    }
}
