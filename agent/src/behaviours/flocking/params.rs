//! `[behaviour]` of `kind = "flocking"`: the weights of eq. 1-11 and the e-puck's numbers.

use serde::{Deserialize, Serialize};
use swarmrt_scenario::reference::{Bounds, Key, check_f, k, r};
use swarmrt_scenario::validate::check;
use swarmrt_scenario::{Config, KeyError};

use crate::behaviour::Params;

/// Where a robot's heading comes from (paper, section II-A and III-B).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum HeadingSource {
    /// The robot's heading sensor: the true heading plus `robots.noise.heading` (Webots'
    /// compass node).
    Compass,
    /// Integrated from the robot's own wheel commands from its start heading: drifts as the
    /// wheels slip (`robots.noise.wheel_slip`), as on the real e-puck.
    Odometry,
}

/// What a robot broadcasts each tick (section II-E).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Encoding {
    /// Flock id and heading as a 32-bit float (the simulated world).
    Full,
    /// One byte: 3 bits of id, 5 bits of heading (32 values, 11.25 degrees), as on the real
    /// e-pucks' IR link; at most 8 robots, one flock.
    Byte,
}

/// Parameters of the flocking behaviour. Defaults are our hand-crafted weights for the
/// simulated e-puck (the paper does not print its own); `docs/results/seed004.md` says how
/// they were chosen.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct FlockingParams {
    /// alpha: weight of the heading alignment h (eq. 1).
    pub alpha: f64,
    /// beta: base of the proximal weight Gamma = beta^(iota + s) (eq. 2).
    pub beta: f64,
    /// delta: base of the cohesion weight Delta = delta^(zeta + d) (eq. 3).
    pub delta: f64,
    /// iota: bias of the proximal exponent (eq. 2).
    pub iota: f64,
    /// zeta: bias of the cohesion exponent, d in metres (eq. 3).
    pub zeta: f64,
    /// kappa: turn gain (eq. 11).
    pub kappa: f64,
    /// M_b: migratory bias, 0..=1 (eq. 5).
    pub mb: f64,
    /// D: desired distance to the flock's centre of mass in metres (eq. 3; 0.10 in simulation,
    /// 0.075 on the real e-pucks).
    pub desired_distance: f64,
    /// Migration direction of each flock in degrees (flock k = start group k); one value
    /// applies to every flock.
    pub migration_deg: Vec<f64>,
    /// Seconds after which a flock-mate not heard from is forgotten (`time_out`).
    pub time_out: f64,
    /// Heading source.
    pub heading: HeadingSource,
    /// Radio encoding.
    pub encoding: Encoding,
    /// W_r: wheel radius in metres (e-puck: 0.0205 m, Mondada et al. 2009).
    pub wheel_radius: f64,
    /// l: axle length in metres (e-puck: 0.052 m).
    pub axle: f64,
    /// v_max of eq. 16 in m/s: the speed the metric v' is normalised by (6.28 cm/s in the
    /// paper for both the simulated and the calibrated worlds).
    pub performance_speed: f64,
}

impl Default for FlockingParams {
    fn default() -> Self {
        FlockingParams {
            alpha: 1.0,
            beta: 100.0,
            delta: 10.0,
            iota: -0.5,
            zeta: 0.0,
            kappa: 0.5,
            mb: 0.3,
            desired_distance: 0.10,
            migration_deg: vec![0.0],
            time_out: 1.0,
            heading: HeadingSource::Compass,
            encoding: Encoding::Full,
            wheel_radius: 0.0205,
            axle: 0.052,
            performance_speed: 0.0628,
        }
    }
}

/// Most robots one-byte messages can name (3 bits of id).
pub const BYTE_MAX_ROBOTS: u32 = 8;

impl Params for FlockingParams {
    #[rustfmt::skip]
    const KEYS: &'static [Key] = &[
        k("behaviour.alpha", r(0.0, 1e3), "", "alpha: weight of the heading alignment h (eq. 1)."),
        k("behaviour.beta", r(0.0, 1e3), "", "beta: base of the proximal weight Gamma = beta^(iota + s) (eq. 2)."),
        k("behaviour.delta", r(0.0, 1e3), "", "delta: base of the cohesion weight Delta = delta^(zeta + d) (eq. 3)."),
        k("behaviour.iota", r(-10.0, 10.0), "", "iota: bias of the proximal exponent (eq. 2)."),
        k("behaviour.zeta", r(-10.0, 10.0), "", "zeta: bias of the cohesion exponent, d in metres (eq. 3)."),
        k("behaviour.kappa", r(0.0, 1e3), "", "kappa: turn gain (eq. 11)."),
        k("behaviour.mb", r(0.0, 1.0), "", "M_b: migratory bias (eq. 5)."),
        k("behaviour.desired_distance", r(0.0, 1e3), "m", "D: desired distance to the flock's centre of mass (eq. 3)."),
        k("behaviour.migration_deg", r(-360.0, 360.0), "deg", "Migration direction per flock (flock k = start group k); one value for all.").also("one value, or one per start group"),
        k("behaviour.time_out", r(0.0, 1e6), "s", "A flock-mate not heard from this long is forgotten."),
        k("behaviour.heading", Bounds::Any, "", "Heading source: the compass sensor, or odometry (drifts with wheel slip)."),
        k("behaviour.encoding", Bounds::Any, "", "Radio encoding: a float heading, or one byte (3-bit id, 5-bit heading).").also("`\"byte\"`: at most 8 robots, one flock"),
        k("behaviour.wheel_radius", r(1e-4, 10.0), "m", "W_r: wheel radius (e-puck: 0.0205)."),
        k("behaviour.axle", r(1e-4, 10.0), "m", "l: axle length (e-puck: 0.052)."),
        k("behaviour.performance_speed", r(1e-6, 1e3), "m/s", "v_max of eq. 16: the speed the metric v' is normalised by."),
    ];

    fn validate(&self, cfg: &Config) -> Result<(), KeyError> {
        let keys = Self::KEYS;
        check_f(keys, "behaviour.alpha", self.alpha)?;
        check_f(keys, "behaviour.beta", self.beta)?;
        check_f(keys, "behaviour.delta", self.delta)?;
        check_f(keys, "behaviour.iota", self.iota)?;
        check_f(keys, "behaviour.zeta", self.zeta)?;
        check_f(keys, "behaviour.kappa", self.kappa)?;
        check_f(keys, "behaviour.mb", self.mb)?;
        check_f(keys, "behaviour.desired_distance", self.desired_distance)?;
        let flocks = cfg.start_group_count();
        check(
            self.migration_deg.len() == 1 || self.migration_deg.len() == flocks,
            "behaviour.migration_deg",
            &format!(
                "one direction, or one per flock (robots.start.groups has {flocks}), got {}",
                self.migration_deg.len()
            ),
        )?;
        for (k, m) in self.migration_deg.iter().enumerate() {
            check_f(keys, &format!("behaviour.migration_deg[{k}]"), *m)?;
        }
        check_f(keys, "behaviour.time_out", self.time_out)?;
        check_f(keys, "behaviour.wheel_radius", self.wheel_radius)?;
        check_f(keys, "behaviour.axle", self.axle)?;
        check_f(keys, "behaviour.performance_speed", self.performance_speed)?;
        if self.encoding == Encoding::Byte {
            check(
                cfg.robots.count <= BYTE_MAX_ROBOTS,
                "behaviour.encoding",
                &format!(
                    "\"full\" for more than {BYTE_MAX_ROBOTS} robots (one byte holds a 3-bit id; robots.count is {})",
                    cfg.robots.count
                ),
            )?;
            check(
                flocks == 1,
                "behaviour.encoding",
                "\"full\" with several flocks (one byte has no room for a flock id)",
            )?;
        }
        Ok(())
    }
}
