//! The chain's metrics, from the true poses in `trajectory.csv` and the robots' notes, so
//! both modes give the same numbers.
//!
//! - `rod_violations`: rod-ticks (a pair of consecutive robots, both active, at one tick)
//!   with a length outside `[rod_min - rod_tolerance, rod_max + rod_tolerance]`; out of
//!   `rod_ticks`, with the extreme lengths seen.
//! - `angle_violations`: connector-ticks (a robot and both neighbours active) with an angle
//!   outside `[angle_min - tol, angle_max + tol]`, out of `angle_ticks`.
//! - `vetoes`: vetoes raised (a robot starting to object: depth 1); `veto_depth`: the most
//!   robots one veto travelled (a passed veto counts each robot it reached, the initiator
//!   included); `replans`: vetoes that reached the initiator.
//! - `propagation_ticks`: ticks from the initiator's first move to the last chain end's
//!   first move (a robot moves when it is 2 cm off its start), and per robot between them.
//! - `head_progress`: how much nearer the goal the initiator ended than it started, in
//!   metres; `head_path`: the length of its path.
//! - `collisions`, `reached`, and whether and when the tail reached the target.

use serde_json::{Value, json};
use swarmrt_protocol::records::{Records, Row};
use swarmrt_scenario::Config;

use super::messages::ChainNote;
use super::params::ChainParams;
use super::rods::connector_angle;
use crate::behaviour::{Series, SeriesPlot};
use crate::consensus::behaviour_notes;

/// The metrics [`metrics`] computes, as dotted paths into metrics.json.
pub const NAMES: [&str; 14] = [
    "chain.rod_violations",
    "chain.rod_ticks",
    "chain.angle_violations",
    "chain.vetoes",
    "chain.veto_depth",
    "chain.replans",
    "chain.propagation_ticks",
    "chain.propagation_per_robot",
    "chain.head_progress",
    "chain.head_path",
    "chain.collisions",
    "chain.reached",
    "chain.tail_reached",
    "chain.tail_reached_tick",
];

/// Metres off its start position at which a robot counts as moved.
const MOVED: f64 = 0.02;

/// The tick each robot first moved (`None`: never).
#[derive(Debug, Clone, PartialEq)]
pub struct FirstMoves(pub Vec<Option<u64>>);

/// The tick each robot first moved by [`MOVED`] from its first recorded position.
pub fn first_moves(run: &Records) -> FirstMoves {
    let Some(first) = run.ticks.first() else {
        return FirstMoves(Vec::new());
    };
    let start: Vec<(f64, f64)> = first.iter().map(|r| (r.x, r.y)).collect();
    let mut out = vec![None; start.len()];
    for rows in &run.ticks {
        for r in rows {
            let i = r.id as usize;
            if i < out.len()
                && out[i].is_none()
                && (r.x - start[i].0).hypot(r.y - start[i].1) > MOVED
            {
                out[i] = Some(r.tick);
            }
        }
    }
    FirstMoves(out)
}

/// The length of every rod whose two robots are active at this tick.
fn rods(rows: &[Row]) -> impl Iterator<Item = f64> + '_ {
    rows.windows(2)
        .filter(|w| w[0].active && w[1].active && w[1].id == w[0].id + 1)
        .map(|w| (w[1].x - w[0].x).hypot(w[1].y - w[0].y))
}

/// The angle (radians) of every connector whose robot and two neighbours are active.
fn angles(rows: &[Row]) -> impl Iterator<Item = f64> + '_ {
    rows.windows(3)
        .filter(|w| w.iter().all(|r| r.active) && w[2].id == w[0].id + 2)
        .map(|w| connector_angle((w[0].x, w[0].y), (w[1].x, w[1].y), (w[2].x, w[2].y)))
}

/// The ends of the chain other than the initiator.
fn ends(n: usize, initiator: usize) -> Vec<usize> {
    let mut e = vec![n - 1];
    if n > 1 {
        e.insert(0, 0);
    }
    e.retain(|&x| x != initiator);
    e.dedup();
    e
}

/// The chain's metrics.
pub fn metrics(cfg: &Config, p: &ChainParams, run: &Records) -> Vec<(&'static str, Value)> {
    let n = cfg.robots.count as usize;
    let c = (p.initiator as usize).min(n.saturating_sub(1));
    let (rod_lo, rod_hi) = (p.rod_min - p.rod_tolerance, p.rod_max + p.rod_tolerance);
    let tol = p.angle_tolerance_deg.to_radians();
    let (ang_lo, ang_hi) = (
        p.angle_min_deg.to_radians() - tol,
        p.angle_max_deg.to_radians() + tol,
    );
    let (mut rod_ticks, mut rod_bad, mut angle_ticks, mut angle_bad) = (0u64, 0u64, 0u64, 0u64);
    let (mut longest, mut shortest) = (0.0f64, f64::INFINITY);
    let mut sharpest = f64::INFINITY;
    for rows in &run.ticks {
        for len in rods(rows) {
            rod_ticks += 1;
            rod_bad += u64::from(len < rod_lo || len > rod_hi);
            longest = longest.max(len);
            shortest = shortest.min(len);
        }
        for a in angles(rows) {
            angle_ticks += 1;
            angle_bad += u64::from(a < ang_lo || a > ang_hi);
            sharpest = sharpest.min(a);
        }
    }
    let (mut vetoes, mut depth, mut replans) = (0u64, 0u64, 0u64);
    for (_, _, note) in behaviour_notes::<ChainNote>(run) {
        let d = match note {
            ChainNote::Veto { depth: d, .. } => {
                vetoes += u64::from(d == 1);
                d
            }
            ChainNote::Replan { depth: d, .. } => {
                replans += 1;
                d
            }
        };
        depth = depth.max(u64::from(d));
    }
    let moves = first_moves(run);
    let t0 = moves.0.get(c).copied().flatten();
    let ends = if n > 0 { ends(n, c) } else { Vec::new() };
    let propagation = t0.and_then(|t0| {
        ends.iter()
            .map(|&e| {
                moves
                    .0
                    .get(e)
                    .copied()
                    .flatten()
                    .map(|t| t.saturating_sub(t0))
            })
            .collect::<Option<Vec<u64>>>()
            .and_then(|v| v.into_iter().max())
    });
    let hops = ends.iter().map(|&e| e.abs_diff(c)).max().unwrap_or(0);
    let goal = cfg.goal_of(p.initiator);
    let head: Vec<(f64, f64)> = run
        .ticks
        .iter()
        .filter_map(|rows| rows.iter().find(|r| r.id as usize == c))
        .map(|r| (r.x, r.y))
        .collect();
    let to_goal = |q: &(f64, f64)| (q.0 - goal.x).hypot(q.1 - goal.y);
    let progress = match (head.first(), head.last()) {
        (Some(a), Some(b)) => to_goal(a) - to_goal(b),
        _ => 0.0,
    };
    let path: f64 = head
        .windows(2)
        .map(|w| (w[1].0 - w[0].0).hypot(w[1].1 - w[0].1))
        .sum();
    let tail = ends.last().copied();
    let tail_tick = run
        .reached()
        .find(|&(_, r)| tail.is_some_and(|t| r as usize == t))
        .map(|(tick, _)| tick);
    let finite = |v: f64| if v.is_finite() { json!(v) } else { Value::Null };
    let all = json!({
        "rod_violations": rod_bad,
        "rod_ticks": rod_ticks,
        "rod_longest": finite(if rod_ticks > 0 { longest } else { f64::NAN }),
        "rod_shortest": finite(shortest),
        "angle_violations": angle_bad,
        "angle_ticks": angle_ticks,
        "angle_sharpest_deg": finite(sharpest.to_degrees()),
        "vetoes": vetoes,
        "veto_depth": depth,
        "replans": replans,
        "propagation_ticks": propagation,
        "propagation_per_robot": propagation.filter(|_| hops > 0).map(|t| t as f64 / hops as f64),
        "head_progress": progress,
        "head_path": path,
        "collisions": run.collisions().count(),
        "reached": run.reached().count(),
        "tail_reached": tail_tick.is_some(),
        "tail_reached_tick": tail_tick,
    });
    vec![("chain", all)]
}

/// Per tick: the longest and shortest rod and the sharpest connector (`chain.csv`, drawn as
/// `chain_rods.png`); per robot: the tick it first moved (`chain_propagation.csv`, the wave
/// of a motion travelling down the chain); per veto note: who and when (`chain_vetoes.csv`,
/// when there were vetoes).
pub fn series(cfg: &Config, p: &ChainParams, run: &Records) -> Vec<Series> {
    let dt = cfg.scenario.dt;
    let mut rows = Vec::new();
    for tick in &run.ticks {
        let longest = rods(tick).fold(f64::NAN, f64::max);
        let shortest = rods(tick).fold(f64::NAN, f64::min);
        let sharpest = angles(tick).fold(f64::NAN, f64::min).to_degrees();
        let t = tick.first().map_or(0, |r| r.tick);
        rows.push(vec![
            t as f64,
            t as f64 * dt,
            longest,
            shortest,
            p.rod_max,
            p.rod_min,
            sharpest,
        ]);
    }
    let moves = first_moves(run);
    let wave = moves
        .0
        .iter()
        .enumerate()
        .filter_map(|(i, t)| t.map(|t| vec![i as f64, t as f64, t as f64 * dt]))
        .collect();
    // Veto events: a depth-1 veto opens one, the vetoes it passes on and the re-plan belong
    // to it (Fig. 3's back-propagation, one line per event).
    let mut vetoes = Vec::new();
    let mut event = 0u64;
    for (tick, robot, note) in behaviour_notes::<ChainNote>(run) {
        let depth = match note {
            ChainNote::Veto { depth, .. } | ChainNote::Replan { depth, .. } => depth,
        };
        event += u64::from(matches!(note, ChainNote::Veto { depth: 1, .. }));
        vetoes.push(vec![
            tick as f64,
            tick as f64 * dt,
            robot as f64,
            depth as f64,
            event as f64,
        ]);
    }
    let mut out = vec![
        Series {
            name: "chain",
            columns: vec![
                "tick",
                "time_s",
                "longest_rod",
                "shortest_rod",
                "rod_max",
                "rod_min",
                "sharpest_angle_deg",
            ],
            rows,
            plots: vec![SeriesPlot {
                file: "chain_rods",
                title: format!("{}: longest and shortest rod", cfg.scenario.name),
                x: "time_s",
                lines: vec!["longest_rod", "shortest_rod", "rod_max", "rod_min"],
                group_by: None,
                y_label: "rod length (m)",
            }],
        },
        Series {
            name: "chain_propagation",
            columns: vec!["robot", "first_move_tick", "first_move_s"],
            rows: wave,
            plots: vec![SeriesPlot {
                file: "chain_propagation",
                title: format!("{}: when each robot first moved", cfg.scenario.name),
                x: "robot",
                lines: vec!["first_move_tick"],
                group_by: None,
                y_label: "tick",
            }],
        },
    ];
    if !vetoes.is_empty() {
        out.push(Series {
            name: "chain_vetoes",
            columns: vec!["tick", "time_s", "robot", "depth", "event"],
            rows: vetoes,
            plots: vec![SeriesPlot {
                file: "chain_vetoes",
                title: format!(
                    "{}: vetoes travelling back to the initiator",
                    cfg.scenario.name
                ),
                x: "tick",
                lines: vec!["robot"],
                group_by: Some("event"),
                y_label: "robot",
            }],
        });
    }
    out
}
