//! Consensus contracts: the swarm decisions a replicated log carries, the radio messages of
//! the Raft-style election and log (and of the quadrant leader choice), the notes a robot
//! reports about its own consensus state, and the `[consensus]` config section.
//!
//! Everything here travels as postcard (radio frames of at most [`crate::MAX_PAYLOAD`] bytes,
//! notes within [`crate::MAX_REPORT`] bytes per tick), so enums are externally tagged and no
//! field is skipped conditionally: postcard has no field names to skip by.

use serde::{Deserialize, Serialize};

use crate::config::{Config, check, range_f, range_u64};

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
        let mut buf = [0u8; 64];
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
    /// Quadrant leader choice: "I am the leader of my group", repeated so that ties are made
    /// final over the radio.
    QuadLeader {
        /// The leader's score.
        score: u8,
        /// The leader's tie-break draw.
        draw: u32,
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
        /// [`Entry::digest`].
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
        /// [`Entry::digest`].
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

/// Which consensus algorithm the robots run.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Algorithm {
    /// Raft-style election and replicated log of decisions.
    #[default]
    Raft,
    /// The quadrant leader choice of seed 001, section 2.2.
    Quadrant,
}

/// `[[consensus.propose]]`: a decision to propose at `tick`. Exactly one of `goal` and
/// `speed` is set.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Proposal {
    /// The leader at this tick (or the first one after) proposes it.
    pub tick: u64,
    /// `[x, y]`: a [`Decision::SetGoal`].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub goal: Option<[f64; 2]>,
    /// A [`Decision::SetSpeed`].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub speed: Option<f64>,
}

impl Proposal {
    /// The decision this proposal carries (a validated config has exactly one).
    pub fn decision(&self) -> Decision {
        match (self.goal, self.speed) {
            (Some([x, y]), _) => Decision::SetGoal { x, y },
            (None, Some(speed)) => Decision::SetSpeed { speed },
            (None, None) => Decision::SetSpeed { speed: 0.0 },
        }
    }
}

/// `[consensus.quadrant]`: timing of the quadrant leader choice.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct QuadrantConfig {
    /// Ticks between a robot's claims (and, once decided, its leader announcements).
    #[serde(default = "default_claim_period")]
    pub claim_period: u32,
    /// Tick from which a robot decides on the claims heard so far.
    #[serde(default = "default_decide_tick")]
    pub decide_tick: u64,
}

impl Default for QuadrantConfig {
    fn default() -> Self {
        QuadrantConfig {
            claim_period: default_claim_period(),
            decide_tick: default_decide_tick(),
        }
    }
}

/// `[consensus]`: the algorithm and its timing, in ticks. Optional: without it robots run
/// no consensus at all.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ConsensusConfig {
    /// `"raft"` or `"quadrant"`.
    #[serde(default)]
    pub algorithm: Algorithm,
    /// Lower bound of the randomized election timeout (Raft section 5.2). It is also the
    /// leader lease: a robot that heard its leader more recently ignores (pre-)vote requests
    /// (thesis section 4.2.3).
    #[serde(default = "default_election_min")]
    pub election_timeout_min: u32,
    /// Upper bound (exclusive) of the randomized election timeout.
    #[serde(default = "default_election_max")]
    pub election_timeout_max: u32,
    /// Ticks between leader heartbeats; candidates repeat their requests at this period.
    #[serde(default = "default_heartbeat")]
    pub heartbeat_ticks: u32,
    /// Pre-vote (thesis section 9.6): a robot that drifted away cannot depose a healthy
    /// leader when it comes back.
    #[serde(default = "yes")]
    pub pre_vote: bool,
    /// A leader that has not heard from a majority for `election_timeout_max` ticks steps
    /// down (thesis section 6.2).
    #[serde(default = "yes")]
    pub check_quorum: bool,
    /// Ticks between the cumulative [`ConsensusNote::Sent`] notes.
    #[serde(default = "default_stats_every")]
    pub stats_every: u32,
    /// Scheduled decisions.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub propose: Vec<Proposal>,
    /// Quadrant leader choice timing.
    #[serde(default)]
    pub quadrant: QuadrantConfig,
}

impl Default for ConsensusConfig {
    fn default() -> Self {
        ConsensusConfig {
            algorithm: Algorithm::Raft,
            election_timeout_min: default_election_min(),
            election_timeout_max: default_election_max(),
            heartbeat_ticks: default_heartbeat(),
            pre_vote: true,
            check_quorum: true,
            stats_every: default_stats_every(),
            propose: Vec::new(),
            quadrant: QuadrantConfig::default(),
        }
    }
}

/// Most scheduled proposals (their ids travel as `u16`).
pub const MAX_PROPOSALS: usize = 1000;

impl ConsensusConfig {
    /// Checks the bounds; the error names the key and what was expected.
    pub fn validate(&self, cfg: &Config) -> Result<(), (String, String)> {
        range_u64(
            "consensus.election_timeout_min",
            self.election_timeout_min as u64,
            2,
            100_000,
        )?;
        range_u64(
            "consensus.election_timeout_max",
            self.election_timeout_max as u64,
            self.election_timeout_min as u64 + 1,
            1_000_000,
        )
        .map_err(|(k, _)| {
            (
                k,
                format!(
                    "expected an integer above consensus.election_timeout_min = {} and at most 1000000, got {}",
                    self.election_timeout_min, self.election_timeout_max
                ),
            )
        })?;
        // Section 5.6: broadcast time << election timeout. A timeout shorter than one radio
        // round trip can never see a vote come back in time.
        let rtt = 2 * (1 + cfg.radio.delay_ticks as u64 + cfg.radio.jitter_ticks as u64);
        check(
            self.election_timeout_min as u64 > rtt,
            "consensus.election_timeout_min",
            &format!(
                "an integer above the radio round trip 2 * (1 + radio.delay_ticks + radio.jitter_ticks) = {rtt} ticks (Raft section 5.6), got {}",
                self.election_timeout_min
            ),
        )?;
        range_u64(
            "consensus.heartbeat_ticks",
            self.heartbeat_ticks as u64,
            1,
            self.election_timeout_min as u64 - 1,
        )
        .map_err(|(k, _)| {
            (
                k,
                format!(
                    "expected an integer in [1, {}] (below consensus.election_timeout_min, or followers time out between heartbeats), got {}",
                    self.election_timeout_min - 1,
                    self.heartbeat_ticks
                ),
            )
        })?;
        range_u64(
            "consensus.stats_every",
            self.stats_every as u64,
            1,
            1_000_000,
        )?;
        check(
            self.propose.len() <= MAX_PROPOSALS,
            "consensus.propose",
            &format!(
                "at most {MAX_PROPOSALS} proposals, got {}",
                self.propose.len()
            ),
        )?;
        let b = cfg.map.bounds;
        for (i, p) in self.propose.iter().enumerate() {
            let key = format!("consensus.propose[{i}]");
            range_u64(&format!("{key}.tick"), p.tick, 0, 100_000_000)?;
            check(
                p.goal.is_some() != p.speed.is_some(),
                &key,
                "exactly one of `goal = [x, y]` and `speed = v`",
            )?;
            if let Some([x, y]) = p.goal {
                range_f(&format!("{key}.goal[0]"), x, b[0], b[2])?;
                range_f(&format!("{key}.goal[1]"), y, b[1], b[3])?;
            }
            if let Some(s) = p.speed {
                range_f(&format!("{key}.speed"), s, 0.0, cfg.robots.max_speed)?;
            }
        }
        range_u64(
            "consensus.quadrant.claim_period",
            self.quadrant.claim_period as u64,
            1,
            100_000,
        )?;
        range_u64(
            "consensus.quadrant.decide_tick",
            self.quadrant.decide_tick,
            1,
            100_000_000,
        )?;
        Ok(())
    }
}

fn yes() -> bool {
    true
}
fn default_election_min() -> u32 {
    20
}
fn default_election_max() -> u32 {
    40
}
fn default_heartbeat() -> u32 {
    4
}
fn default_stats_every() -> u32 {
    20
}
fn default_claim_period() -> u32 {
    3
}
fn default_decide_tick() -> u64 {
    30
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{MAX_PAYLOAD, MAX_REPORT, Note, RadioMsg};

    fn size<T: Serialize>(v: &T) -> usize {
        postcard::to_allocvec(v).unwrap().len()
    }

    #[test]
    fn worst_case_messages_fit_a_frame() {
        let big = u64::MAX;
        let entry = Entry {
            term: big,
            item: Item::Decision {
                id: u16::MAX,
                decision: Decision::SetGoal { x: 1.0, y: 2.0 },
            },
        };
        // A heartbeat and an AppendEntries with one entry fit even with every number at its
        // largest encoding; the leader adds entries while the frame still fits.
        let append = RadioMsg::Consensus(ConsensusMsg::Append {
            term: big,
            prev_index: big,
            prev_term: big,
            commit: big,
            entries: vec![entry],
        });
        assert!(size(&append) <= MAX_PAYLOAD, "{}", size(&append));
        for m in [
            ConsensusMsg::PreVote {
                term: big,
                last_index: big,
                last_term: big,
            },
            ConsensusMsg::AppendResp {
                term: big,
                success: true,
                index: big,
            },
        ] {
            assert!(size(&RadioMsg::Consensus(m)) <= MAX_PAYLOAD);
        }
    }

    #[test]
    fn notes_are_small_and_round_trip_through_json_and_postcard() {
        let n = Note::Consensus(ConsensusNote::State {
            term: 7,
            role: Role::Leader,
            vote: Some(3),
        });
        let json = serde_json::to_string(&n).unwrap();
        assert_eq!(
            json,
            r#"{"consensus":{"state":{"term":7,"role":"leader","vote":3}}}"#
        );
        assert_eq!(serde_json::from_str::<Note>(&json).unwrap(), n);
        let bytes = postcard::to_allocvec(&n).unwrap();
        assert!(bytes.len() <= 6, "{}", bytes.len());
        assert_eq!(postcard::from_bytes::<Note>(&bytes).unwrap(), n);
        // The largest note a robot can emit still leaves room for several in one report.
        let worst = Note::Consensus(ConsensusNote::Sent(SentCounts {
            pre_vote: u32::MAX,
            pre_vote_resp: u32::MAX,
            vote: u32::MAX,
            vote_resp: u32::MAX,
            append: u32::MAX,
            append_resp: u32::MAX,
            quad_claim: u32::MAX,
            quad_leader: u32::MAX,
        }));
        assert!(size(&worst) * 4 < MAX_REPORT);
    }

    const BASE: &str = r#"
[scenario]
name = "t"
ticks = 10
[map]
bounds = [0.0, 0.0, 10.0, 10.0]
goal = { x = 8.0, y = 8.0, radius = 1.0 }
[robots]
count = 4
[consensus]
election_timeout_min = 20
[[consensus.propose]]
tick = 5
goal = [2.0, 3.0]
[[consensus.propose]]
tick = 9
speed = 0.2
"#;

    fn load(ov: &[&str]) -> Result<Config, crate::config::ConfigError> {
        let ov: Vec<String> = ov.iter().map(|s| s.to_string()).collect();
        Config::from_toml_str("t.toml", BASE, &ov)
    }

    #[test]
    fn consensus_section_loads_round_trips_and_is_optional() {
        let c = load(&[]).unwrap();
        let cc = c.consensus.as_ref().unwrap();
        assert_eq!(cc.election_timeout_max, 40);
        assert_eq!(
            cc.propose[0].decision(),
            Decision::SetGoal { x: 2.0, y: 3.0 }
        );
        assert_eq!(cc.propose[1].decision(), Decision::SetSpeed { speed: 0.2 });
        assert_eq!(
            Config::from_toml_str("t.toml", &c.to_toml(), &[]).unwrap(),
            c
        );
        let without = BASE.split("[consensus]").next().unwrap();
        let c = Config::from_toml_str("t.toml", without, &[]).unwrap();
        assert_eq!(c.consensus, None);
        assert!(!c.to_toml().contains("consensus"));
    }

    #[test]
    fn consensus_errors_name_the_key_and_the_bounds() {
        let cases: &[(&[&str], &str, &str)] = &[
            (
                &["consensus.electon_timeout_min=3"],
                "consensus.electon_timeout_min",
                "unknown field",
            ),
            (
                &["consensus.election_timeout_max=20"],
                "consensus.election_timeout_max",
                "above consensus.election_timeout_min = 20",
            ),
            (
                &["consensus.heartbeat_ticks=20"],
                "consensus.heartbeat_ticks",
                "[1, 19]",
            ),
            (
                &["consensus.heartbeat_ticks=0"],
                "consensus.heartbeat_ticks",
                "[1, 19]",
            ),
            (
                &["radio.delay_ticks=9"],
                "consensus.election_timeout_min",
                "round trip",
            ),
            (
                &["consensus.algorithm=\"paxos\""],
                "consensus.algorithm",
                "unknown variant",
            ),
            (
                &["consensus.stats_every=0"],
                "consensus.stats_every",
                "[1, 1000000]",
            ),
            (
                &["consensus.quadrant.claim_period=0"],
                "consensus.quadrant.claim_period",
                "[1, 100000]",
            ),
        ];
        for (ov, key, msg) in cases {
            let e = load(ov).unwrap_err();
            assert_eq!(e.key, *key, "{ov:?}: {e}");
            assert!(e.to_string().contains(msg), "{ov:?}: {e}");
        }
        let both = BASE.replace("goal = [2.0, 3.0]", "goal = [2.0, 3.0]\nspeed = 0.1");
        let e = Config::from_toml_str("t.toml", &both, &[]).unwrap_err();
        assert_eq!(e.key, "consensus.propose[0]", "{e}");
        let outside = BASE.replace("goal = [2.0, 3.0]", "goal = [20.0, 3.0]");
        let e = Config::from_toml_str("t.toml", &outside, &[]).unwrap_err();
        assert_eq!(e.key, "consensus.propose[0].goal[0]", "{e}");
        let fast = BASE.replace("speed = 0.2", "speed = 5.0");
        let e = Config::from_toml_str("t.toml", &fast, &[]).unwrap_err();
        assert_eq!(e.key, "consensus.propose[1].speed", "{e}");
    }

    #[test]
    fn leaders_claim_leadership_others_do_not() {
        let leader = ConsensusNote::State {
            term: 2,
            role: Role::Leader,
            vote: Some(1),
        };
        let candidate = ConsensusNote::State {
            term: 2,
            role: Role::Candidate,
            vote: Some(1),
        };
        assert!(leader.claims_leadership());
        assert!(!candidate.claims_leadership());
        let q = |leads| ConsensusNote::Quadrant {
            leader: 3,
            leads,
            score: 4,
        };
        assert!(q(true).claims_leadership());
        assert!(!q(false).claims_leadership());
        assert!(!ConsensusNote::Commit { index: 1 }.claims_leadership());
    }

    #[test]
    fn digest_tells_entries_apart() {
        let a = Entry {
            term: 1,
            item: Item::Noop,
        };
        let b = Entry {
            term: 2,
            item: Item::Noop,
        };
        let c = Entry {
            term: 1,
            item: Item::Decision {
                id: 0,
                decision: Decision::SetSpeed { speed: 0.2 },
            },
        };
        assert_eq!(a.digest(), a.digest());
        assert_ne!(a.digest(), b.digest());
        assert_ne!(a.digest(), c.digest());
    }
}
