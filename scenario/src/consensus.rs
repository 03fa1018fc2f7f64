//! `[consensus]`: which consensus the robots run and its timing, in ticks. The messages and
//! notes of the algorithms belong to the robots (`swarmrt_agent::consensus`).

use serde::{Deserialize, Serialize};

use crate::bounds::{Bounds, Key, Lim, check, k, r, range_f, range_u64};
use crate::error::KeyError;

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
    /// `[x, y]`: set the swarm's goal.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub goal: Option<[f64; 2]>,
    /// Set the swarm's cruise speed.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub speed: Option<f64>,
}

/// `[consensus.quadrant]`: timing of the quadrant leader choice.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct QuadrantConfig {
    /// Ticks between a robot's claims (and, once decided, its leader announcements).
    pub claim_period: u32,
    /// Tick from which a robot decides on the claims heard so far.
    pub decide_tick: u64,
}

impl Default for QuadrantConfig {
    fn default() -> Self {
        QuadrantConfig {
            claim_period: 3,
            decide_tick: 30,
        }
    }
}

/// `[consensus]`: the algorithm and its timing, in ticks. Optional: without it robots run
/// no consensus at all.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ConsensusConfig {
    /// `"raft"` or `"quadrant"`.
    pub algorithm: Algorithm,
    /// Lower bound of the randomized election timeout (Raft section 5.2). It is also the
    /// leader lease: a robot that heard its leader more recently ignores (pre-)vote requests
    /// (thesis section 4.2.3).
    pub election_timeout_min: u32,
    /// Upper bound (exclusive) of the randomized election timeout.
    pub election_timeout_max: u32,
    /// Ticks between leader heartbeats; candidates repeat their requests at this period.
    pub heartbeat_ticks: u32,
    /// Pre-vote (thesis section 9.6): a robot that drifted away cannot depose a healthy
    /// leader when it comes back.
    pub pre_vote: bool,
    /// A leader that has not heard from a majority for `election_timeout_max` ticks steps
    /// down (thesis section 6.2).
    pub check_quorum: bool,
    /// Ticks between the cumulative message-count notes a robot reports.
    pub stats_every: u32,
    /// Scheduled decisions.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub propose: Vec<Proposal>,
    /// Quadrant leader choice timing.
    pub quadrant: QuadrantConfig,
    /// Raft keeps each robot's term, vote and log in stable storage that survives its process
    /// (a file per robot under the run directory; modelled in memory `--in-process`), so a
    /// restarted robot cannot vote twice in one term. `false` shows what amnesia does.
    #[serde(skip_serializing_if = "is_true")]
    pub storage: bool,
}

fn is_true(v: &bool) -> bool {
    *v
}

impl Default for ConsensusConfig {
    fn default() -> Self {
        ConsensusConfig {
            algorithm: Algorithm::Raft,
            election_timeout_min: 20,
            election_timeout_max: 40,
            heartbeat_ticks: 4,
            pre_vote: true,
            check_quorum: true,
            stats_every: 20,
            propose: Vec::new(),
            quadrant: QuadrantConfig::default(),
            storage: true,
        }
    }
}

/// Most scheduled proposals (their ids travel as `u16`).
pub const MAX_PROPOSALS: usize = 1000;

/// What `[consensus]`'s bounds depend on in other sections.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Around {
    /// `radio.delay_ticks`.
    pub delay_ticks: u64,
    /// `radio.jitter_ticks`.
    pub jitter_ticks: u64,
    /// `map.bounds`.
    pub bounds: [f64; 4],
    /// `robots.max_speed`.
    pub max_speed: f64,
}

#[rustfmt::skip]
mod keys {
    use super::*;

    /// `consensus.algorithm`.
    pub const ALGORITHM: Key = k("consensus.algorithm", Bounds::Any, "", "Raft election and log, or the quadrant leader choice of seed 001.");
    /// `consensus.election_timeout_min`.
    pub const ELECTION_TIMEOUT_MIN: Key = k("consensus.election_timeout_min", r(2.0, 100_000.0), "ticks", "Lower end of the randomized election timeout; also the leader lease.").also("above the radio round trip `2 * (1 + delay_ticks + jitter_ticks)`");
    /// `consensus.election_timeout_max`.
    pub const ELECTION_TIMEOUT_MAX: Key = k("consensus.election_timeout_max", Bounds::Range(Lim::Of("election_timeout_min + 1"), Lim::V(1_000_000.0)), "ticks", "Upper end (exclusive) of the election timeout.");
    /// `consensus.heartbeat_ticks`.
    pub const HEARTBEAT_TICKS: Key = k("consensus.heartbeat_ticks", Bounds::Range(Lim::V(1.0), Lim::Of("election_timeout_min - 1")), "ticks", "Ticks between leader heartbeats.");
    /// `consensus.pre_vote`.
    pub const PRE_VOTE: Key = k("consensus.pre_vote", Bounds::Any, "", "Pre-vote: a robot back from afar cannot depose a healthy leader.");
    /// `consensus.check_quorum`.
    pub const CHECK_QUORUM: Key = k("consensus.check_quorum", Bounds::Any, "", "A leader that hears no majority for `election_timeout_max` steps down.");
    /// `consensus.stats_every`.
    pub const STATS_EVERY: Key = k("consensus.stats_every", r(1.0, 1_000_000.0), "ticks", "Ticks between the message-count notes a robot reports.");
    /// `consensus.storage`.
    pub const STORAGE: Key = k("consensus.storage", Bounds::Any, "", "Raft term, vote and log survive a restart (`storage/raft-<id>.state`); false: amnesia.").absent("true");
    /// `consensus.quadrant.claim_period`.
    pub const QUADRANT_CLAIM_PERIOD: Key = k("consensus.quadrant.claim_period", r(1.0, 100_000.0), "ticks", "Ticks between a robot's claims and leader announcements.");
    /// `consensus.quadrant.decide_tick`.
    pub const QUADRANT_DECIDE_TICK: Key = k("consensus.quadrant.decide_tick", r(1.0, 100_000_000.0), "tick", "Tick from which a robot decides on the claims heard.");
    /// `consensus.propose[i].tick`.
    pub const PROPOSE_TICK: Key = k("consensus.propose[i].tick", r(0.0, 100_000_000.0), "tick", "The leader at this tick (or the first after) proposes it.");
    /// `consensus.propose[i].goal`.
    pub const PROPOSE_GOAL: Key = k("consensus.propose[i].goal", Bounds::Rule("a point `[x, y]` inside `map.bounds`"), "m", "Set the swarm's goal.").also("exactly one of `goal` and `speed`");
    /// `consensus.propose[i].speed`.
    pub const PROPOSE_SPEED: Key = k("consensus.propose[i].speed", Bounds::Range(Lim::V(0.0), Lim::Of("robots.max_speed")), "m/s", "Set the swarm's cruise speed.");

    /// Every key of `[consensus]`, in the order of the reference.
    pub const KEYS: &[Key] = &[
        ALGORITHM, ELECTION_TIMEOUT_MIN, ELECTION_TIMEOUT_MAX, HEARTBEAT_TICKS, PRE_VOTE,
        CHECK_QUORUM, STATS_EVERY, STORAGE, QUADRANT_CLAIM_PERIOD, QUADRANT_DECIDE_TICK,
        PROPOSE_TICK, PROPOSE_GOAL, PROPOSE_SPEED,
    ];
}
pub use keys::*;

impl ConsensusConfig {
    /// Checks the bounds against its own rows ([`KEYS`]) and what they depend on elsewhere;
    /// the error names the key and what was expected.
    pub fn validate(&self, around: &Around) -> Result<(), KeyError> {
        ELECTION_TIMEOUT_MIN.check_int(self.election_timeout_min as u64)?;
        self.validate_timing(around)?;
        STATS_EVERY.check_int(self.stats_every as u64)?;
        self.validate_proposals(around)?;
        QUADRANT_CLAIM_PERIOD.check_int(self.quadrant.claim_period as u64)?;
        QUADRANT_DECIDE_TICK.check_int(self.quadrant.decide_tick)?;
        Ok(())
    }

    /// The election timeout's upper end, the radio round trip and the heartbeat.
    fn validate_timing(&self, around: &Around) -> Result<(), KeyError> {
        let max_timeout = ELECTION_TIMEOUT_MAX.hi() as u64;
        range_u64(
            ELECTION_TIMEOUT_MAX.path,
            self.election_timeout_max as u64,
            self.election_timeout_min as u64 + 1,
            max_timeout,
        )
        .map_err(|(k, _)| {
            (
                k,
                format!(
                    "expected an integer above consensus.election_timeout_min = {} and at most {max_timeout}, got {}",
                    self.election_timeout_min, self.election_timeout_max
                ),
            )
        })?;
        // Section 5.6: broadcast time << election timeout. A timeout shorter than one radio
        // round trip can never see a vote come back in time.
        let rtt = 2 * (1 + around.delay_ticks + around.jitter_ticks);
        check(
            self.election_timeout_min as u64 > rtt,
            ELECTION_TIMEOUT_MIN.path,
            &format!(
                "an integer above the radio round trip 2 * (1 + radio.delay_ticks + radio.jitter_ticks) = {rtt} ticks (Raft section 5.6), got {}",
                self.election_timeout_min
            ),
        )?;
        range_u64(
            HEARTBEAT_TICKS.path,
            self.heartbeat_ticks as u64,
            HEARTBEAT_TICKS.lo() as u64,
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
        })
    }

    /// `[[consensus.propose]]`: how many, and each one's tick, goal or speed.
    fn validate_proposals(&self, around: &Around) -> Result<(), KeyError> {
        check(
            self.propose.len() <= MAX_PROPOSALS,
            "consensus.propose",
            &format!(
                "at most {MAX_PROPOSALS} proposals, got {}",
                self.propose.len()
            ),
        )?;
        let b = around.bounds;
        for (i, p) in self.propose.iter().enumerate() {
            let key = format!("consensus.propose[{i}]");
            PROPOSE_TICK.check_int_at(&format!("{key}.tick"), p.tick)?;
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
                let slowest = PROPOSE_SPEED.lo();
                range_f(&format!("{key}.speed"), s, slowest, around.max_speed)?;
            }
        }
        Ok(())
    }
}
