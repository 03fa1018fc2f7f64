//! The scenario as the planner sees it: the shared occupancy grid built from the map (every
//! robot builds the same one from the config) and the search parameters from
//! `[behaviour]`. Also the plan `swarm plan` prints and the metrics re-time: every vehicle
//! from its start to its goal, planned one after another (prioritised, by id).

use swarmrt_planner::{Cell, Grid, Job, PlanError, PlanParams, Reservations, Route, plan_all};
use swarmrt_scenario::Config;

use super::PlannerParams;

/// The occupancy grid over `map.bounds` × `[0, map.height]`: cells within the robot radius
/// of an obstacle (a prism from the ground to its height) are blocked. The walls are the
/// grid's edges: cell centres stay half a cell inside them.
pub fn grid(cfg: &Config, p: &PlannerParams) -> Result<Grid, PlanError> {
    let [x0, y0, x1, y1] = cfg.map.bounds;
    let top = cfg.map.height.unwrap_or(p.cell);
    let mut g = Grid::new([x0, y0, 0.0], [x1, y1, top], p.cell)?;
    let r = cfg.robots.radius;
    let h = |height: Option<f64>| height.unwrap_or(top).min(top);
    for c in &cfg.map.circles {
        g.block_cylinder([c.x, c.y], c.r, 0.0, h(c.height), r);
    }
    for b in &cfg.map.rectangles {
        g.block_box([b.x_min, b.y_min, 0.0], [b.x_max, b.y_max, h(b.height)], r);
    }
    for poly in &cfg.map.polygons {
        g.block_prism(&poly.points, 0.0, h(poly.height), r);
    }
    Ok(g)
}

/// The search parameters of eq. 1-3 from `[behaviour]`.
pub fn params(p: &PlannerParams) -> PlanParams {
    PlanParams {
        a: p.a,
        b: p.b,
        delta: p.delta,
        epsilon: p.epsilon,
        slot: p.slot(),
        wait_cost: p.cell,
        clearance: p.clearance,
        max_expansions: p.max_expansions as u64,
        ..PlanParams::default()
    }
}

/// Robot `id`'s start and goal, `[x, y, z]`.
pub fn start_and_goal(cfg: &Config, id: u32) -> Option<([f64; 3], [f64; 3])> {
    let starts = cfg.start_poses(|_, _| true)?;
    let (x, y, _) = *starts.get(id as usize)?;
    let g = cfg.goal_of(id);
    Some((
        [x, y, cfg.start_z(id)],
        [g.x, g.y, g.z.unwrap_or(cfg.start_z(id))],
    ))
}

/// Every vehicle from its start cell to its goal cell from slot 0, in id order.
pub fn jobs(cfg: &Config, g: &Grid) -> Vec<Job> {
    (0..cfg.robots.count)
        .filter_map(|id| {
            let (s, e) = start_and_goal(cfg, id)?;
            Some(Job {
                vehicle: id,
                start: g.nearest_cell(s),
                goal: g.nearest_cell(e),
                start_slot: 0,
            })
        })
        .collect()
}

/// One vehicle's route in the scenario's plan.
#[derive(Debug, Clone)]
pub struct Planned {
    /// The vehicle.
    pub vehicle: u32,
    /// Its start cell and goal cell.
    pub start: Cell,
    /// Its goal cell.
    pub goal: Cell,
    /// The route, or why there is none.
    pub route: Result<Route, PlanError>,
}

/// Plans every vehicle from its start to its goal from slot 0, in id order: what the first
/// leader plans (up to the lead time), and what `swarm plan` prints.
pub fn plan_scenario(cfg: &Config, p: &PlannerParams) -> Result<Vec<Planned>, PlanError> {
    let g = grid(cfg, p)?;
    let pp = params(p);
    let jobs = jobs(cfg, &g);
    let fixed = Reservations::new(&g, &pp)?;
    let routes = plan_all(&g, &jobs, fixed, &pp);
    Ok(jobs
        .iter()
        .zip(routes)
        .map(|(j, route)| Planned {
            vehicle: j.vehicle,
            start: j.start,
            goal: j.goal,
            route,
        })
        .collect())
}

/// Conflicts of the scenario's plan by eq. 1 (clearance 0): must be 0.
pub fn conflicts(cfg: &Config, p: &PlannerParams, planned: &[Planned]) -> u32 {
    let Ok(g) = grid(cfg, p) else {
        return 0;
    };
    let routes: Vec<(u32, Route)> = planned
        .iter()
        .filter_map(|x| x.route.as_ref().ok().map(|r| (x.vehicle, r.clone())))
        .collect();
    swarmrt_planner::conflicts(&g, &routes, &params(p))
}
