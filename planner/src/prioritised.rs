//! Prioritised planning for the swarm: the paper's leader builds the shared grid and plans
//! the vehicles one after another, each against the routes fixed before it (Marchenko &
//! Ponomarenko 2024, 2.1, Fig. 3: "occupancy of each cell depending on route and time").
//! Also the independent checks: conflicts by eq. (1) and minimum separation.

use std::collections::{BTreeMap, BTreeSet};

use crate::astar::{Job, Planner};
use crate::error::PlanError;
use crate::grid::Grid;
use crate::occupancy::Reservations;
use crate::params::PlanParams;
use crate::route::Route;
use crate::spline::Trajectory;

/// Plans `jobs` in the given order (the order is the priority).
///
/// Before planning, every job's vehicle holds its start cell over
/// `[start_slot, start_slot + hold_slots]`, so vehicles planned earlier do not route through
/// vehicles still waiting for their turn. Planning a vehicle drops its hold; a planned route is
/// then fixed in the reservations (parked at its goal for ever). A vehicle that finds no route
/// stays where it is: its start cell is reserved for ever, like a dead vehicle, so later
/// routes avoid it. `fixed` must have been built for this `grid` with these `params` (its δ
/// and clearance are fixed at construction).
pub fn plan_all(
    grid: &Grid,
    jobs: &[Job],
    fixed: Reservations,
    params: &PlanParams,
) -> Vec<Result<Route, PlanError>> {
    let mut res = fixed;
    if let Err(e) = params.validate() {
        return jobs.iter().map(|_| Err(e.clone())).collect();
    }
    for job in jobs {
        if grid.contains(job.start) {
            res.add_hold(
                job.vehicle,
                job.start,
                job.start_slot,
                job.start_slot.saturating_add(params.hold_slots),
            );
        }
    }
    let mut planner = Planner::new();
    let mut out = Vec::with_capacity(jobs.len());
    for job in jobs {
        res.remove_vehicle(job.vehicle);
        let r = planner.plan(grid, &res, job, params);
        match &r {
            Ok(route) => res.add_route(job.vehicle, route),
            Err(_) if grid.contains(job.start) => res.add_dead(job.vehicle, job.start),
            Err(_) => {}
        }
        out.push(r);
    }
    out
}

/// Number of vehicle pairs that break eq. (1) with clearance 0: one holds a cell at a slot
/// within δ (in slots, [`PlanParams::pad_slots`]) of a slot at which the other holds the
/// same cell; a route's last cell counts as held for ever. Symmetric, so "overlap" of one
/// vehicle's held interval with the other's δ-padded interval. Planned routes give 0.
pub fn conflicts(grid: &Grid, routes: &[(u32, Route)], params: &PlanParams) -> u32 {
    let pad = i64::from(params.pad_slots());
    // Per cell: (vehicle, first slot, last slot) runs.
    let mut runs: BTreeMap<usize, Vec<(u32, i64, i64)>> = BTreeMap::new();
    for (v, r) in routes {
        for (c, s0, s1, parked) in r.runs() {
            let s1 = if parked { i64::MAX / 4 } else { s1 };
            if grid.contains(c) {
                runs.entry(grid.index(c)).or_default().push((*v, s0, s1));
            }
        }
    }
    let mut pairs = BTreeSet::new();
    for list in runs.values() {
        for (x, a) in list.iter().enumerate() {
            for b in &list[x + 1..] {
                if a.0 != b.0 && a.1 - pad <= b.2 && b.1 <= a.2 + pad {
                    pairs.insert((a.0.min(b.0), a.0.max(b.0)));
                }
            }
        }
    }
    pairs.len() as u32
}

/// Smallest distance between any two vehicles, sampling `samples_per_slot` times per slot
/// from the earliest start to one slot after the latest end, along either the
/// piecewise-linear routes (`smooth = false`) or their smoothed [`Trajectory`]s.
/// Infinite with fewer than two routes.
pub fn min_separation(
    grid: &Grid,
    routes: &[(u32, Route)],
    params: &PlanParams,
    samples_per_slot: u32,
    smooth: bool,
) -> f64 {
    if routes.len() < 2 {
        return f64::INFINITY;
    }
    let first = routes.iter().map(|(_, r)| r.start_slot).min().unwrap_or(0);
    let last = routes.iter().map(|(_, r)| r.end_slot()).max().unwrap_or(0) + 1;
    let trajs: Vec<Trajectory> = if smooth {
        routes
            .iter()
            .map(|(_, r)| Trajectory::new(grid, r, params.slot, None, 5))
            .collect()
    } else {
        Vec::new()
    };
    let n = u64::from(last - first) * u64::from(samples_per_slot.max(1));
    let mut best = f64::INFINITY;
    let mut pos = vec![[0.0; 3]; routes.len()];
    for q in 0..=n {
        let t = (f64::from(first) + q as f64 / f64::from(samples_per_slot.max(1))) * params.slot;
        for (x, (_, r)) in routes.iter().enumerate() {
            pos[x] = if smooth {
                trajs[x].position(t)
            } else {
                r.position_at(grid, params.slot, t)
            };
        }
        for a in 0..pos.len() {
            for b in a + 1..pos.len() {
                let d = ((pos[a][0] - pos[b][0]).powi(2)
                    + (pos[a][1] - pos[b][1]).powi(2)
                    + (pos[a][2] - pos[b][2]).powi(2))
                .sqrt();
                best = best.min(d);
            }
        }
    }
    best
}
