//! `[behaviour]` of `kind = "grouping"`: the timings, forces and sizes of seed 001.

use serde::{Deserialize, Serialize};
use swarmrt_scenario::validate::{check, range_f, range_u64};
use swarmrt_scenario::{Config, KeyError};

use crate::behaviour::Params;

/// What the grouping force (section 2.1) senses robots with.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Sense {
    /// The 360° range finder with the shape classifier (`classify.rs`), as the paper does.
    Lidar,
    /// The range-and-bearing sensor (exact, with ids).
    RangeBearing,
}

/// Parameters of the grouping behaviour. The paper prints none of its values; the defaults
/// are ours for a 0.2 m robot at up to 0.5 m/s, chosen so that S1-S4 run as the paper
/// describes (docs/results/seed001.md).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct GroupingParams {
    /// Grouping time limit in seconds (the paper's "time constant ... estimated by considering
    /// maximum range of the range finder and average velocity").
    pub grouping_time: f64,
    /// Clustering threshold in metres: a robot whose closest neighbour is nearer has finished
    /// clustering.
    pub cluster_distance: f64,
    /// G of eq. 3 (robots have unit mass).
    pub gravity: f64,
    /// Largest force one neighbour may exert (eq. 3 capped "to avoid unexpected collisions").
    pub force_cap: f64,
    /// Sensor the grouping force uses.
    pub sense: Sense,
    /// Seconds after grouping during which robots stand still and choose leaders (section 2.2).
    pub decide_time: f64,
    /// Ticks between a robot's leader claims.
    pub claim_period: u32,
    /// Formation radius f_r in metres (eq. 8-9).
    pub radius: f64,
    /// Seconds between the leader's checks of the pattern (and re-sends of the formation).
    pub recheck: f64,
    /// Speed of the formation's centre in m/s (below `robots.max_speed`, so members catch up).
    pub group_speed: f64,
    /// k_att of the attractive potential P_att = k_att |q - slot|^2 / 2 (eq. 10-11), 1/s.
    pub k_att: f64,
    /// k_rep of the repulsive potential (eq. 10-11, Khatib's form), m^3/s.
    pub k_rep: f64,
    /// rho_0: obstacles (lidar hits) farther than this exert no repulsion, metres.
    pub rep_range: f64,
    /// Turn gain: turn rate = k_turn * heading error, 1/s.
    pub k_turn: f64,
    /// Largest change of the turn rate, rad/s^2: the wheels' inertia, which the paper's
    /// Gazebo robots have and a kinematic world lacks (it keeps ΔΩ of eq. 16 physical).
    pub turn_accel: f64,
    /// Maximum search radius r of eq. 13, metres.
    pub search_radius: f64,
    /// A leader that finds the goal tells the other leaders (false when each group seeks a
    /// goal of its own colour, as in S4).
    pub share_goal: bool,
    /// The centre of the formation stops this close to the goal, metres.
    pub arrive: f64,
}

impl Default for GroupingParams {
    fn default() -> Self {
        GroupingParams {
            grouping_time: 8.0,
            cluster_distance: 0.8,
            gravity: 1.0,
            force_cap: 4.0,
            sense: Sense::Lidar,
            decide_time: 3.0,
            claim_period: 3,
            radius: 1.0,
            recheck: 1.0,
            group_speed: 0.35,
            k_att: 1.0,
            k_rep: 0.02,
            rep_range: 0.7,
            k_turn: 3.0,
            turn_accel: 3.0,
            search_radius: 8.0,
            share_goal: true,
            arrive: 0.3,
        }
    }
}

impl Params for GroupingParams {
    fn validate(&self, cfg: &Config) -> Result<(), KeyError> {
        range_f("behaviour.grouping_time", self.grouping_time, 0.0, 1e5)?;
        range_f(
            "behaviour.cluster_distance",
            self.cluster_distance,
            2.0 * cfg.robots.radius,
            1e3,
        )?;
        range_f("behaviour.gravity", self.gravity, 0.0, 1e6)?;
        range_f("behaviour.force_cap", self.force_cap, 1e-6, 1e6)?;
        range_f("behaviour.decide_time", self.decide_time, 0.0, 1e5)?;
        range_u64("behaviour.claim_period", self.claim_period as u64, 1, 10_000)?;
        range_f("behaviour.radius", self.radius, cfg.robots.radius, 1e3)?;
        range_f("behaviour.recheck", self.recheck, cfg.scenario.dt, 1e5)?;
        range_f("behaviour.group_speed", self.group_speed, 0.0, cfg.robots.max_speed)?;
        range_f("behaviour.k_att", self.k_att, 0.0, 1e3)?;
        range_f("behaviour.k_rep", self.k_rep, 0.0, 1e3)?;
        range_f("behaviour.rep_range", self.rep_range, 0.0, 1e3)?;
        range_f("behaviour.k_turn", self.k_turn, 0.0, 1e3)?;
        range_f("behaviour.turn_accel", self.turn_accel, 1e-3, 1e6)?;
        range_f("behaviour.search_radius", self.search_radius, 0.0, 1e6)?;
        range_f("behaviour.arrive", self.arrive, 0.0, 1e3)?;
        check(
            self.sense == Sense::RangeBearing || cfg.robots.lidar.rays >= 8,
            "behaviour.sense",
            &format!(
                "\"range-bearing\", or at least 8 lidar rays for the classifier (robots.lidar.rays is {})",
                cfg.robots.lidar.rays
            ),
        )?;
        Ok(())
    }
}
