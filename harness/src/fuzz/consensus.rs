//! `swarm fuzz consensus`: seeded fault fuzzing of the Raft election and log.
//!
//! Each seed draws a case: robot count, radio (Bernoulli or Gilbert-Elliott loss up to about
//! 50 %, delay, jitter, capacity), Raft timing (pre-vote and check-quorum usually on, but not
//! always: safety must hold either way), beacons sharing the frames, and a fault phase with
//! partitions, isolated robots (a robot drifting out of range and back), crashes of the
//! leader or of any robot and restarts with persistent state, and scheduled proposals. Then
//! every fault heals (partitions end, crashed robots restart) and one more proposal is
//! scheduled. The case holds when the checker finds no violation at any tick and, within a
//! bound after the heal, there is a leader and the last proposal is committed and applied by
//! every robot (liveness).

use std::fmt;

use rand::Rng as _;
use swarmrt_agent::consensus::Item;
use swarmrt_agent::consensus::raft::Raft;
use swarmrt_agent::consensus::stream;
use swarmrt_scenario::consensus::{ConsensusConfig, Proposal};
use swarmrt_scenario::{Config, LossModel};

use super::{CrashPoint, Sim, base_config, grid};

/// A fault in the fault phase.
#[derive(Debug, Clone, PartialEq)]
pub enum Fault {
    /// Robots on different sides cannot hear each other during `from..to`.
    Partition {
        /// First tick.
        from: u64,
        /// First tick healed.
        to: u64,
        /// Side of each robot.
        side: Vec<bool>,
    },
    /// Robot `robot` crashes at `at` (the leader of that moment when `leader`) and restarts
    /// at `restart` with its persistent state.
    Crash {
        /// Tick of the crash.
        at: u64,
        /// The robot (when not the leader).
        robot: u32,
        /// Crash whoever leads at `at` instead (falls back to `robot` without a leader).
        leader: bool,
        /// Tick of the restart (at the latest the heal).
        restart: u64,
    },
    /// Whoever leads at `from` is cut off from all others until `to` (a stale leader that
    /// keeps leading alone, then comes back).
    IsolateLeader {
        /// First tick.
        from: u64,
        /// First tick healed.
        to: u64,
    },
    /// Figure 8 of the Raft paper, staged. Whoever leads at `from` (A) is cut off alone until
    /// `to` while proposals arrive, so their entries are on A alone. The first other robot to
    /// win an election meanwhile (B) crashes in the tick it won, after writing its no-op and
    /// before anything left: a later-term entry at the same index, on B alone. The first
    /// leader after the cut heals (usually A, in a later term, its no-op behind its old
    /// entries) crashes `ack` ticks after a follower was seen partway through catching up on
    /// its log (grown, still short of the leader's), when that follower's acknowledgement of
    /// a prefix can have arrived but not yet the rest; B restarts then, and A at the heal.
    Figure8 {
        /// First tick of the cut.
        from: u64,
        /// First tick healed.
        to: u64,
        /// Ticks from a follower's partial catch-up to the leader's crash.
        ack: u64,
    },
}

/// One drawn case.
#[derive(Debug, Clone)]
pub struct Case {
    /// The seed it was drawn from.
    pub seed: u64,
    /// Scenario (robot count, radio, consensus and its proposals).
    pub cfg: Config,
    /// Faults, in no particular order.
    pub faults: Vec<Fault>,
    /// Tick at which every fault is healed.
    pub heal: u64,
    /// Ticks after the heal within which a leader and the last proposal's commit and apply
    /// by every robot are required.
    pub bound: u64,
}

impl fmt::Display for Case {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let r = &self.cfg.radio;
        let c = self
            .cfg
            .consensus
            .as_ref()
            .expect("fuzz cases run consensus");
        let loss = match r.loss_model {
            LossModel::Bernoulli => format!("bernoulli {:.2}", r.loss),
            LossModel::GilbertElliott => format!(
                "gilbert-elliott p={:.2} r={:.2} good={:.2} bad={:.2}",
                r.ge_p, r.ge_r, r.ge_loss_good, r.ge_loss_bad
            ),
        };
        write!(
            f,
            "robots={} loss={loss} delay={} jitter={} capacity={} election={}..{} heartbeat={} pre_vote={} check_quorum={} faults={} heal={} bound={}",
            self.cfg.robots.count,
            r.delay_ticks,
            r.jitter_ticks,
            r.capacity,
            c.election_timeout_min,
            c.election_timeout_max,
            c.heartbeat_ticks,
            c.pre_vote,
            c.check_quorum,
            self.faults.len(),
            self.heal,
            self.bound
        )
    }
}

/// Draws the case of `seed`.
pub fn draw(seed: u64) -> Case {
    let mut rng = stream(seed, "fuzz-case", 0);
    let mut cfg = base_config();
    cfg.scenario.seed = seed;
    let n: u32 = if rng.random_bool(0.05) {
        rng.random_range(1..=2)
    } else {
        rng.random_range(3..=11)
    };
    cfg.robots.count = n;
    let r = &mut cfg.radio;
    if rng.random_bool(0.5) {
        r.loss_model = LossModel::Bernoulli;
        r.loss = rng.random_range(0.0..=0.5);
    } else {
        r.loss_model = LossModel::GilbertElliott;
        r.ge_p = rng.random_range(0.01..=0.2);
        // Bursts end at least as often as they start: stationary loss about 50 % at most.
        r.ge_r = rng.random_range(r.ge_p..=0.6);
        r.ge_loss_good = rng.random_range(0.0..=0.05);
        r.ge_loss_bad = rng.random_range(0.5..=1.0);
    }
    r.delay_ticks = rng.random_range(0..=3);
    r.jitter_ticks = rng.random_range(0..=3);
    r.capacity = rng.random_range(2..=8);
    // Raft's timing requirement (section 5.6: broadcast time << election timeout): the
    // shortest timeout spans at least two radio round trips, heartbeats at least four per
    // timeout. Shorter timeouts livelock under bursty loss (seed 2654 before this rule: a
    // robot kept timing out and, without pre-vote, deposed every new leader).
    let rtt = 2 * (1 + r.delay_ticks + r.jitter_ticks);
    let lo = (2 * rtt).max(8);
    let min = rng.random_range(lo..=lo + 22);
    let max = min + rng.random_range(4..=30);
    let heartbeat = rng.random_range(1..=(min / 4).max(1));
    let heal: u64 = rng.random_range(200..=800);
    let mut propose: Vec<Proposal> = (0..rng.random_range(0..=3))
        .map(|k| Proposal {
            tick: rng.random_range(0..heal),
            goal: Some([k as f64, 1.0]),
            speed: None,
        })
        .collect();
    propose.push(Proposal {
        tick: heal,
        goal: None,
        speed: Some(0.25),
    });
    cfg.consensus = Some(ConsensusConfig {
        election_timeout_min: min,
        election_timeout_max: max,
        heartbeat_ticks: heartbeat,
        pre_vote: rng.random_bool(0.9),
        check_quorum: rng.random_bool(0.9),
        stats_every: 50,
        propose,
        ..ConsensusConfig::default()
    });
    if cfg.behaviour.kind == "goto" {
        let period: i64 = if rng.random_bool(0.5) {
            0
        } else {
            rng.random_range(2..=10)
        };
        cfg.behaviour
            .params
            .insert("beacon_period".into(), toml::Value::Integer(period));
    }
    let mut faults = Vec::new();
    for _ in 0..rng.random_range(0..=6) {
        let from = rng.random_range(0..heal);
        match rng.random_range(0..3) {
            0 => {
                let to = (from + rng.random_range(10..=300)).min(heal);
                faults.push(Fault::Partition {
                    from,
                    to,
                    side: (0..n).map(|_| rng.random_bool(0.5)).collect(),
                });
            }
            1 => {
                // One robot drifts out of range and comes back.
                let to = (from + rng.random_range(10..=300)).min(heal);
                let lone = rng.random_range(0..n);
                faults.push(Fault::Partition {
                    from,
                    to,
                    side: (0..n).map(|i| i == lone).collect(),
                });
            }
            _ => {
                let restart = (from + rng.random_range(1..=300)).min(heal);
                faults.push(Fault::Crash {
                    at: from,
                    robot: rng.random_range(0..n),
                    leader: rng.random_bool(0.5),
                    restart,
                });
            }
        }
    }
    shapes(seed, &mut cfg, &mut faults, heal, (min, max, rtt));
    // Liveness: enough for several elections under loss, with the round trips of the delay.
    let bound = 30 * (max as u64 + rtt as u64) + 300;
    Case {
        seed,
        cfg,
        faults,
        heal,
        bound,
    }
}

/// Fault shapes aimed at the textbook Raft bugs (docs/consensus.md, "Mutants"), drawn from a
/// stream of their own and appended after the faults above, so those draws stay as they were
/// (a seed's base case is unchanged; about two thirds of the seeds get extra faults):
/// - leader churn: the leader crashes a few times in a row, each time right after a burst of
///   proposals (its entries on a minority at most), restarts soon, and sometimes a voter crashes and
///   restarts during the election that follows (Figure 8; votes across restarts);
/// - a stale leader: the leader of a moment is cut off alone while a proposal arrives, and
///   comes back after the others elected a new one (stale terms, conflicting entries);
/// - Figure 8 ([`Fault::Figure8`], from a stream of its own): an earlier term's entries
///   replicated to a majority by a later leader that crashes before its own no-op is.
fn shapes(seed: u64, cfg: &mut Config, faults: &mut Vec<Fault>, heal: u64, t: (u32, u32, u32)) {
    let (min, max, rtt) = (t.0 as u64, t.1 as u64, t.2 as u64);
    let n = cfg.robots.count;
    let mut rng = stream(seed, "shape", 0);
    let mut extra: Vec<u64> = Vec::new();
    if rng.random_bool(0.5) {
        let mut at = rng.random_range(0..heal);
        for _ in 0..rng.random_range(2..=6) {
            at += rng.random_range(max..=3 * max + rtt);
            if at >= heal {
                break;
            }
            // A burst: more decisions than one frame carries, so a follower catching up
            // acknowledges a prefix without the next leader's no-op (Figure 8's window).
            let before = at.saturating_sub(rng.random_range(0..=rtt + 1));
            for j in 0..rng.random_range(1..=8) {
                extra.push(before.saturating_sub(j));
            }
            faults.push(Fault::Crash {
                at,
                robot: rng.random_range(0..n),
                leader: true,
                restart: (at + rng.random_range(1..=max)).min(heal),
            });
            if rng.random_bool(0.5) {
                let v = at + rng.random_range(min..=max + rtt);
                if v < heal {
                    faults.push(Fault::Crash {
                        at: v,
                        robot: rng.random_range(0..n),
                        leader: false,
                        restart: (v + rng.random_range(1..=rtt + 2)).min(heal),
                    });
                }
            }
        }
    }
    if rng.random_bool(0.3) {
        let from = rng.random_range(0..heal);
        let to = (from + rng.random_range(min..=2 * max + rtt)).min(heal);
        extra.push(from + rng.random_range(1..=rtt + 1));
        faults.push(Fault::IsolateLeader { from, to });
    }
    // Figure 8 (its own stream, so the shapes above stay as they were): a burst of proposals
    // longer than two frames, so a follower catching up on it acknowledges a prefix without
    // the new leader's no-op (the note budget of a tick holds about two frames of appends).
    let mut rng = stream(seed, "figure8", 0);
    if n >= 3 && rng.random_bool(0.3) {
        let from = rng.random_range(0..heal);
        let to = (from + rng.random_range(max + 2 * rtt..=3 * max + 2 * rtt)).min(heal);
        // The acknowledgement takes half a round trip, plus up to one tick of slack.
        let ack = rng.random_range(rtt / 2..=rtt / 2 + 1);
        for _ in 0..rng.random_range(16..=32) {
            extra.push(from + 1);
        }
        faults.push(Fault::Figure8 { from, to, ack });
    }
    if let Some(c) = cfg.consensus.as_mut() {
        // Before the last proposal (the one at the heal that liveness waits for).
        let last = c.propose.pop();
        let k0 = c.propose.len();
        for (j, tick) in extra.into_iter().filter(|&t| t < heal).enumerate() {
            c.propose.push(Proposal {
                tick,
                goal: Some([(k0 + j) as f64, 1.0]),
                speed: None,
            });
        }
        c.propose.extend(last);
    }
}

/// What one case did.
#[derive(Debug, Clone)]
pub struct Outcome {
    /// Why it failed (violations or liveness), empty when it held.
    pub failures: Vec<String>,
    /// Ticks simulated.
    pub ticks: u64,
    /// Ticks from the heal to the last proposal applied everywhere, when it was.
    pub recovered_after: Option<u64>,
    /// The recorded `events.jsonl` text, when asked for.
    pub events: Option<String>,
    /// Messages left unprocessed for lack of note room, and dropped for lack of frames.
    pub budget: (u64, u64),
}

/// Runs a case; `record` keeps its note stream as `events.jsonl` text.
pub fn run(case: &Case, record: bool) -> Outcome {
    let n = case.cfg.robots.count as usize;
    let mut sim = Sim::new(&case.cfg, grid(n, 0.7));
    if record {
        sim.record();
    }
    let last_id = case
        .cfg
        .consensus
        .as_ref()
        .map_or(0, |c| c.propose.len().saturating_sub(1)) as u16;
    let mut crashed_by: Vec<Option<usize>> = vec![None; n];
    let mut isolated: Vec<Option<u32>> = vec![None; case.faults.len()];
    let mut fig8: Vec<Figure8State> = vec![Figure8State::default(); case.faults.len()];
    let end = case.heal + case.bound;
    let mut recovered_after = None;
    let mut failures = Vec::new();
    while sim.tick() < end {
        let t = sim.tick();
        // Faults take effect at the tick boundary, in the order drawn.
        for (k, f) in case.faults.iter().enumerate() {
            if let Fault::IsolateLeader { from, .. } = f
                && *from == t
            {
                isolated[k] = sim.leader();
            }
            if let &Fault::Figure8 { from, to, ack } = f {
                let st = &mut fig8[k];
                if from == t
                    && let Some(a) = sim.leader()
                {
                    isolated[k] = Some(a);
                    st.a_term = term_of(&sim, a);
                    st.armed = true;
                    sim.crash_on_winning(Some(Some(a)));
                }
                if st.armed {
                    if let Some(b) = sim.take_crashed_on_winning() {
                        st.armed = false;
                        st.b = Some(b);
                        crashed_by[b as usize] = Some(k);
                    } else if t >= to {
                        st.armed = false;
                        sim.crash_on_winning(None);
                    }
                }
                if st.b.is_some() && st.crash.is_none() && t >= to {
                    match st.leader {
                        None => {
                            if let Some(l) = sim.leader()
                                && term_of(&sim, l) > st.a_term
                            {
                                st.leader = Some(l);
                                st.last = (0..n as u32).map(|r| last_index(&sim, r)).collect();
                            }
                        }
                        Some(l) => {
                            // A follower whose log grew this tick but still ends short of
                            // the leader's: it acknowledges a prefix. (A robot that is down
                            // has no log here; its restart is not growth.)
                            let top = last_index(&sim, l).unwrap_or(0);
                            for r in (0..n as u32).filter(|&r| r != l) {
                                let li = last_index(&sim, r);
                                if let (Some(now), Some(Some(before))) =
                                    (li, st.last.get(r as usize))
                                    && now > *before
                                    && now < top
                                    && st.crash.is_none()
                                {
                                    st.crash = Some((l, t + ack));
                                }
                                st.last[r as usize] = li;
                            }
                        }
                    }
                }
                if let (Some(b), Some((l, at))) = (st.b, st.crash)
                    && at == t
                {
                    if sim.alive(l) && crashed_by[b as usize] == Some(k) {
                        sim.crash(l);
                        crashed_by[l as usize] = Some(k);
                        sim.restart(b);
                        crashed_by[b as usize] = None;
                    }
                    st.b = None;
                }
            }
            if let Fault::Crash {
                at,
                robot,
                leader,
                restart,
            } = f
            {
                if *at == t {
                    let target = if *leader {
                        sim.leader().unwrap_or(*robot)
                    } else {
                        *robot
                    };
                    if sim.alive(target) {
                        sim.crash_at(target, crash_point(case.seed, k));
                        crashed_by[target as usize] = Some(k);
                    }
                }
                for (r, by) in crashed_by.iter_mut().enumerate() {
                    if *by == Some(k) && (*restart == t || t >= case.heal) {
                        sim.restart(r as u32);
                        *by = None;
                    }
                }
            }
        }
        if t >= case.heal {
            for (r, by) in crashed_by.iter_mut().enumerate() {
                if by.take().is_some() {
                    sim.restart(r as u32);
                }
            }
        }
        sim.step(groups(&case.faults, &isolated, t, n));
        if !sim.checker().violations().is_empty() {
            break;
        }
        if t >= case.heal && sim.checker().current_leader().is_some() {
            let done = (0..n as u32).all(|r| {
                sim.agent(r)
                    .and_then(|a| a.consensus())
                    .and_then(|c| c.raft())
                    .is_some_and(|raft| applied_decision(raft, last_id))
            });
            if done {
                recovered_after = Some(t + 1 - case.heal);
                break;
            }
        }
    }
    for v in sim.checker().violations().iter().take(5) {
        failures.push(v.to_string());
    }
    if sim.checker().amnesia_restarts() > 0 {
        failures.push(format!(
            "{} restarts lost persistent state",
            sim.checker().amnesia_restarts()
        ));
    }
    if failures.is_empty() && recovered_after.is_none() {
        failures.push(format!(
            "liveness: {} ticks after the heal at {}: leader {:?}, committed {}, applied per robot {:?}",
            case.bound,
            case.heal,
            sim.checker().current_leader(),
            sim.checker().committed(),
            (0..n as u32).map(|r| sim.checker().applied_by(r)).collect::<Vec<_>>()
        ));
    }
    Outcome {
        failures,
        ticks: sim.tick(),
        recovered_after,
        events: record.then(|| sim.recorded()),
        budget: sim.budget_counters(),
    }
}

/// Progress of a [`Fault::Figure8`] through its stages.
#[derive(Debug, Clone, Default)]
struct Figure8State {
    /// The term of the leader cut off (A), so the leader after the cut is told from it.
    a_term: u64,
    /// Waiting for the first other robot to win (B).
    armed: bool,
    /// B, down since it won.
    b: Option<u32>,
    /// The first leader after the cut.
    leader: Option<u32>,
    /// Every robot's last log index at the previous tick (`None`: down), once that leader
    /// is known.
    last: Vec<Option<u64>>,
    /// That leader, and the tick it crashes at.
    crash: Option<(u32, u64)>,
}

/// Robot `r`'s last log index, unless it is down.
fn last_index(sim: &Sim, r: u32) -> Option<u64> {
    sim.agent(r)
        .and_then(|a| a.consensus())
        .and_then(|c| c.raft())
        .map(|raft| raft.log().last_index())
}

fn term_of(sim: &Sim, r: u32) -> u64 {
    sim.agent(r)
        .and_then(|a| a.consensus())
        .and_then(|c| c.raft())
        .map_or(0, |raft| raft.term())
}

/// Radio groups at tick `t`: one bit per active partition, so two robots are apart when any
/// active partition puts them on different sides.
/// `isolated[k]` is the robot fault `k` cut off, for [`Fault::IsolateLeader`] and
/// [`Fault::Figure8`].
fn groups(faults: &[Fault], isolated: &[Option<u32>], t: u64, n: usize) -> Option<Vec<u64>> {
    let mut g = vec![0u64; n];
    let mut any = false;
    for (bit, f) in faults.iter().enumerate() {
        match f {
            Fault::Partition { from, to, side } if (*from..*to).contains(&t) => {
                any = true;
                for (r, s) in side.iter().enumerate() {
                    g[r] |= (*s as u64) << bit;
                }
            }
            Fault::IsolateLeader { from, to } | Fault::Figure8 { from, to, .. }
                if (*from..*to).contains(&t) =>
            {
                if let Some(l) = isolated[bit] {
                    any = true;
                    g[l as usize] |= 1 << bit;
                }
            }
            _ => {}
        }
    }
    any.then_some(g)
}

/// The last `last` recorded events of `events` (an `events.jsonl` text) as readable lines,
/// `tick robot: what`, oldest first.
pub fn timeline(events: &str, last: usize) -> Vec<String> {
    let lines: Vec<&str> = events.lines().collect();
    lines[lines.len().saturating_sub(last)..]
        .iter()
        .map(|l| match serde_json::from_str::<serde_json::Value>(l) {
            Ok(serde_json::Value::Object(mut o)) => {
                let tick = o.remove("tick").map(|v| v.to_string()).unwrap_or_default();
                let robot = o.remove("robot").map(|v| v.to_string()).unwrap_or_default();
                // `{"event":"note","note":{"consensus":X}}` reads as X.
                let what = match (o.get("event"), o.get("note")) {
                    (Some(e), Some(n)) if e == "note" => {
                        n.get("consensus").unwrap_or(n).to_string()
                    }
                    _ => serde_json::Value::Object(o).to_string(),
                };
                format!("{tick:>6} r{robot:<3} {what}")
            }
            _ => (*l).to_string(),
        })
        .collect()
}

/// Whether `raft` has applied scheduled decision `id`.
pub fn applied_decision(raft: &Raft, id: u16) -> bool {
    (1..=raft.applied()).any(|i| {
        matches!(raft.log().get(i).map(|e| e.item), Some(Item::Decision { id: k, .. }) if k == id)
    })
}

/// Where fault `k` of case `seed` crashes its robot: between ticks, after the write to stable
/// storage but before sending, or during a torn write; a third each, from a stream of its own
/// so the cases drawn before crash points existed stay the same.
fn crash_point(seed: u64, k: usize) -> CrashPoint {
    match stream(seed, "crash_point", k as u64).random_range(0..3) {
        0 => CrashPoint::BetweenTicks,
        1 => CrashPoint::AfterWrite,
        _ => CrashPoint::TornWrite,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_seed_replays_to_the_same_notes() {
        let case = draw(11);
        let (a, b) = (run(&case, true), run(&draw(11), true));
        assert!(a.failures.is_empty(), "{:?}", a.failures);
        assert_eq!(a.ticks, b.ticks);
        assert_eq!(a.events, b.events);
        assert_ne!(draw(12).to_string(), case.to_string());
    }

    #[test]
    fn liveness_fails_when_the_bound_is_too_short() {
        let mut case = draw(3);
        case.faults.clear();
        case.bound = 1;
        let out = run(&case, false);
        assert_eq!(out.failures.len(), 1, "{:?}", out.failures);
        assert!(
            out.failures[0].starts_with("liveness"),
            "{:?}",
            out.failures
        );
    }

    #[test]
    fn crashing_the_leader_and_partitions_still_hold() {
        // Every seed below draws at least one leader crash; all must hold.
        let mut crashed = 0;
        for seed in 0..40 {
            let case = draw(seed);
            if case
                .faults
                .iter()
                .any(|f| matches!(f, Fault::Crash { leader: true, .. }))
            {
                crashed += 1;
                let out = run(&case, false);
                assert!(out.failures.is_empty(), "seed {seed}: {:?}", out.failures);
            }
        }
        assert!(crashed >= 5, "enough leader crashes drawn: {crashed}");
    }
}
