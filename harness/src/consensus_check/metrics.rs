//! The consensus section of `metrics.json`, as the checker computes it from the notes.
//!
//! `metrics.json` is written with its keys sorted at every level, so the field order here is
//! for reading, not for the file.

use std::collections::BTreeMap;

use serde::Serialize;
use swarmrt_agent::consensus::{Decision, SentCounts};

use super::{Checker, add_counts};

/// `metrics.json` → `consensus`: what the checker found, or why it could not read the notes.
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(untagged)]
pub enum ConsensusReport {
    /// The notes read and checked.
    Checked(Box<ConsensusMetrics>),
    /// `events.jsonl` could not be read as notes: `{"error": ...}`.
    Unreadable {
        /// Which line and why.
        error: String,
    },
}

/// The consensus metrics of a run (see [`consensus_metrics`]).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ConsensusMetrics {
    /// First tick a leader appeared.
    pub first_leader_tick: Option<u64>,
    /// The highest-term leader in office at the end.
    pub leader: Option<Leader>,
    /// Times the leader changed.
    pub leader_changes: u64,
    /// Ticks from each leader's death or disappearance to the next leader.
    pub reelection_ticks: Vec<u64>,
    /// The highest term any robot reached.
    pub terms: u64,
    /// Length of the committed log.
    pub committed: usize,
    /// The least any live robot applied.
    pub applied_min_live: Option<u64>,
    /// Every proposal: when proposed, committed, by how many robots applied.
    pub decisions: Vec<DecisionRow>,
    /// Broken properties found (must be 0).
    pub safety_violations: usize,
    /// The first ten of them, as lines.
    pub violations: Vec<String>,
    /// Restarts that lost persistent state.
    pub amnesia_restarts: u64,
    /// Consensus frames sent per kind (kinds never sent left out).
    pub sent: BTreeMap<&'static str, u32>,
    /// Consensus notes read.
    pub notes: u64,
    /// The quadrant leader choice's outcome, when robots reported one.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub quadrant: Option<QuadrantMetrics>,
}

/// A leader and its term.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub struct Leader {
    /// The robot.
    pub robot: u32,
    /// Its term.
    pub term: u64,
}

/// One proposal of the run and what became of it.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct DecisionRow {
    /// The proposal's id.
    pub id: u16,
    /// What it decides.
    pub decision: Decision,
    /// Its log index.
    pub index: u64,
    /// The term it was proposed in.
    pub term: u64,
    /// Tick it was proposed.
    pub proposed_tick: u64,
    /// The leader that proposed it.
    pub proposer: u32,
    /// First tick it was committed (`None`: never, or another entry won its index).
    pub committed_tick: Option<u64>,
    /// Robots that applied it (0 when it was not committed).
    pub applied_by: usize,
}

/// The quadrant leader choice at the end of the run.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct QuadrantMetrics {
    /// Robots that believe they lead.
    pub self_declared_leaders: Vec<u32>,
    /// Every robot believes in the same leader.
    pub all_agree: bool,
    /// Each robot's belief, in id order.
    pub beliefs: Vec<Belief>,
}

/// One robot's belief about the quadrant leader.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub struct Belief {
    /// The robot.
    pub robot: u32,
    /// The leader it believes in.
    pub leader: u32,
    /// That leader's score.
    pub score: u8,
}

impl Checker {
    /// The consensus metrics (see [`consensus_metrics`]).
    pub fn metrics(&self) -> ConsensusMetrics {
        ConsensusMetrics {
            first_leader_tick: self.first_leader_tick,
            leader: self
                .current_leader
                .map(|(robot, term)| Leader { robot, term }),
            leader_changes: self.leader_changes,
            reelection_ticks: self.reelection_ticks.clone(),
            terms: self.robots.values().map(|v| v.term).max().unwrap_or(0),
            committed: self.committed.len(),
            applied_min_live: (self.robots.values())
                .filter(|v| v.alive)
                .map(|v| v.applied)
                .min(),
            decisions: self.decisions(),
            safety_violations: self.violations.len(),
            violations: self
                .violations
                .iter()
                .take(10)
                .map(|v| v.to_string())
                .collect(),
            amnesia_restarts: self.amnesia,
            sent: self.sent(),
            notes: self.notes,
            quadrant: self.quadrant(),
        }
    }

    fn decisions(&self) -> Vec<DecisionRow> {
        (self.proposals.iter())
            .map(|(&(index, term), p)| {
                let committed =
                    (self.committed.get(index as usize - 1)).is_some_and(|&(t, _)| t == term);
                DecisionRow {
                    id: p.id,
                    decision: p.decision,
                    index,
                    term,
                    proposed_tick: p.tick,
                    proposer: p.robot,
                    committed_tick: committed.then(|| self.committed_tick[index as usize - 1]),
                    applied_by: match committed {
                        true => self.applied_by.get(&index).map_or(0, |s| s.len()),
                        false => 0,
                    },
                }
            })
            .collect()
    }

    /// Every robot's cumulative counts, kinds never sent left out.
    fn sent(&self) -> BTreeMap<&'static str, u32> {
        let mut sent = SentCounts::default();
        for v in self.robots.values() {
            add_counts(&mut sent, &v.sent_before);
            add_counts(&mut sent, &v.sent);
        }
        sent.pairs().into_iter().filter(|&(_, n)| n > 0).collect()
    }

    fn quadrant(&self) -> Option<QuadrantMetrics> {
        let beliefs: BTreeMap<u32, (u32, u8)> = (self.robots.iter())
            .filter_map(|(&r, v)| v.quadrant.map(|q| (r, q)))
            .collect();
        let first = beliefs.values().next()?.0;
        Some(QuadrantMetrics {
            self_declared_leaders: (beliefs.iter())
                .filter(|&(&r, &(l, _))| r == l)
                .map(|(&r, _)| r)
                .collect(),
            all_agree: beliefs.values().all(|b| b.0 == first),
            beliefs: (beliefs.iter())
                .map(|(&robot, &(leader, score))| Belief {
                    robot,
                    leader,
                    score,
                })
                .collect(),
        })
    }
}

/// The consensus metrics of a run from its `events.jsonl` text: `first_leader_tick`,
/// `leader_changes`, `reelection_ticks` (from a leader's death or disappearance to the next
/// leader), `terms` (highest term), `committed` (length of the committed log),
/// `applied_min_live`, `decisions` (each proposal: when proposed, committed, by how many
/// robots applied), `safety_violations` (must be 0) with the first few `violations`,
/// `amnesia_restarts`, `sent` (consensus frames per kind, from the robots' cumulative `sent`
/// notes; a robot's last `stats_every` ticks before the end or its death are not counted)
/// and, for the quadrant leader choice, `quadrant`.
pub fn consensus_metrics(events: &str) -> ConsensusReport {
    match Checker::from_events(events) {
        Ok(c) => ConsensusReport::Checked(Box::new(c.metrics())),
        Err(error) => ConsensusReport::Unreadable { error },
    }
}
