//! `[behaviour]` of `kind = "grouping"`: the timings, forces and sizes of seed 001.

use serde::{Deserialize, Serialize};
use swarmrt_scenario::reference::{Bounds, Key, Lim, check_f, check_u, hi, k, lo, r};
use swarmrt_scenario::validate::{check, range_f};
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

/// How a leader steers its formation toward a known goal.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum LeaderNav {
    /// Straight for the goal, with sideways detours after a stall (a bug algorithm at the
    /// group's scale, `unstick` in mod.rs): enough for single walls and doors.
    Detour,
    /// The cheapest way through a map of the walls its own range finder has seen, unseen
    /// space taken as free (`map.rs`): mazes with dead ends and distant doors (S4).
    Map,
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
    /// How the leader steers toward a known goal.
    pub leader_nav: LeaderNav,
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
            leader_nav: LeaderNav::Detour,
        }
    }
}

impl Params for GroupingParams {
    #[rustfmt::skip]
    const KEYS: &'static [Key] = &[
        k("behaviour.grouping_time", r(0.0, 1e5), "s", "Grouping time limit."),
        k("behaviour.cluster_distance", Bounds::Range(Lim::Of("2 * robots.radius"), Lim::V(1e3)), "m", "A robot whose closest neighbour is nearer has finished clustering."),
        k("behaviour.gravity", r(0.0, 1e6), "", "G of eq. 3 (robots have unit mass)."),
        k("behaviour.force_cap", r(1e-6, 1e6), "", "Largest force one neighbour may exert (eq. 3, capped)."),
        k("behaviour.sense", Bounds::Any, "", "What the grouping force senses robots with: the range finder and its shape classifier, or range-and-bearing.").also("`\"lidar\"` needs 8+ lidar rays"),
        k("behaviour.decide_time", r(0.0, 1e5), "s", "Time after grouping during which robots stand still and choose leaders."),
        k("behaviour.claim_period", r(1.0, 10_000.0), "ticks", "Ticks between a robot's leader claims."),
        k("behaviour.radius", Bounds::Range(Lim::Of("robots.radius"), Lim::V(1e3)), "m", "Formation radius f_r (eq. 8-9)."),
        k("behaviour.recheck", Bounds::Range(Lim::Of("scenario.dt"), Lim::V(1e5)), "s", "Time between the leader's checks of the pattern (and re-sends of the formation)."),
        k("behaviour.group_speed", Bounds::Range(Lim::V(0.0), Lim::Of("robots.max_speed")), "m/s", "Speed of the formation's centre."),
        k("behaviour.k_att", r(0.0, 1e3), "1/s", "k_att of the attractive potential (eq. 10-11)."),
        k("behaviour.k_rep", r(0.0, 1e3), "m^3/s", "k_rep of the repulsive potential (eq. 10-11)."),
        k("behaviour.rep_range", r(0.0, 1e3), "m", "rho_0: lidar hits farther than this exert no repulsion."),
        k("behaviour.k_turn", r(0.0, 1e3), "1/s", "Turn gain: turn rate = k_turn * heading error."),
        k("behaviour.turn_accel", r(1e-3, 1e6), "rad/s^2", "Largest change of the turn rate (the wheels' inertia)."),
        k("behaviour.search_radius", r(0.0, 1e6), "m", "Maximum search radius r of eq. 13."),
        k("behaviour.share_goal", Bounds::Any, "", "A leader that finds the goal tells the other leaders (false when each group has its own goal)."),
        k("behaviour.arrive", r(0.0, 1e3), "m", "The formation's centre stops this close to the goal."),
        k("behaviour.leader_nav", Bounds::Any, "", "How the leader steers toward a known goal: straight with detours after a stall, or the cheapest way through its own lidar map (mazes)."),
    ];

    fn validate(&self, cfg: &Config) -> Result<(), KeyError> {
        let keys = Self::KEYS;
        let (low, high) = (|key| lo(keys, key), |key| hi(keys, key));
        check_f(keys, "behaviour.grouping_time", self.grouping_time)?;
        range_f(
            "behaviour.cluster_distance",
            self.cluster_distance,
            2.0 * cfg.robots.radius,
            high("behaviour.cluster_distance"),
        )?;
        check_f(keys, "behaviour.gravity", self.gravity)?;
        check_f(keys, "behaviour.force_cap", self.force_cap)?;
        check_f(keys, "behaviour.decide_time", self.decide_time)?;
        check_u(keys, "behaviour.claim_period", self.claim_period as u64)?;
        range_f(
            "behaviour.radius",
            self.radius,
            cfg.robots.radius,
            high("behaviour.radius"),
        )?;
        range_f(
            "behaviour.recheck",
            self.recheck,
            cfg.scenario.dt,
            high("behaviour.recheck"),
        )?;
        let slowest = low("behaviour.group_speed");
        range_f(
            "behaviour.group_speed",
            self.group_speed,
            slowest,
            cfg.robots.max_speed,
        )?;
        check_f(keys, "behaviour.k_att", self.k_att)?;
        check_f(keys, "behaviour.k_rep", self.k_rep)?;
        check_f(keys, "behaviour.rep_range", self.rep_range)?;
        check_f(keys, "behaviour.k_turn", self.k_turn)?;
        check_f(keys, "behaviour.turn_accel", self.turn_accel)?;
        check_f(keys, "behaviour.search_radius", self.search_radius)?;
        check_f(keys, "behaviour.arrive", self.arrive)?;
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
