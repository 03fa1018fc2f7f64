//! Checks a run's consensus from its notes alone (`events.jsonl`, or the same note stream in
//! memory) and computes the consensus metrics.
//!
//! Robots report every change of their Raft state as a [`ConsensusNote`]; the checker rebuilds
//! each robot's term, vote, role, log (index, term, digest), commit and apply sequence from
//! them and verifies, after every note and at the end of every tick, the properties of Raft's
//! Figure 3 (Ongaro & Ousterhout 2014):
//!
//! - **election safety**: at most one leader per term (and a leader voted for itself);
//! - **log matching**: two logs holding an entry with the same index and term are identical
//!   up to it (checked with a hash chain per log: the chain at (index, term) must be unique);
//! - **leader completeness**: a leader of term T holds every entry committed with a term
//!   <= T, and nobody truncates an entry it has committed;
//! - **state machine safety**: no two robots commit or apply different entries at one index;
//! - **monotonicity**: per robot, the term never decreases, the vote never changes within a
//!   term, the commit index never decreases, entries are applied in order 1, 2, ...
//!
//! A `Boot` note restarts a robot's view: with its persistent state (term, vote, log, commit)
//! intact the view carries on; a restart that lost state ("amnesia": lower term, shorter log
//! or commit than recorded, or the vote of the recorded term) is counted, not reported as a violation by itself, because Raft
//! assumes stable storage; what it then breaks (two leaders in a term, ...) is reported. A
//! robot whose notes stop because it died is simply no longer checked.

use std::collections::BTreeMap;

mod metrics;
pub use metrics::{
    Belief, ConsensusMetrics, ConsensusReport, DecisionRow, Leader, QuadrantMetrics,
    consensus_metrics,
};

use serde::de::IgnoredAny;
use serde_json::Value;
use swarmrt_agent::consensus::{ConsensusNote, Decision, RecordedNote, Role, SentCounts};
use swarmrt_protocol::records::{Event, FaultKind};

/// A broken property.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Violation {
    /// Tick of the note (or the end of tick) at which it was seen.
    pub tick: u64,
    /// The robot whose note exposed it.
    pub robot: u32,
    /// Which property: `election_safety`, `log_matching`, `leader_completeness`,
    /// `state_machine_safety`, `monotonic_term`, `monotonic_vote`, `monotonic_commit`,
    /// `apply_order` or `record` (a note stream that contradicts itself).
    pub property: &'static str,
    /// What exactly.
    pub detail: String,
}

impl std::fmt::Display for Violation {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "tick {} robot {}: {}: {}",
            self.tick, self.robot, self.property, self.detail
        )
    }
}

/// A log entry the record does not show (its term and digest are unknown).
const UNKNOWN: (u64, u32) = (u64::MAX, 0);

/// Appends `entry` to `v`'s log and chain; returns the new chain hash.
fn push_entry(v: &mut View, entry: (u64, u32)) -> u64 {
    let c = chain(v.chain[v.chain.len() - 1], entry.0, entry.1);
    v.log.push(entry);
    v.chain.push(c);
    c
}

#[derive(Debug, Clone)]
struct View {
    alive: bool,
    term: u64,
    role: Role,
    vote: Option<u32>,
    /// (term, digest) per index - 1.
    log: Vec<(u64, u32)>,
    /// chain[i] = hash of log[..i]; chain[0] is the empty prefix.
    chain: Vec<u64>,
    commit: u64,
    applied: u64,
    /// Committed prefix already verified against this robot's log while it leads.
    completeness_checked: u64,
    sent: SentCounts,
    sent_before: SentCounts,
    quadrant: Option<(u32, u8)>,
}

impl Default for View {
    fn default() -> Self {
        View {
            alive: true,
            term: 0,
            role: Role::Follower,
            vote: None,
            log: Vec::new(),
            chain: vec![CHAIN_SEED],
            commit: 0,
            applied: 0,
            completeness_checked: 0,
            sent: SentCounts::default(),
            sent_before: SentCounts::default(),
            quadrant: None,
        }
    }
}

const CHAIN_SEED: u64 = 0xcbf2_9ce4_8422_2325;

fn chain(prev: u64, term: u64, digest: u32) -> u64 {
    let mut h = prev;
    for b in term.to_le_bytes().into_iter().chain(digest.to_le_bytes()) {
        h ^= b as u64;
        h = h.wrapping_mul(0x0000_0100_0000_01b3);
    }
    h
}

#[derive(Debug, Clone)]
struct Proposal {
    tick: u64,
    robot: u32,
    id: u16,
    decision: Decision,
}

/// The checker's state: one view per robot plus what all robots share.
#[derive(Debug, Clone, Default)]
pub struct Checker {
    robots: BTreeMap<u32, View>,
    /// Election safety: the leader of each term.
    leaders: BTreeMap<u64, u32>,
    /// Log matching: the chain hash of the log prefix ending at each (index, term).
    entries: BTreeMap<(u64, u64), u64>,
    /// The committed prefix, (term, digest) per index - 1.
    committed: Vec<(u64, u32)>,
    /// First tick at which each index was committed (index - 1).
    committed_tick: Vec<u64>,
    /// Term of the robot whose note first committed each index: a leader of term T must
    /// hold what was committed before T (Leader Completeness), not what a later term
    /// commits of an earlier term's entries while it is a stale leader.
    committed_in: Vec<u64>,
    /// What some robot applied at each index.
    applied: BTreeMap<u64, (u64, u32)>,
    /// Robots that applied each index.
    applied_by: BTreeMap<u64, std::collections::BTreeSet<u32>>,
    proposals: BTreeMap<(u64, u64), Proposal>,
    violations: Vec<Violation>,
    // Metrics.
    first_leader_tick: Option<u64>,
    current_leader: Option<(u32, u64)>,
    last_leader: Option<u32>,
    leaderless_since: Option<u64>,
    reelection_ticks: Vec<u64>,
    leader_changes: u64,
    amnesia: u64,
    last_tick: u64,
    notes: u64,
}

impl Checker {
    /// An empty checker.
    pub fn new() -> Checker {
        Checker::default()
    }

    /// Every violation found so far, in the order found.
    pub fn violations(&self) -> &[Violation] {
        &self.violations
    }

    /// Restarts that lost persistent state.
    pub fn amnesia_restarts(&self) -> u64 {
        self.amnesia
    }

    /// The highest-term leader, if one holds office now.
    pub fn current_leader(&self) -> Option<(u32, u64)> {
        self.current_leader
    }

    /// Length of the committed prefix.
    pub fn committed(&self) -> u64 {
        self.committed.len() as u64
    }

    /// First tick a leader appeared.
    pub fn first_leader_tick(&self) -> Option<u64> {
        self.first_leader_tick
    }

    /// Ticks from each leader's death or disappearance to the next leader.
    pub fn reelection_ticks(&self) -> &[u64] {
        &self.reelection_ticks
    }

    /// Last index robot `r` applied (0 if unknown).
    pub fn applied_by(&self, r: u32) -> u64 {
        self.robots.get(&r).map_or(0, |v| v.applied)
    }

    fn violation(&mut self, tick: u64, robot: u32, property: &'static str, detail: String) {
        self.violations.push(Violation {
            tick,
            robot,
            property,
            detail,
        });
    }

    fn leader_gone(&mut self, tick: u64, robot: u32) {
        if self.current_leader.map(|l| l.0) == Some(robot) {
            self.current_leader = None;
            self.leaderless_since.get_or_insert(tick);
        }
    }

    /// A robot's process died at `tick`: its notes stop; it no longer counts as leader.
    pub fn died(&mut self, tick: u64, robot: u32) {
        self.last_tick = self.last_tick.max(tick);
        self.robots.entry(robot).or_default().alive = false;
        self.leader_gone(tick, robot);
    }

    /// One note of robot `r` at `tick`, in record order.
    pub fn note(&mut self, tick: u64, r: u32, note: &ConsensusNote) {
        self.last_tick = self.last_tick.max(tick);
        self.notes += 1;
        let mut v = self.robots.remove(&r).unwrap_or_default();
        v.alive = true;
        self.apply_note(tick, r, &mut v, note);
        self.robots.insert(r, v);
    }

    fn apply_note(&mut self, tick: u64, r: u32, v: &mut View, note: &ConsensusNote) {
        match *note {
            ConsensusNote::Boot {
                term,
                vote,
                last_index,
                commit,
            } => {
                // A vote of the recorded term must survive too (Figure 2: votedFor is
                // persistent), or the robot can vote twice in that term.
                let lost_vote = term == v.term && v.vote.is_some() && vote != v.vote;
                // Its committed entries must be there; past them its log may legally differ
                // from the record (below).
                if term < v.term || last_index < v.commit || commit < v.commit || lost_vote {
                    self.amnesia += 1;
                }
                // A robot can make its state durable and die before that tick's command (and
                // notes) leaves: write-ahead allows it. So past what the record saw committed,
                // its log may hold entries the record never saw, above or below the recorded
                // length (a truncation and new appends). Those are unknown here and stay
                // unchecked until overwritten; the committed prefix is checked as before.
                let known = v.commit.min(last_index) as usize;
                v.log.truncate(known.min(v.log.len()));
                v.chain.truncate(v.log.len() + 1);
                while (v.log.len() as u64) < last_index {
                    push_entry(v, UNKNOWN);
                }
                v.term = term;
                v.vote = vote;
                v.role = Role::Follower;
                v.commit = commit.min(v.log.len() as u64);
                v.applied = 0;
                v.completeness_checked = 0;
                add_counts(&mut v.sent_before, &v.sent);
                v.sent = SentCounts::default();
                self.leader_gone(tick, r);
            }
            ConsensusNote::State { term, role, vote } => {
                if term < v.term {
                    self.violation(
                        tick,
                        r,
                        "monotonic_term",
                        format!("term went from {} to {term}", v.term),
                    );
                } else if term == v.term && v.vote.is_some() && vote != v.vote {
                    self.violation(
                        tick,
                        r,
                        "monotonic_vote",
                        format!("vote in term {term} changed from {:?} to {vote:?}", v.vote),
                    );
                }
                let was_leader = v.role == Role::Leader && v.term == term;
                v.term = term;
                v.vote = vote;
                v.role = role;
                if role == Role::Leader && !was_leader {
                    v.completeness_checked = 0;
                    if vote != Some(r) {
                        self.violation(
                            tick,
                            r,
                            "election_safety",
                            format!("leader of term {term} voted for {vote:?}, not itself"),
                        );
                    }
                    match self.leaders.get(&term) {
                        Some(&other) if other != r => self.violation(
                            tick,
                            r,
                            "election_safety",
                            format!("second leader of term {term} (robot {other} leads it)"),
                        ),
                        _ => {
                            self.leaders.insert(term, r);
                        }
                    }
                    self.new_leader(tick, r, term);
                } else if role != Role::Leader {
                    self.leader_gone(tick, r);
                }
            }
            ConsensusNote::Append {
                index,
                term,
                digest,
            } => {
                let len = v.log.len() as u64;
                if index != len + 1 {
                    self.violation(
                        tick,
                        r,
                        "record",
                        format!("append at {index} to a log of {len} entries"),
                    );
                }
                // Resynchronise so one bad note does not cascade.
                let keep = index.saturating_sub(1).min(len) as usize;
                v.log.truncate(keep);
                v.chain.truncate(keep + 1);
                while (v.log.len() as u64) < index.saturating_sub(1) {
                    push_entry(v, UNKNOWN);
                }
                let c = push_entry(v, (term, digest));
                if v.log.contains(&UNKNOWN) {
                    // A prefix the record does not show cannot be compared with others'.
                    return;
                }
                match self.entries.get(&(index, term)) {
                    Some(&other) if other != c => self.violation(
                        tick,
                        r,
                        "log_matching",
                        format!(
                            "entry ({index}, term {term}) ends a prefix that differs from another robot's"
                        ),
                    ),
                    Some(_) => {}
                    None => {
                        self.entries.insert((index, term), c);
                    }
                }
            }
            ConsensusNote::Truncate { index } => {
                let len = v.log.len() as u64;
                if index == 0 || index > len {
                    self.violation(
                        tick,
                        r,
                        "record",
                        format!("truncate from {index} in a log of {len} entries"),
                    );
                }
                if index <= v.commit {
                    self.violation(
                        tick,
                        r,
                        "leader_completeness",
                        format!(
                            "removed committed entries from {index} (commit {})",
                            v.commit
                        ),
                    );
                }
                let keep = index.saturating_sub(1).min(len) as usize;
                v.log.truncate(keep);
                v.chain.truncate(keep + 1);
            }
            ConsensusNote::Commit { index } => {
                if index <= v.commit {
                    self.violation(
                        tick,
                        r,
                        "monotonic_commit",
                        format!("commit went from {} to {index}", v.commit),
                    );
                    return;
                }
                if index > v.log.len() as u64 {
                    self.violation(
                        tick,
                        r,
                        "record",
                        format!("commit {index} beyond a log of {} entries", v.log.len()),
                    );
                    return;
                }
                for i in v.commit + 1..=index {
                    let e = v.log[i as usize - 1];
                    let k = i as usize - 1;
                    if e == UNKNOWN {
                        // Not shown by the record: another robot's notes decide it.
                        continue;
                    }
                    if k < self.committed.len() {
                        if self.committed[k] != e {
                            self.violation(
                                tick,
                                r,
                                "state_machine_safety",
                                format!(
                                    "committed (term {}, digest {:08x}) at index {i}, another robot committed (term {}, digest {:08x})",
                                    e.0, e.1, self.committed[k].0, self.committed[k].1
                                ),
                            );
                        }
                    } else if k == self.committed.len() {
                        self.committed.push(e);
                        self.committed_tick.push(tick);
                        self.committed_in.push(v.term);
                    }
                }
                v.commit = index;
            }
            ConsensusNote::Apply {
                index,
                term,
                digest,
            } => {
                if index != v.applied + 1 {
                    self.violation(
                        tick,
                        r,
                        "apply_order",
                        format!("applied {index} after {}", v.applied),
                    );
                }
                if index > v.commit {
                    self.violation(
                        tick,
                        r,
                        "state_machine_safety",
                        format!("applied {index} beyond its commit {}", v.commit),
                    );
                }
                let held = (index as usize).checked_sub(1).and_then(|i| v.log.get(i));
                if held != Some(&(term, digest)) && held != Some(&UNKNOWN) {
                    self.violation(
                        tick,
                        r,
                        "record",
                        format!("applied ({index}, term {term}) not in its log"),
                    );
                }
                match self.applied.get(&index) {
                    Some(&(t, d)) if (t, d) != (term, digest) => self.violation(
                        tick,
                        r,
                        "state_machine_safety",
                        format!(
                            "applied (term {term}, digest {digest:08x}) at index {index}, another robot applied (term {t}, digest {d:08x})"
                        ),
                    ),
                    Some(_) => {}
                    None => {
                        self.applied.insert(index, (term, digest));
                    }
                }
                self.applied_by.entry(index).or_default().insert(r);
                v.applied = index;
            }
            ConsensusNote::Propose {
                index,
                term,
                id,
                decision,
            } => {
                if v.role != Role::Leader || v.term != term {
                    self.violation(
                        tick,
                        r,
                        "record",
                        format!("proposed in term {term} as {:?} of term {}", v.role, v.term),
                    );
                }
                self.proposals.insert(
                    (index, term),
                    Proposal {
                        tick,
                        robot: r,
                        id,
                        decision,
                    },
                );
            }
            ConsensusNote::Sent(c) => v.sent = c,
            ConsensusNote::Quadrant { leader, score, .. } => v.quadrant = Some((leader, score)),
        }
    }

    fn new_leader(&mut self, tick: u64, r: u32, term: u64) {
        if self.current_leader.is_some_and(|(_, t)| t > term) {
            // A stale leader of an older term (e.g. a partitioned minority) does not replace
            // the current one.
            return;
        }
        self.first_leader_tick.get_or_insert(tick);
        if let Some(since) = self.leaderless_since.take() {
            self.reelection_ticks.push(tick - since);
        }
        if self.last_leader.is_some_and(|l| l != r) {
            self.leader_changes += 1;
        }
        self.last_leader = Some(r);
        self.current_leader = Some((r, term));
    }

    /// End of `tick`: leader completeness for every robot that leads now.
    pub fn end_tick(&mut self, tick: u64) {
        self.last_tick = self.last_tick.max(tick);
        let mut found = Vec::new();
        for (&r, v) in self.robots.iter_mut() {
            if !v.alive || v.role != Role::Leader {
                continue;
            }
            while (v.completeness_checked as usize) < self.committed.len() {
                let i = v.completeness_checked as usize;
                let (t, d) = self.committed[i];
                if t > v.term {
                    // Committed by a later leader: not this one's business (and log terms
                    // never decrease, so neither are the entries after it).
                    break;
                }
                if self.committed_in[i] >= v.term {
                    // An earlier term's entry committed in this term or later (by another
                    // leader, while this one is stale): Raft does not promise it here.
                    v.completeness_checked += 1;
                    continue;
                }
                let held = v.log.get(i);
                if held != Some(&(t, d)) && held != Some(&UNKNOWN) {
                    found.push((
                        r,
                        format!(
                            "leader of term {} lacks committed entry {} (term {t})",
                            v.term,
                            i + 1
                        ),
                    ));
                    break;
                }
                v.completeness_checked += 1;
            }
        }
        for (r, detail) in found {
            self.violation(tick, r, "leader_completeness", detail);
        }
    }

    /// Reads `events.jsonl` text and checks it tick by tick.
    pub fn from_events(text: &str) -> Result<Checker, String> {
        let mut c = Checker::new();
        let mut tick: Option<u64> = None;
        for (n, line) in text.lines().enumerate() {
            if line.trim().is_empty() {
                continue;
            }
            let v: Value = serde_json::from_str(line)
                .map_err(|e| format!("events.jsonl line {}: {e}", n + 1))?;
            let t = v["tick"].as_u64().unwrap_or(0);
            if let Some(prev) = tick
                && t > prev
            {
                c.end_tick(prev);
            }
            tick = Some(tick.map_or(t, |p| p.max(t)));
            // An event kind this build does not know is none of the checker's business.
            let Ok(event) = serde_json::from_value::<Event<Value>>(v) else {
                continue;
            };
            match event {
                // Consensus notes are recorded as `{"consensus": {...}}`; a behaviour's notes
                // (any other JSON) are none of the checker's business.
                Event::Note { robot, note, .. } => {
                    match RecordedNote::<IgnoredAny>::from_json(&note)
                        .map_err(|e| format!("events.jsonl line {}: note: {e}", n + 1))?
                    {
                        RecordedNote::Consensus(cn) => c.note(t, robot, &cn),
                        RecordedNote::Behaviour(_) => {}
                    }
                }
                Event::Died { robot, .. } => c.died(t, robot),
                // A restarted robot's old process is gone from that tick; its fresh process
                // announces itself with a Boot note when it rejoins.
                Event::Fault {
                    fault: FaultKind::Restart,
                    robot: Some(robot),
                    ..
                } => c.died(t, robot),
                _ => {}
            }
        }
        if let Some(t) = tick {
            c.end_tick(t);
        }
        Ok(c)
    }
}

fn add_counts(into: &mut SentCounts, c: &SentCounts) {
    into.pre_vote += c.pre_vote;
    into.pre_vote_resp += c.pre_vote_resp;
    into.vote += c.vote;
    into.vote_resp += c.vote_resp;
    into.append += c.append;
    into.append_resp += c.append_resp;
    into.quad_claim += c.quad_claim;
    into.quad_leader += c.quad_leader;
}

#[cfg(test)]
mod tests;
