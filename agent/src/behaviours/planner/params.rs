//! `[behaviour]` of `kind = "planner"` (seed 002): the grid, the potential and the search of
//! the paper, and how vehicles fly and hand over the routes.

use serde::{Deserialize, Serialize};
use swarmrt_scenario::validate::{check, range_f, range_u64};
use swarmrt_scenario::{Config, KeyError};

use crate::behaviour::Params;

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
        }
    }
}

impl Params for PlannerParams {
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
        range_f("behaviour.cell", self.cell, 0.05, 100.0)?;
        range_f("behaviour.a", self.a, 0.0, 1e6)?;
        range_f("behaviour.b", self.b, 0.0, 1e6)?;
        range_f("behaviour.delta", self.delta, 0.0, 600.0)?;
        range_f("behaviour.epsilon", self.epsilon, 0.0, 100.0)?;
        let vz = cfg.robots.aerial.map_or(0.0, |a| a.max_vertical_speed);
        // A move changes each axis by at most one cell per slot: sqrt(2) cells horizontally.
        let fastest = (cfg.robots.max_speed / 2f64.sqrt()).min(vz);
        range_f("behaviour.cruise_speed", self.cruise_speed, 1e-3, fastest).map_err(|(k, _)| {
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
        range_f("behaviour.clearance", self.clearance, 0.0, 100.0)?;
        range_u64("behaviour.n_points", self.n_points as u64, 1, 1000)?;
        range_f("behaviour.lead_time", self.lead_time, 0.0, 3600.0)?;
        range_u64("behaviour.lost_after", self.lost_after as u64, 1, 1_000_000)?;
        range_u64("behaviour.settle", self.settle as u64, 0, 1_000_000)?;
        range_f("behaviour.gain", self.gain, 0.0, 100.0)?;
        range_u64(
            "behaviour.max_expansions",
            self.max_expansions as u64,
            1,
            100_000_000,
        )
    }
}

impl PlannerParams {
    /// Seconds per slot: one move between neighbouring cells.
    pub fn slot(&self) -> f64 {
        self.cell / self.cruise_speed
    }
}
