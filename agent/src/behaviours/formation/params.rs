//! `[behaviour]` of `kind = "formation"` (seed 000).

use serde::{Deserialize, Serialize};
use swarmrt_scenario::reference::{Bounds, Key, Lim, check_f, check_u, k, lo, r};
use swarmrt_scenario::validate::range_f;
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
    /// When both side observers see an obstacle and the middle one does not, ranges within
    /// this many metres count as equal (straight on); otherwise the swarm turns away from the
    /// nearer side. Ours: section 5.2 is silent on that case. The radio carries decimetres.
    pub gap_tie: f64,
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
            gap_tie: 0.05,
        }
    }
}

impl Params for FormationParams {
    #[rustfmt::skip]
    const KEYS: &'static [Key] = &[
        k("behaviour.speed", Bounds::Range(Lim::V(0.0), Lim::Of("robots.max_speed")), "m/s", "Constant linear speed v (section 4.1: only the heading changes)."),
        k("behaviour.turn_deg", Bounds::Range(Lim::V(0.0), Lim::Of("min(robots.max_turn_rate * scenario.dt, 180 deg)")), "deg", "Turn angle w per step (the paper: 1, 5, 10, 20)."),
        k("behaviour.detect_range", r(0.0, 1e6), "m", "An observer reports an obstacle when a ray of its cone hits closer than this."),
        k("behaviour.cone_deg", r(0.0, 180.0), "deg", "Half-width of each observer's lidar cone."),
        k("behaviour.side_offset_deg", r(-90.0, 90.0), "deg", "How far the side observers' cones point outward."),
        k("behaviour.epsilon_obstacle", r(0.0, 1.0), "", "Epsilon-greedy probability of the opposite turn when an obstacle is seen."),
        k("behaviour.epsilon_clear", r(0.0, 1.0), "", "Epsilon-greedy probability of the opposite turn when nothing is seen."),
        k("behaviour.lookahead", r(0.0, 1e6), "m", "How far ahead of its slot, along the swarm heading, a robot steers."),
        k("behaviour.stale_ticks", r(1.0, 1_000_000.0), "ticks", "A neighbour silent this long is left out of the virtual leader."),
        k("behaviour.verdict_ticks", r(1.0, 1_000_000.0), "ticks", "An observer's lidar verdict counts this long after it was sent."),
        k("behaviour.gap_tie", r(0.0, 1e6), "m", "Both side observers see an obstacle, the middle one not: side ranges within this count as equal (straight on), else turn away from the nearer."),
    ];

    fn validate(&self, cfg: &Config) -> Result<(), KeyError> {
        let keys = Self::KEYS;
        let low = |key| lo(keys, key);
        range_f(
            "behaviour.speed",
            self.speed,
            low("behaviour.speed"),
            cfg.robots.max_speed,
        )?;
        let max_turn = (cfg.robots.max_turn_rate * cfg.scenario.dt).to_degrees();
        range_f(
            "behaviour.turn_deg",
            self.turn_deg,
            low("behaviour.turn_deg"),
            max_turn.min(180.0),
        )?;
        check_f(keys, "behaviour.detect_range", self.detect_range)?;
        check_f(keys, "behaviour.cone_deg", self.cone_deg)?;
        check_f(keys, "behaviour.side_offset_deg", self.side_offset_deg)?;
        check_f(keys, "behaviour.epsilon_obstacle", self.epsilon_obstacle)?;
        check_f(keys, "behaviour.epsilon_clear", self.epsilon_clear)?;
        check_f(keys, "behaviour.lookahead", self.lookahead)?;
        check_u(keys, "behaviour.stale_ticks", self.stale_ticks as u64)?;
        check_u(keys, "behaviour.verdict_ticks", self.verdict_ticks as u64)?;
        check_f(keys, "behaviour.gap_tie", self.gap_tie)
    }
}
