//! `[behaviour]` of `kind = "formation"` (seed 000).

use serde::{Deserialize, Serialize};
use swarmrt_scenario::validate::{range_f, range_u64};
use swarmrt_scenario::{Config, KeyError};

use crate::behaviour::Params;

/// Parameters of the virtual-leader formation (seed 000). The desired formation is the start
/// layout (`robots.start`), centred on the virtual leader.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct FormationParams {
    /// Constant linear speed v in m/s (section 4.1: only the heading changes).
    pub speed: f64,
    /// Turn angle w per step, degrees (the paper's "angle w": 1, 5, 10, 20).
    pub turn_deg: f64,
    /// An observer reports an obstacle when a ray of its cone hits closer than this (metres).
    pub detect_range: f64,
    /// Half-width of each observer's lidar cone, degrees.
    pub cone_deg: f64,
    /// How far the side observers' cones point outward, degrees ("slightly to either side").
    pub side_offset_deg: f64,
    /// Epsilon-greedy probability of the opposite turn when an obstacle is seen (0.1 %).
    pub epsilon_obstacle: f64,
    /// Epsilon-greedy probability of the opposite turn when nothing is seen (1 %).
    pub epsilon_clear: f64,
    /// How far ahead of its slot, along the swarm heading, a robot steers (metres).
    pub lookahead: f64,
    /// A neighbour whose last message is older than this many ticks is left out (down or gone).
    pub stale_ticks: u32,
    /// An observer's lidar verdict counts for this many ticks after it was sent.
    pub verdict_ticks: u32,
}

impl Default for FormationParams {
    fn default() -> Self {
        FormationParams {
            speed: 0.5,
            turn_deg: 5.0,
            detect_range: 2.0,
            cone_deg: 25.0,
            side_offset_deg: 20.0,
            epsilon_obstacle: 0.001,
            epsilon_clear: 0.01,
            lookahead: 1.0,
            stale_ticks: 20,
            verdict_ticks: 3,
        }
    }
}

impl Params for FormationParams {
    fn validate(&self, cfg: &Config) -> Result<(), KeyError> {
        range_f("behaviour.speed", self.speed, 0.0, cfg.robots.max_speed)?;
        let max_turn = (cfg.robots.max_turn_rate * cfg.scenario.dt).to_degrees();
        range_f(
            "behaviour.turn_deg",
            self.turn_deg,
            0.0,
            max_turn.min(180.0),
        )?;
        range_f("behaviour.detect_range", self.detect_range, 0.0, 1e6)?;
        range_f("behaviour.cone_deg", self.cone_deg, 0.0, 180.0)?;
        range_f(
            "behaviour.side_offset_deg",
            self.side_offset_deg,
            -90.0,
            90.0,
        )?;
        range_f(
            "behaviour.epsilon_obstacle",
            self.epsilon_obstacle,
            0.0,
            1.0,
        )?;
        range_f("behaviour.epsilon_clear", self.epsilon_clear, 0.0, 1.0)?;
        range_f("behaviour.lookahead", self.lookahead, 0.0, 1e6)?;
        range_u64(
            "behaviour.stale_ticks",
            self.stale_ticks as u64,
            1,
            1_000_000,
        )?;
        range_u64(
            "behaviour.verdict_ticks",
            self.verdict_ticks as u64,
            1,
            1_000_000,
        )
    }
}
