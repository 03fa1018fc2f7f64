//! Seed 001's measures from the records (section 3.1): per robot the navigation time t_s,
//! travel distance d_m, change in angular velocity ΔΩ (eq. 16) and collisions; per group
//! (the robots that follow one leader) their means and the exploration time; for the run the
//! groups, leaders, tie-break rounds and the classifier's precision p_v (eq. 17). All from
//! `trajectory.csv` (true poses) and `events.jsonl`, so both modes give the same numbers.

use std::collections::BTreeMap;

use serde_json::{Value, json};
use swarmrt_protocol::records::Records;
use swarmrt_scenario::{Config, wrap_angle};

use super::messages::GroupNote;
use super::params::GroupingParams;
use crate::consensus::behaviour_notes;

/// The metrics [`metrics`] computes, as dotted paths into metrics.json.
pub const NAMES: [&str; 11] = [
    "grouping.groups",
    "grouping.leaders",
    "grouping.tie_rounds",
    "grouping.precision",
    "grouping.reached",
    "grouping.collisions",
    "grouping.t_s",
    "grouping.t_nav",
    "grouping.d_m",
    "grouping.delta_omega",
    "grouping.explore_time",
];

/// One robot's run.
#[derive(Debug, Clone, PartialEq)]
pub struct RobotRun {
    /// Robot id.
    pub id: u32,
    /// The leader it followed at the end (itself for a leader), if it chose one.
    pub leader: Option<u32>,
    /// t_s: seconds from the start until it entered its goal (None: it never did).
    pub t_s: Option<f64>,
    /// Seconds from its leader's first formation until it entered its goal: the navigation
    /// alone, without grouping and the leader choice (closer to what the paper times).
    pub t_nav: Option<f64>,
    /// d_m: metres travelled until then (or the end).
    pub d_m: f64,
    /// ΔΩ of eq. 16 until then, deg/s^2: the mean of |Ω(i) - Ω(i-1)| / l_c with Ω the true
    /// turn rate over each decision cycle l_c = dt.
    pub delta_omega: f64,
    /// Collisions it took part in.
    pub collisions: u32,
}

/// Eq. 16 over headings sampled every `dt` seconds, in deg/s^2.
pub fn delta_omega(headings: &[f64], dt: f64) -> f64 {
    let omega: Vec<f64> = headings
        .windows(2)
        .map(|w| wrap_angle(w[1] - w[0]) / dt)
        .collect();
    if omega.len() < 2 {
        return 0.0;
    }
    let sum: f64 = omega.windows(2).map(|w| (w[1] - w[0]).abs() / dt).sum();
    (sum / (omega.len() - 1) as f64).to_degrees()
}

/// Every robot's run, in id order.
pub fn robot_runs(cfg: &Config, run: &Records) -> Vec<RobotRun> {
    let n = cfg.robots.count as usize;
    let dt = cfg.scenario.dt;
    let mut reached: Vec<Option<u64>> = vec![None; n];
    for (tick, r) in run.reached() {
        let r = r as usize;
        if r < n && reached[r].is_none() {
            reached[r] = Some(tick);
        }
    }
    let mut collisions = vec![0u32; n];
    for (_, robot, other) in run.collisions() {
        for r in std::iter::once(robot).chain(other) {
            if (r as usize) < n {
                collisions[r as usize] += 1;
            }
        }
    }
    let mut leader: Vec<Option<u32>> = vec![None; n];
    let mut formed: Vec<Option<u64>> = vec![None; n];
    for (tick, r, note) in behaviour_notes::<GroupNote>(run) {
        let r = r as usize;
        match note {
            GroupNote::Leader { leader: l, .. } if r < n => leader[r] = Some(l),
            GroupNote::Formed { .. } if r < n && formed[r].is_none() => formed[r] = Some(tick),
            _ => {}
        }
    }
    let mut d = vec![0.0; n];
    let mut headings: Vec<Vec<f64>> = vec![Vec::new(); n];
    let mut last: Vec<Option<(f64, f64)>> = vec![None; n];
    for rows in &run.ticks {
        for r in rows {
            let i = r.id as usize;
            if i >= n || reached[i].is_some_and(|t| r.tick > t) {
                continue;
            }
            if let Some((x, y)) = last[i] {
                d[i] += ((r.x - x).powi(2) + (r.y - y).powi(2)).sqrt();
            }
            last[i] = Some((r.x, r.y));
            if r.active {
                headings[i].push(r.theta);
            }
        }
    }
    (0..n)
        .map(|i| RobotRun {
            id: i as u32,
            leader: leader[i],
            t_s: reached[i].map(|t| t as f64 * dt),
            t_nav: match (
                reached[i],
                leader[i].and_then(|l| formed.get(l as usize).copied().flatten()),
            ) {
                (Some(r), Some(f)) => Some(r.saturating_sub(f) as f64 * dt),
                _ => None,
            },
            d_m: d[i],
            delta_omega: delta_omega(&headings[i], dt),
            collisions: collisions[i],
        })
        .collect()
}

fn mean(v: impl Iterator<Item = f64>) -> Option<f64> {
    let (s, n) = v.fold((0.0, 0usize), |(s, n), x| (s + x, n + 1));
    (n > 0).then(|| s / n as f64)
}

/// `grouping` in metrics.json: run totals plus `per_group` and `per_robot` tables (Tables I-IV).
pub fn metrics(
    cfg: &Config,
    _params: &GroupingParams,
    run: &Records,
) -> Vec<(&'static str, Value)> {
    let dt = cfg.scenario.dt;
    let robots = robot_runs(cfg, run);
    // First tick per robot of the notes that time the exploration, and the classifier's
    // counts.
    let mut first_formed: BTreeMap<u32, u64> = BTreeMap::new();
    let mut first_seen: BTreeMap<u32, u64> = BTreeMap::new();
    let mut first_told: BTreeMap<u32, u64> = BTreeMap::new();
    let (mut correct, mut wrong) = (0u64, 0u64);
    let mut changes: BTreeMap<u32, u64> = BTreeMap::new();
    let mut leads: BTreeMap<u32, bool> = BTreeMap::new();
    for (tick, r, note) in behaviour_notes::<GroupNote>(run) {
        match note {
            GroupNote::Formed { .. } => {
                first_formed.entry(r).or_insert(tick);
            }
            GroupNote::GoalSeen => {
                first_seen.entry(r).or_insert(tick);
            }
            GroupNote::GoalTold => {
                first_told.entry(r).or_insert(tick);
            }
            GroupNote::Classified {
                correct: c,
                wrong: w,
            } => {
                correct += u64::from(c);
                wrong += u64::from(w);
            }
            GroupNote::Leader {
                leads: l,
                changes: c,
                ..
            } => {
                changes.insert(r, u64::from(c));
                leads.insert(r, l);
            }
            GroupNote::Clustered | GroupNote::Arrived => {}
        }
    }
    let mut groups: BTreeMap<u32, Vec<&RobotRun>> = BTreeMap::new();
    for r in &robots {
        if let Some(l) = r.leader {
            groups.entry(l).or_default().push(r);
        }
    }
    let per_group: Vec<Value> = groups
        .iter()
        .map(|(&l, members)| {
            let seen = first_seen.get(&l).copied();
            let goal = seen.into_iter().chain(first_told.get(&l).copied()).min();
            let formed = first_formed.get(&l).copied();
            let explore = match (goal, formed) {
                (Some(g), Some(f)) => Some(g.saturating_sub(f) as f64 * dt),
                _ => None,
            };
            json!({
                "leader": l,
                "robots": members.len(),
                "t_s": mean(members.iter().filter_map(|r| r.t_s)),
                "t_nav": mean(members.iter().filter_map(|r| r.t_nav)),
                "d_m": mean(members.iter().map(|r| r.d_m)),
                "delta_omega": mean(members.iter().map(|r| r.delta_omega)),
                "collisions": members.iter().map(|r| r.collisions).sum::<u32>(),
                "reached": members.iter().filter(|r| r.t_s.is_some()).count(),
                "explore_time": explore,
                "found_goal": goal.map(|g| if seen == Some(g) { "seen" } else { "told" }),
            })
        })
        .collect();
    let per_robot: Vec<Value> = robots
        .iter()
        .map(|r| {
            json!({"id": r.id, "leader": r.leader, "t_s": r.t_s, "t_nav": r.t_nav, "d_m": r.d_m,
                   "delta_omega": r.delta_omega, "collisions": r.collisions})
        })
        .collect();
    let collisions = run.collisions().count();
    let all = json!({
        "groups": groups.len(),
        "leaders": leads.values().filter(|&&b| b).count(),
        "tie_rounds": changes.values().sum::<u64>(),
        "precision": (correct + wrong > 0).then(|| correct as f64 / (correct + wrong) as f64),
        "classified": {"correct": correct, "wrong": wrong},
        "reached": robots.iter().filter(|r| r.t_s.is_some()).count(),
        "collisions": collisions,
        "t_s": mean(robots.iter().filter_map(|r| r.t_s)),
        "t_nav": mean(robots.iter().filter_map(|r| r.t_nav)),
        "d_m": mean(robots.iter().map(|r| r.d_m)),
        "delta_omega": mean(robots.iter().map(|r| r.delta_omega)),
        "explore_time": mean(per_group.iter().filter_map(|g| g["explore_time"].as_f64())),
        "per_group": per_group,
        "per_robot": per_robot,
    });
    vec![("grouping", all)]
}
