//! Flock performance from the records (eq. 14-22): per flock and tick, order o', cohesion c',
//! velocity v' along the migration urge, instant performance p' and overall performance p̄;
//! and the PSO fitness F_p. Computed from the true poses in `trajectory.csv`, so both modes
//! give the same numbers.
//!
//! A flock is all its robots, whatever their state: a robot knocked down by a collision (or
//! killed) stays where it stopped and drags the flock's cohesion and speed down. The paper's
//! e-pucks just bump; counting only robots still moving would reward weights that crash fast
//! (a flock whose robots are all down would drop out of p̄ instead of scoring zero).

use serde_json::{Value, json};
use swarmrt_protocol::records::Records;
use swarmrt_scenario::Config;

use super::params::FlockingParams;
use crate::behaviour::{Series, SeriesPlot};

/// The metrics [`metrics`] computes, as dotted paths into metrics.json.
pub const NAMES: [&str; 6] = [
    "flocking.order",
    "flocking.cohesion",
    "flocking.velocity",
    "flocking.performance",
    "flocking.fitness",
    "flocking.distance",
];

/// One flock at one tick.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FlockTick {
    /// The tick.
    pub tick: u64,
    /// Robots of the flock still active (the metrics count all of them).
    pub robots: usize,
    /// o'(t), eq. 14: length of the mean heading vector, 1 when all point the same way.
    pub order: f64,
    /// c'(t), eq. 15: 1 / (1 + mean distance to the centre of mass in metres).
    pub cohesion: f64,
    /// v'(t), eq. 16: the centre of mass's speed along the migration urge over v_max, not
    /// below 0.
    pub velocity: f64,
    /// p'(t) = o' c' v', eq. 17.
    pub performance: f64,
    /// p̄(t), eq. 18: mean of p' from the first tick to this one.
    pub overall: f64,
    /// f_p(t) = 0.3 o' + 0.4 c' + 0.3 s', eq. 20-22 (s' penalises mates closer than D to the
    /// centre of mass).
    pub fitness_term: f64,
    /// Centre of mass.
    pub com: (f64, f64),
    /// How far the centre of mass has moved along the migration urge since tick 0 (d_p of
    /// eq. 19 at this tick).
    pub travelled: f64,
}

/// Per flock (start group), its ticks from tick 1 on (v' needs the tick before).
pub fn flock_ticks(cfg: &Config, params: &FlockingParams, run: &Records) -> Vec<Vec<FlockTick>> {
    let flocks = cfg.start_group_count();
    let dt = cfg.scenario.dt;
    let d_des = params.desired_distance;
    let mut out = vec![Vec::new(); flocks];
    for (f, series) in out.iter_mut().enumerate() {
        let m = migration(params, f);
        let mut prev: Option<(f64, f64)> = None;
        let mut start: Option<(f64, f64)> = None;
        let mut sum_p = 0.0;
        let mut n_p = 0u64;
        for rows in &run.ticks {
            let members: Vec<_> = rows
                .iter()
                .filter(|r| cfg.start_group(r.id) == f)
                .collect();
            let Some(first) = members.first() else {
                prev = None;
                continue;
            };
            let n = members.len() as f64;
            let com = (
                members.iter().map(|r| r.x).sum::<f64>() / n,
                members.iter().map(|r| r.y).sum::<f64>() / n,
            );
            let (sx, sy) = members
                .iter()
                .fold((0.0, 0.0), |(sx, sy), r| (sx + r.theta.cos(), sy + r.theta.sin()));
            let order = (sx * sx + sy * sy).sqrt() / n;
            let dists: Vec<f64> = members
                .iter()
                .map(|r| ((r.x - com.0).powi(2) + (r.y - com.1).powi(2)).sqrt())
                .collect();
            let cohesion = 1.0 / (1.0 + dists.iter().sum::<f64>() / n);
            let separation = if d_des > 0.0 {
                1.0 - dists.iter().map(|&d| (d_des - d).max(0.0)).sum::<f64>() / (n * d_des)
            } else {
                1.0
            };
            let tick = first.tick;
            let origin = *start.get_or_insert(com);
            if let Some(p) = prev {
                let along = ((com.0 - p.0) * m.0 + (com.1 - p.1) * m.1) / dt;
                let velocity = (along / params.performance_speed).max(0.0);
                let performance = order * cohesion * velocity;
                sum_p += performance;
                n_p += 1;
                series.push(FlockTick {
                    tick,
                    robots: members.iter().filter(|r| r.active).count(),
                    order,
                    cohesion,
                    velocity,
                    performance,
                    overall: sum_p / n_p as f64,
                    fitness_term: 0.3 * order + 0.4 * cohesion + 0.3 * separation,
                    com,
                    travelled: (com.0 - origin.0) * m.0 + (com.1 - origin.1) * m.1,
                });
            }
            prev = Some(com);
        }
    }
    out
}

/// Unit vector of flock `f`'s migration urge.
fn migration(params: &FlockingParams, f: usize) -> (f64, f64) {
    let deg = params
        .migration_deg
        .get(f)
        .or(params.migration_deg.first())
        .copied()
        .unwrap_or(0.0);
    let a = deg.to_radians();
    (a.cos(), a.sin())
}

/// Time means of one flock's series, its travelled distance d_p along the migration urge
/// (from tick 0 to its last tick) and F_p = 0.9 mean(f_p) + 0.1 d_p (eq. 19; the paper's flock
/// travels along y, its migration urge; ours along whatever the urge is).
fn summary(series: &[FlockTick]) -> Value {
    let n = series.len().max(1) as f64;
    let mean = |f: fn(&FlockTick) -> f64| series.iter().map(f).sum::<f64>() / n;
    let distance = series.last().map_or(0.0, |t| t.travelled);
    json!({
        "order": mean(|t| t.order),
        "cohesion": mean(|t| t.cohesion),
        "velocity": mean(|t| t.velocity),
        "performance": series.last().map_or(0.0, |t| t.overall),
        "fitness": 0.9 * mean(|t| t.fitness_term) + 0.1 * distance,
        "distance": distance,
        "ticks": series.len(),
    })
}

/// `flocking`: the swarm's time means (the mean over flocks when there are several) and
/// `flocks`, one summary per flock.
pub fn metrics(cfg: &Config, params: &FlockingParams, run: &Records) -> Vec<(&'static str, Value)> {
    let per: Vec<Value> = flock_ticks(cfg, params, run)
        .iter()
        .enumerate()
        .map(|(f, s)| {
            let mut v = summary(s);
            v["flock"] = json!(f);
            v
        })
        .collect();
    let mut all = json!({});
    for key in ["order", "cohesion", "velocity", "performance", "fitness", "distance"] {
        let vals: Vec<f64> = per.iter().filter_map(|v| v[key].as_f64()).collect();
        all[key] = json!(vals.iter().sum::<f64>() / vals.len().max(1) as f64);
    }
    all["flocks"] = Value::Array(per);
    vec![("flocking", all)]
}

/// `flocking.csv`: one row per flock and tick; and `flocking.svg` / `.png`: p'(t) and p̄(t)
/// per flock, like the paper's Fig. 4-8.
pub fn series(cfg: &Config, params: &FlockingParams, run: &Records) -> Series {
    let dt = cfg.scenario.dt;
    let mut rows = Vec::new();
    for (f, s) in flock_ticks(cfg, params, run).iter().enumerate() {
        for t in s {
            rows.push(vec![
                t.tick as f64,
                t.tick as f64 * dt,
                f as f64,
                t.robots as f64,
                t.order,
                t.cohesion,
                t.velocity,
                t.performance,
                t.overall,
            ]);
        }
    }
    Series {
        name: "flocking",
        columns: vec![
            "tick",
            "time_s",
            "flock",
            "robots",
            "order",
            "cohesion",
            "velocity",
            "performance",
            "overall_performance",
        ],
        rows,
        plots: vec![SeriesPlot {
            file: "flocking",
            title: format!("{}: instant and overall performance", cfg.scenario.name),
            x: "time_s",
            lines: vec!["performance", "overall_performance"],
            group_by: Some("flock"),
            y_label: "performance",
        }],
    }
}
