//! `[behaviour]` of `kind = "planner"` (seed 002): the grid, the potential and the search of
//! the paper, and how vehicles fly and hand over the routes.

use serde::{Deserialize, Serialize};
use swarmrt_scenario::reference::{Bounds, Key, Lim, check_f, check_u, k, lo, r};
use swarmrt_scenario::validate::{check, range_f};
use swarmrt_scenario::{Config, KeyError};

use swarmrt_planner::Cell;

use crate::behaviour::Params;

/// What a UAV does when its plan breaks and no leader re-plans it: its leader fell silent, no
/// majority is reachable, a vehicle died on its route, or its route came late.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum OnLeaderLoss {
    /// Seed 002 after eq. 3: the route is built on the vehicle, "which allows switching to
    /// autonomous mode if communication with the leader is lost". A UAV keeps flying its
    /// committed route on time (the routes were planned together); one that must deviate
    /// plans its own detour on board against the others' routes and announces it.
    Continue,
    /// Stop and hover until a leader plans everyone again (the earlier policy of this
    /// runtime; with no majority every survivor hovers for good).
    Hover,
}

/// Parameters of the route planner behaviour.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct PlannerParams {
    /// Cell edge d in metres (the paper: 1 m).
    pub cell: f64,
    /// Attraction gain a of the potential, eq. 2 (the paper: 10).
    pub a: f64,
    /// Repulsion gain b of the potential, eq. 2 (the paper: 50).
    pub b: f64,
    /// Safe interval δ in seconds, eq. 1 (the paper: 1 s).
    pub delta: f64,
    /// Bounded relaxation: a route costs at most (1 + epsilon) times the optimum.
    pub epsilon: f64,
    /// Speed of a straight move between neighbouring cells, m/s: one move per slot of
    /// `cell / cruise_speed` seconds (diagonal moves are up to sqrt(3) times faster).
    pub cruise_speed: f64,
    /// Safe-distance zone of eq. 1 (Fig. 1, light grey), metres between cell centres: a cell
    /// is occupied while another vehicle holds a cell this close (0: the same cell only).
    pub clearance: f64,
    /// Samples per segment when the smoothed route is checked against blocked cells (the
    /// paper's cubic spline with N_points = 5).
    pub n_points: u32,
    /// Seconds between planning and the routes' start: time for the routes to commit.
    pub lead_time: f64,
    /// A vehicle not heard for this many ticks is taken for lost: everyone hovers and the
    /// leader re-plans around where it was last heard.
    pub lost_after: u32,
    /// Ticks every vehicle must have been hovering before the leader plans.
    pub settle: u32,
    /// Gain (1/s) that pulls a vehicle back onto its route or its hover point.
    pub gain: f64,
    /// Search states expanded per route before giving up.
    pub max_expansions: u32,
    /// What a UAV does when its plan breaks with no leader to re-plan it.
    pub on_leader_loss: OnLeaderLoss,
}

impl Default for PlannerParams {
    fn default() -> Self {
        PlannerParams {
            cell: 1.0,
            a: 10.0,
            b: 50.0,
            delta: 1.0,
            epsilon: 0.0,
            cruise_speed: 0.5,
            clearance: 1.0,
            n_points: 5,
            lead_time: 2.0,
            lost_after: 10,
            settle: 5,
            gain: 2.0,
            max_expansions: 200_000,
            on_leader_loss: OnLeaderLoss::Continue,
        }
    }
}

impl Params for PlannerParams {
    #[rustfmt::skip]
    const KEYS: &'static [Key] = &[
        k("behaviour.cell", r(0.05, 100.0), "m", "Cell edge d (the paper: 1)."),
        k("behaviour.a", r(0.0, 1e6), "", "Attraction gain a of the potential, eq. 2 (the paper: 10)."),
        k("behaviour.b", r(0.0, 1e6), "", "Repulsion gain b of the potential, eq. 2 (the paper: 50)."),
        k("behaviour.delta", r(0.0, 600.0), "s", "Safe interval delta, eq. 1 (the paper: 1)."),
        k("behaviour.epsilon", r(0.0, 100.0), "", "Bounded relaxation: a route costs at most (1 + epsilon) times the optimum."),
        k("behaviour.cruise_speed", Bounds::Range(Lim::V(1e-3), Lim::Of("min(robots.max_speed / sqrt(2), robots.aerial.max_vertical_speed)")), "m/s", "Speed of a straight move between neighbouring cells: one move per `cell / cruise_speed` slot."),
        k("behaviour.clearance", r(0.0, 100.0), "m", "Safe-distance zone of eq. 1 between cell centres (0: the same cell only)."),
        k("behaviour.n_points", r(1.0, 1000.0), "", "Samples per segment when the smoothed route is checked against blocked cells."),
        k("behaviour.lead_time", r(0.0, 3600.0), "s", "Time between planning and the routes' start, for the routes to commit."),
        k("behaviour.lost_after", r(1.0, 1_000_000.0), "ticks", "A vehicle silent this long is lost: everyone hovers and the leader re-plans."),
        k("behaviour.settle", r(0.0, 1_000_000.0), "ticks", "Ticks every vehicle must have hovered before the leader plans."),
        k("behaviour.gain", r(0.0, 100.0), "1/s", "Gain pulling a vehicle back onto its route or hover point."),
        k("behaviour.max_expansions", r(1.0, 100_000_000.0), "", "Search states expanded per route before giving up."),
        k("behaviour.on_leader_loss", Bounds::Any, "", "continue: fly the committed route on and detour on board when blocked (the paper); hover: wait for a leader's plan."),
    ];

    fn validate(&self, cfg: &Config) -> Result<(), KeyError> {
        check(
            cfg.robots.aerial.is_some(),
            "robots.aerial",
            "a [robots.aerial] section: behaviour.kind = \"planner\" flies UAVs",
        )?;
        check(
            cfg.consensus
                .as_ref()
                .is_some_and(|c| c.algorithm == swarmrt_scenario::consensus::Algorithm::Raft),
            "consensus.algorithm",
            "\"raft\": the Raft leader plans and the log carries the routes",
        )?;
        let keys = Self::KEYS;
        check_f(keys, "behaviour.cell", self.cell)?;
        check_f(keys, "behaviour.a", self.a)?;
        check_f(keys, "behaviour.b", self.b)?;
        check_f(keys, "behaviour.delta", self.delta)?;
        check_f(keys, "behaviour.epsilon", self.epsilon)?;
        let vz = cfg.robots.aerial.map_or(0.0, |a| a.max_vertical_speed);
        // A move changes each axis by at most one cell per slot: sqrt(2) cells horizontally.
        let fastest = (cfg.robots.max_speed / 2f64.sqrt()).min(vz);
        let slowest = lo(keys, "behaviour.cruise_speed");
        range_f(
            "behaviour.cruise_speed",
            self.cruise_speed,
            slowest,
            fastest,
        )
        .map_err(|(k, _)| {
            (
                k,
                format!(
                    "a speed in (0, {}] (robots.max_speed / sqrt(2) and \
                     robots.aerial.max_vertical_speed bound a diagonal move), got {}",
                    swarmrt_scenario::validate::short(fastest),
                    swarmrt_scenario::validate::short(self.cruise_speed)
                ),
            )
        })?;
        check_f(keys, "behaviour.clearance", self.clearance)?;
        check_u(keys, "behaviour.n_points", self.n_points as u64)?;
        check_f(keys, "behaviour.lead_time", self.lead_time)?;
        check_u(keys, "behaviour.lost_after", self.lost_after as u64)?;
        check_u(keys, "behaviour.settle", self.settle as u64)?;
        check_f(keys, "behaviour.gain", self.gain)?;
        check_u(keys, "behaviour.max_expansions", self.max_expansions as u64)?;
        check_goal_cells(cfg, self)
    }
}

/// Every UAV needs a goal cell of its own, free, and outside the others' safe zones: a UAV
/// parked at its goal holds its zone for ever (eq. 1), so a second UAV sent there, or next
/// to it, could never arrive and would hover until `scenario.ticks`. Refused before tick 0
/// instead, naming the UAVs, the goal and what to change.
fn check_goal_cells(cfg: &Config, p: &PlannerParams) -> Result<(), KeyError> {
    let Ok(grid) = super::scene::grid(cfg, p) else {
        return Ok(()); // the grid's own error is reported where the grid is built
    };
    let goals: Vec<(u32, Cell, [f64; 3])> = (0..cfg.robots.count)
        .filter_map(|id| {
            let (_, g) = super::scene::start_and_goal(cfg, id)?;
            Some((id, grid.nearest_cell(g), g))
        })
        .collect();
    let at = |g: [f64; 3]| {
        format!(
            "({}, {}, {})",
            swarmrt_scenario::validate::short(g[0]),
            swarmrt_scenario::validate::short(g[1]),
            swarmrt_scenario::validate::short(g[2])
        )
    };
    for (id, cell, g) in &goals {
        if grid.blocked(*cell) {
            return Err((
                "robots.start.groups".to_string(),
                format!(
                    "expected a goal in free space for every UAV, but robot {id}'s goal {} is in an \
                     obstacle (or within robots.radius of one): move its group's goal",
                    at(*g)
                ),
            ));
        }
    }
    let cell_dist = |a: Cell, b: Cell| {
        let d = |x: u16, y: u16| (f64::from(x) - f64::from(y)).powi(2);
        (d(a.i, b.i) + d(a.j, b.j) + d(a.k, b.k)).sqrt() * p.cell
    };
    for (n, (a, ca, ga)) in goals.iter().enumerate() {
        let close: Vec<String> = goals[n + 1..]
            .iter()
            .filter(|(_, cb, _)| cell_dist(*ca, *cb) <= p.clearance + 1e-9)
            .map(|(b, _, _)| b.to_string())
            .collect();
        if !close.is_empty() {
            return Err((
                "robots.start.groups".to_string(),
                format!(
                    "expected every UAV's goal more than behaviour.clearance = {} m from the others', \
                     but robots {a}, {} share the goal {}: give each UAV its own start group \
                     and goal, or raise robots.start.spacing (a group's goals lie 2 x spacing \
                     apart)",
                    swarmrt_scenario::validate::short(p.clearance),
                    close.join(", "),
                    at(*ga)
                ),
            ));
        }
    }
    Ok(())
}

impl PlannerParams {
    /// The parameters of a resolved config (`swarmrt_harness::config::load_run_config`);
    /// `Err` at `behaviour.kind` when its behaviour is not `planner`.
    pub fn of(cfg: &Config) -> Result<PlannerParams, KeyError> {
        crate::registry::params::<super::Planner>(cfg)
    }

    /// Seconds per slot: one move between neighbouring cells.
    pub fn slot(&self) -> f64 {
        self.cell / self.cruise_speed
    }
}
