//! `planner` in metrics.json, from the records alone (so both modes give the same numbers),
//! except `plan_ms`: the wall-clock time to plan the scenario's routes, measured by planning
//! them again after the run (a clock has no place in the records).

use std::collections::BTreeMap;
use std::time::Instant;

use serde_json::{Value, json};
use swarmrt_protocol::records::Records;
use swarmrt_scenario::Config;

use swarmrt_planner::{Reservations, plan_all};

use super::{PlanNote, PlannerParams, scene};
use crate::consensus::behaviour_notes;

/// The scalar metrics [`metrics`] computes, as sweeps and tunes name them.
pub const NAMES: &[&str] = &[
    "planner.plans",
    "planner.replans",
    "planner.route_cost",
    "planner.expansions",
    "planner.no_route",
    "planner.hovers",
    "planner.detours",
    "planner.conflicts",
    "planner.min_separation",
    "planner.reached",
    "planner.collisions",
];

/// A planned route as its `planned` note tells it.
struct Planned {
    plan: u32,
    vehicle: u32,
    start_slot: u32,
    moves: u32,
    /// The cost as the record holds it: the `f32` written as its shortest decimal and read
    /// back as `f64` (widening the `f32` would give other digits).
    cost: f64,
    expansions: u32,
}

/// `x` as `events.jsonl` holds it, read back as `f64`: `serde_json` writes the shortest
/// decimal that reads back as `x`, and a reader parses that as `f64`. A non-finite `x` (written
/// as `null`, so never in a note that decoded) stays as it is.
fn recorded_f64(x: f32) -> f64 {
    serde_json::to_string(&x)
        .ok()
        .and_then(|s| serde_json::from_str::<f64>(&s).ok())
        .unwrap_or(f64::from(x))
}

/// Conflicts in flown positions: pairs of vehicles (both active) that held the same grid
/// cell within δ of each other (eq. 1 with clearance 0). Must be 0.
pub fn flown_conflicts(cfg: &Config, p: &PlannerParams, run: &Records) -> u64 {
    let Ok(grid) = scene::grid(cfg, p) else {
        return 0;
    };
    let window = (p.delta / cfg.scenario.dt).round() as u64;
    // Per cell: (tick, vehicle) occupancy, in tick order.
    let mut last: BTreeMap<u32, Vec<(u64, u32)>> = BTreeMap::new();
    let mut conflicts = std::collections::BTreeSet::new();
    for rows in &run.ticks {
        for r in rows.iter().filter(|r| r.active) {
            let c = grid.nearest_cell([r.x, r.y, r.z]);
            let key = grid.index(c) as u32;
            let seen = last.entry(key).or_default();
            for &(t, v) in seen.iter() {
                if v != r.id && r.tick <= t + window {
                    conflicts.insert((v.min(r.id), v.max(r.id), key));
                }
            }
            seen.retain(|&(t, v)| v != r.id && r.tick <= t + window);
            seen.push((r.tick, r.id));
        }
    }
    conflicts.len() as u64
}

/// Smallest distance between two robots' centres over the run (3D), metres.
pub fn min_separation(run: &Records) -> Option<f64> {
    let mut best: Option<f64> = None;
    for rows in &run.ticks {
        for (a, ra) in rows.iter().enumerate() {
            for rb in &rows[a + 1..] {
                let d =
                    ((ra.x - rb.x).powi(2) + (ra.y - rb.y).powi(2) + (ra.z - rb.z).powi(2)).sqrt();
                best = Some(best.map_or(d, |b: f64| b.min(d)));
            }
        }
    }
    best
}

/// Wall-clock milliseconds to plan the scenario's routes (from the starts, as `swarm plan`
/// does), the grid built beforehand: per route (vehicle k's share, the time to plan the
/// first k + 1 vehicles minus the first k: prioritised planning is sequential) and in
/// total; the best of five. Metrics only, never a record.
pub fn plan_ms(cfg: &Config, p: &PlannerParams) -> (Vec<f64>, Option<f64>) {
    let (Ok(g), pp) = (scene::grid(cfg, p), scene::params(p)) else {
        return (Vec::new(), None);
    };
    let jobs = scene::jobs(cfg, &g);
    let Ok(fixed) = Reservations::new(&g, &pp) else {
        return (Vec::new(), None);
    };
    let prefix_ms: Vec<f64> = (0..=jobs.len())
        .map(|k| {
            (0..5)
                .map(|_| {
                    let t0 = Instant::now();
                    let routes = plan_all(&g, &jobs[..k], fixed.clone(), &pp);
                    let ms = t0.elapsed().as_secs_f64() * 1e3;
                    std::hint::black_box(routes);
                    ms
                })
                .fold(f64::INFINITY, f64::min)
        })
        .collect();
    let per_route = prefix_ms
        .windows(2)
        .map(|w| (w[1] - w[0]).max(0.0))
        .collect();
    (per_route, prefix_ms.last().copied())
}

/// The `planner` section.
pub fn metrics(cfg: &Config, p: &PlannerParams, run: &Records) -> Vec<(&'static str, Value)> {
    let mut plans: BTreeMap<u32, Vec<Planned>> = BTreeMap::new();
    let mut no_route = 0u64;
    let mut hovers = 0u64;
    let mut detours = 0u64;
    for (_, _, note) in behaviour_notes::<PlanNote>(run) {
        match note {
            PlanNote::Planned {
                plan,
                vehicle,
                start_slot,
                moves,
                cost,
                expansions,
            } => plans.entry(plan).or_default().push(Planned {
                plan,
                vehicle,
                start_slot,
                moves,
                cost: recorded_f64(cost),
                expansions,
            }),
            PlanNote::NoRoute { .. } => no_route += 1,
            PlanNote::Hover { .. } => hovers += 1,
            PlanNote::Detour { .. } => detours += 1,
            PlanNote::Flying { .. } | PlanNote::Arrived => {}
        }
    }
    let routes: Vec<Value> = plans
        .values()
        .flatten()
        .map(|pl| {
            json!({"plan": pl.plan, "vehicle": pl.vehicle, "start_slot": pl.start_slot,
                   "moves": pl.moves, "cost": pl.cost, "expansions": pl.expansions})
        })
        .collect();
    let first = plans.values().next();
    let sum = |of: fn(&Planned) -> f64| first.map_or(0.0, |v| v.iter().map(of).sum());
    let (per_route, total) = plan_ms(cfg, p);
    let reached = run.reached().count();
    let all = json!({
        "plans": plans.len(),
        "replans": plans.len().saturating_sub(1),
        "routes": routes,
        "route_cost": sum(|pl| pl.cost),
        "expansions": sum(|pl| f64::from(pl.expansions)),
        "no_route": no_route,
        "hovers": hovers,
        "detours": detours,
        "conflicts": flown_conflicts(cfg, p, run),
        "min_separation": min_separation(run),
        "reached": reached,
        "collisions": run.collisions().count(),
        "plan_ms": {"total": total, "per_route": per_route},
    });
    vec![("planner", all)]
}
