//! The consensus layer's radio messages and the swarm decisions its log carries.
//!
//! Everything here travels as postcard (radio frames of at most
//! [`swarmrt_protocol::MAX_PAYLOAD`] bytes), so enums are externally tagged and no field is
//! skipped conditionally: postcard has no field names to skip by.

use serde::{Deserialize, Serialize};
use swarmrt_scenario::consensus::Proposal;

/// A swarm decision the replicated log carries. Robots act on it only once it is committed
/// and applied (Raft, Ongaro & Ousterhout 2014, section 5.3: "state machine safety").
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Decision {
    /// Every robot heads for its own slot around (`x`, `y`) instead of the map goal.
    SetGoal {
        /// Goal centre x in metres.
        x: f64,
        /// Goal centre y in metres.
        y: f64,
    },
    /// Every robot cruises at `speed` m/s from now on (a behaviour switch; 0 halts the swarm).
    SetSpeed {
        /// Cruise speed in m/s.
        speed: f64,
    },
    /// A part of one vehicle's planned route (seed 002): proposed by the leader, not by the
    /// schedule; a vehicle flies only a route whose parts are all committed.
    Route(RoutePart),
}

/// Most moves in one [`RoutePart`]: a part plus the AppendEntries header fits one radio frame.
pub const ROUTE_PART_MOVES: usize = 32;

/// Part `part` of `parts` of the route plan `plan` gives `vehicle`: from cell `start` at slot
/// `start_slot`, one move per slot (`swarmrt_planner::Route::moves` codes: 13 waits, the
/// others step to one of the 26 neighbouring cells).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct RoutePart {
    /// The plan (the leader's count of plans, higher is newer; a vehicle flies its newest).
    pub plan: u32,
    /// The vehicle (robot id).
    pub vehicle: u32,
    /// This part's index.
    pub part: u8,
    /// How many parts the route has.
    pub parts: u8,
    /// The slot at which the vehicle is in `start`.
    pub start_slot: u32,
    /// The cell `[i, j, k]` this part starts from.
    pub start: [u16; 3],
    /// Number of valid moves.
    pub len: u8,
    /// One move per slot; only `..len` are meaningful.
    pub moves: [u8; ROUTE_PART_MOVES],
}

/// What one log entry holds.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Item {
    /// The entry a new leader appends at the start of its term, so entries of earlier terms
    /// get committed through it (Raft section 5.4.2 and section 8).
    Noop,
    /// A scheduled decision; `id` is its position in `consensus.propose`, so a new leader can
    /// tell whether an earlier leader already put it in the log and never proposes it twice.
    Decision {
        /// Index into the configured schedule.
        id: u16,
        /// The decision.
        decision: Decision,
    },
}

/// The `id` of a decision no schedule names (a behaviour proposed it).
pub const UNSCHEDULED: u16 = u16::MAX;

/// One replicated log entry.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Entry {
    /// The term of the leader that created it.
    pub term: u64,
    /// What it says.
    pub item: Item,
}

impl Entry {
    /// A 32-bit digest of the entry (FNV-1a over its postcard bytes). Notes carry it instead
    /// of the entry, so a checker can compare logs across robots from `events.jsonl` alone
    /// while each note stays a few bytes.
    pub fn digest(&self) -> u32 {
        let mut buf = [0u8; 160];
        let bytes = postcard::to_slice(self, &mut buf)
            .map(|b| &*b)
            .unwrap_or(&[]);
        let mut h: u32 = 0x811c_9dc5;
        for &b in bytes {
            h ^= b as u32;
            h = h.wrapping_mul(0x0100_0193);
        }
        h
    }
}

/// Radio messages of the consensus algorithms (inside [`crate::RadioMsg::Consensus`]).
///
/// Raft's RPCs become one-way messages: a response is a message back to the sender. Requests
/// and the leader's AppendEntries are broadcast (a radio reaches everyone in range at once,
/// and the capacity of a few frames per tick would not allow one unicast per follower);
/// responses are unicast.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ConsensusMsg {
    /// Pre-vote request (Ongaro's thesis, section 9.6): "would you vote for me in `term`?"
    /// `term` is the sender's term + 1; nobody changes its own term because of it.
    PreVote {
        /// The term the sender would campaign in.
        term: u64,
        /// Index of the sender's last log entry.
        last_index: u64,
        /// Term of the sender's last log entry.
        last_term: u64,
    },
    /// Answer to [`ConsensusMsg::PreVote`]: `term` echoes the request's term when granted,
    /// else it is the responder's own term.
    PreVoteResp {
        /// See above.
        term: u64,
        /// Whether the responder would vote.
        granted: bool,
    },
    /// RequestVote (Raft section 5.2).
    Vote {
        /// The candidate's term.
        term: u64,
        /// Index of the candidate's last log entry.
        last_index: u64,
        /// Term of the candidate's last log entry.
        last_term: u64,
    },
    /// Answer to [`ConsensusMsg::Vote`].
    VoteResp {
        /// The responder's term.
        term: u64,
        /// Whether the vote was granted.
        granted: bool,
    },
    /// AppendEntries (Raft section 5.3); without entries it is a heartbeat.
    Append {
        /// The leader's term.
        term: u64,
        /// Index of the entry just before `entries`.
        prev_index: u64,
        /// Term of that entry.
        prev_term: u64,
        /// The leader's commit index.
        commit: u64,
        /// Entries from `prev_index + 1` on (as many as fit a frame).
        entries: Vec<Entry>,
    },
    /// Answer to [`ConsensusMsg::Append`]. On success `index` is the last index known to
    /// match the leader's log; on a refusal it is a hint: the leader retries from `index + 1`.
    AppendResp {
        /// The responder's term.
        term: u64,
        /// Whether the entries were accepted.
        success: bool,
        /// Match index or retry hint, see above.
        index: u64,
    },
    /// Quadrant leader choice (seed 001, section 2.2): "my best quadrant holds `score` group
    /// members; `draw` breaks ties".
    QuadClaim {
        /// Most group members the sender sees in one quadrant of its own frame.
        score: u8,
        /// The sender's seeded tie-break draw.
        draw: u32,
    },
    /// Quadrant leader choice: "the best claim I know of is robot `leader`'s", its own or
    /// relayed from a group member, repeated so that the best claim floods the whole group
    /// (members that do not sense each other included) and ties are made final over the radio.
    QuadLeader {
        /// That robot's score.
        score: u8,
        /// Its tie-break draw.
        draw: u32,
        /// The robot that made the claim.
        leader: u32,
    },
}

impl ConsensusMsg {
    /// A short name per variant, used for per-kind message counts.
    pub fn kind(&self) -> &'static str {
        match self {
            ConsensusMsg::PreVote { .. } => "pre_vote",
            ConsensusMsg::PreVoteResp { .. } => "pre_vote_resp",
            ConsensusMsg::Vote { .. } => "vote",
            ConsensusMsg::VoteResp { .. } => "vote_resp",
            ConsensusMsg::Append { .. } => "append",
            ConsensusMsg::AppendResp { .. } => "append_resp",
            ConsensusMsg::QuadClaim { .. } => "quad_claim",
            ConsensusMsg::QuadLeader { .. } => "quad_leader",
        }
    }
}

impl From<&Proposal> for Decision {
    /// The decision a scheduled proposal carries (a validated config has exactly one).
    fn from(p: &Proposal) -> Decision {
        match (p.goal, p.speed) {
            (Some([x, y]), _) => Decision::SetGoal { x, y },
            (None, Some(speed)) => Decision::SetSpeed { speed },
            (None, None) => Decision::SetSpeed { speed: 0.0 },
        }
    }
}
