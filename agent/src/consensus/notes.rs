//! The notes a robot reports about its own consensus state (within
//! [`swarmrt_protocol::MAX_REPORT`] bytes per tick, postcard-encoded like the messages).
//! How notes read back from `events.jsonl`: [`RecordedNote`] tells a consensus note from a
//! behaviour's, and [`behaviour_notes`] gives a behaviour's metrics its own notes, typed.

use serde::de::DeserializeOwned;
use serde::{Deserialize, Serialize};
use serde_json::Value;
use swarmrt_protocol::records::Records;

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

/// A note as `events.jsonl` records it (the `note` field of a `note` event): the consensus
/// layer's tagged, `{"consensus":{...}}`, a behaviour's as itself (`N`, the behaviour's
/// [`crate::behaviour::Behaviour::Note`]). How [`crate::registry::Note::to_json`] writes them.
#[derive(Debug, Clone, PartialEq)]
pub enum RecordedNote<N> {
    /// A consensus note.
    Consensus(ConsensusNote),
    /// A behaviour's note.
    Behaviour(N),
}

impl<N: DeserializeOwned> RecordedNote<N> {
    /// Decodes a recorded note: an object with a `consensus` key must be a [`ConsensusNote`],
    /// anything else an `N`; `Err` says why it is neither.
    pub fn from_json(note: &Value) -> Result<RecordedNote<N>, serde_json::Error> {
        match note.as_object().and_then(|o| o.get("consensus")) {
            Some(c) => ConsensusNote::deserialize(c).map(RecordedNote::Consensus),
            None => N::deserialize(note).map(RecordedNote::Behaviour),
        }
    }
}

impl<'de, N: DeserializeOwned> Deserialize<'de> for RecordedNote<N> {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        RecordedNote::from_json(&Value::deserialize(d)?).map_err(serde::de::Error::custom)
    }
}

/// A behaviour's own notes in a run's records, decoded as its note type `N`, in record order;
/// consensus notes are left out. A note that is neither (a record written by a build whose
/// note types differed) is left out with a warning, never read as some default.
pub fn behaviour_notes<N: DeserializeOwned>(run: &Records) -> impl Iterator<Item = (u64, u32, N)> {
    run.try_notes_as::<RecordedNote<N>>()
        .filter_map(|(tick, robot, note)| match note {
            Ok(RecordedNote::Behaviour(n)) => Some((tick, robot, n)),
            Ok(RecordedNote::Consensus(_)) => None,
            Err(e) => {
                tracing::warn!(
                    tick,
                    robot,
                    "a note this build cannot read is left out: {e}"
                );
                None
            }
        })
}
