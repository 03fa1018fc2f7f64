//! `[consensus]`: which consensus the robots run and its timing, in ticks. The messages and
//! notes of the algorithms belong to the robots (`swarmrt_agent::consensus`).

use serde::{Deserialize, Serialize};

use crate::config::Config;
use crate::error::KeyError;
use crate::reference::{KEYS, check_u, hi, lo};
use crate::validate::{check, range_f, range_u64};

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

impl ConsensusConfig {
    /// Checks the bounds; the error names the key and what was expected.
    pub fn validate(&self, cfg: &Config) -> Result<(), KeyError> {
        check_u(
            KEYS,
            "consensus.election_timeout_min",
            self.election_timeout_min as u64,
        )?;
        let max_timeout = hi(KEYS, "consensus.election_timeout_max") as u64;
        range_u64(
            "consensus.election_timeout_max",
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
            lo(KEYS, "consensus.heartbeat_ticks") as u64,
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
        check_u(KEYS, "consensus.stats_every", self.stats_every as u64)?;
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
            check_u(KEYS, &format!("{key}.tick"), p.tick)?;
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
                let slowest = lo(KEYS, "consensus.propose[i].speed");
                range_f(&format!("{key}.speed"), s, slowest, cfg.robots.max_speed)?;
            }
        }
        check_u(
            KEYS,
            "consensus.quadrant.claim_period",
            self.quadrant.claim_period as u64,
        )?;
        check_u(
            KEYS,
            "consensus.quadrant.decide_tick",
            self.quadrant.decide_tick,
        )?;
        Ok(())
    }
}
