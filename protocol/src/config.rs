//! The scenario config (DESIGN section 8): TOML, SI units, unknown keys refused.
//!
//! Loading is three steps so every error can name the file, the key and what was expected:
//! parse the TOML into a table, apply `--set key=value` overrides to that table, then
//! deserialize (with the failing key path) and [`Config::validate`] the bounds.

use serde::{Deserialize, Serialize};
use std::fmt;
use std::path::Path;

use crate::messages::{MAX_LIDAR_RAYS, MAX_OUTBOX};

/// A user error in a config: which file, which key, what was expected.
#[derive(Debug, Clone, PartialEq)]
pub struct ConfigError {
    /// The file (or `<--set>` for an override).
    pub file: String,
    /// Dotted key path, empty when the whole file is at fault.
    pub key: String,
    /// What was expected and what was found.
    pub message: String,
}

impl fmt::Display for ConfigError {
    /// One line: control characters (a newline in a quoted key, a NUL or an escape sequence
    /// echoed from the file) are shown escaped, never printed.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let (file, message) = (escape_controls(&self.file), escape_controls(&self.message));
        if self.key.is_empty() {
            write!(f, "{file}: {message}")
        } else {
            write!(f, "{file}: key `{}`: {message}", escape_controls(&self.key))
        }
    }
}

/// `s` with every control character escaped as Rust does (`\n`, `\u{1b}`).
pub fn escape_controls(s: &str) -> String {
    s.chars()
        .map(|c| {
            if c.is_control() {
                c.escape_default().to_string()
            } else {
                c.to_string()
            }
        })
        .collect()
}

impl std::error::Error for ConfigError {}

/// A whole scenario.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Config {
    /// Name, length, time step and seed.
    pub scenario: Scenario,
    /// Bounds, goal and obstacles.
    pub map: MapConfig,
    /// Robot body, limits, start layout and sensors.
    pub robots: RobotsConfig,
    /// The radio medium.
    #[serde(default)]
    pub radio: RadioConfig,
    /// Which behaviour every robot runs.
    #[serde(default)]
    pub behaviour: BehaviourConfig,
    /// Scheduled faults.
    #[serde(default)]
    pub faults: crate::faults::FaultsConfig,
    /// Consensus among the robots (none when absent).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub consensus: Option<crate::consensus::ConsensusConfig>,
}

/// `[scenario]`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Scenario {
    /// Scenario name, used in the run directory name.
    pub name: String,
    /// The run seed: every random draw derives from it.
    #[serde(default)]
    pub seed: u64,
    /// Number of ticks to run at most.
    pub ticks: u64,
    /// Seconds per tick.
    #[serde(default = "default_dt")]
    pub dt: f64,
    /// End the run early once every robot has reached the goal or is down or dead.
    #[serde(default = "yes")]
    pub stop_when_done: bool,
    /// A robot that has not answered within this many milliseconds is logged as late.
    #[serde(default = "default_deadline_ms")]
    pub deadline_ms: u64,
    /// A robot that has answered nothing for this many milliseconds (a hung or externally
    /// stopped process) is marked dead and killed, so one stuck robot cannot hang the run.
    #[serde(default = "default_unresponsive_ms")]
    pub unresponsive_ms: u64,
}

/// `[map]`: the arena. Its bounds are walls.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MapConfig {
    /// `[min_x, min_y, max_x, max_y]` in metres.
    pub bounds: [f64; 4],
    /// The target area.
    pub goal: Goal,
    /// Circular obstacles.
    #[serde(default)]
    pub circles: Vec<CircleObstacle>,
    /// Axis-aligned rectangular obstacles.
    #[serde(default)]
    pub rectangles: Vec<RectObstacle>,
    /// Convex polygon obstacles (points counter-clockwise or clockwise).
    #[serde(default)]
    pub polygons: Vec<PolygonObstacle>,
}

/// The goal: a disc robots try to reach.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Goal {
    /// Centre x in metres.
    pub x: f64,
    /// Centre y in metres.
    pub y: f64,
    /// A robot whose centre is within this radius has reached the goal.
    pub radius: f64,
}

/// A circle obstacle.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CircleObstacle {
    /// Centre x.
    pub x: f64,
    /// Centre y.
    pub y: f64,
    /// Radius.
    pub r: f64,
}

/// An axis-aligned rectangle obstacle.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RectObstacle {
    /// Left edge.
    pub x_min: f64,
    /// Bottom edge.
    pub y_min: f64,
    /// Right edge.
    pub x_max: f64,
    /// Top edge.
    pub y_max: f64,
}

/// A convex polygon obstacle.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PolygonObstacle {
    /// Vertices `[x, y]`, at least three.
    pub points: Vec<[f64; 2]>,
}

/// `[robots]`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RobotsConfig {
    /// Number of robots (one process each).
    pub count: u32,
    /// Body radius in metres.
    #[serde(default = "default_radius")]
    pub radius: f64,
    /// Forward speed limit in m/s.
    #[serde(default = "default_max_speed")]
    pub max_speed: f64,
    /// Turn-rate limit in rad/s.
    #[serde(default = "default_max_turn_rate")]
    pub max_turn_rate: f64,
    /// Where robots start.
    #[serde(default)]
    pub start: StartLayout,
    /// The lidar.
    #[serde(default)]
    pub lidar: LidarConfig,
    /// The range-and-bearing sensor.
    #[serde(default)]
    pub range_bearing: RangeBearingConfig,
    /// The goal sensor (camera cone).
    #[serde(default)]
    pub goal_sensor: GoalSensorConfig,
    /// Sensor noise.
    #[serde(default)]
    pub noise: NoiseConfig,
}

/// Start layout: derived from the count, so changing `robots.count` alone stays valid.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StartLayout {
    /// Centre of the grid of start positions, x.
    pub x: f64,
    /// Centre of the grid, y.
    pub y: f64,
    /// Distance between neighbouring start positions.
    pub spacing: f64,
    /// Initial heading of every robot, degrees.
    #[serde(default)]
    pub heading_deg: f64,
}

impl Default for StartLayout {
    fn default() -> Self {
        StartLayout {
            x: 2.0,
            y: 2.0,
            spacing: 0.8,
            heading_deg: 0.0,
        }
    }
}

/// The lidar: `rays` beams evenly over `fov_deg`, centred on the heading.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LidarConfig {
    /// Number of rays (1..=64).
    #[serde(default = "default_rays")]
    pub rays: u32,
    /// Field of view in degrees (0..=360).
    #[serde(default = "default_fov")]
    pub fov_deg: f64,
    /// Maximum range in metres.
    #[serde(default = "default_lidar_range")]
    pub range: f64,
}

impl Default for LidarConfig {
    fn default() -> Self {
        LidarConfig {
            rays: default_rays(),
            fov_deg: default_fov(),
            range: default_lidar_range(),
        }
    }
}

impl LidarConfig {
    /// Angle of ray `k` relative to the heading: evenly over the field of view, ray 0 at
    /// `-fov/2`; a full circle does not repeat its first ray at the end.
    pub fn ray_angle(&self, k: usize) -> f64 {
        let rays = self.rays.max(1) as usize;
        if rays == 1 {
            return 0.0;
        }
        let fov = self.fov_deg.to_radians();
        let step = if self.fov_deg >= 360.0 {
            fov / rays as f64
        } else {
            fov / (rays - 1) as f64
        };
        -fov / 2.0 + step * k as f64
    }
}

/// The e-puck style range-and-bearing sensor.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RangeBearingConfig {
    /// Neighbours within this distance are reported.
    #[serde(default = "default_rb_range")]
    pub range: f64,
}

impl Default for RangeBearingConfig {
    fn default() -> Self {
        RangeBearingConfig {
            range: default_rb_range(),
        }
    }
}

/// The goal sensor: sees the goal inside a cone and a range.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GoalSensorConfig {
    /// Maximum distance in metres.
    #[serde(default = "default_goal_range")]
    pub range: f64,
    /// Cone width in degrees, centred on the heading.
    #[serde(default = "default_goal_fov")]
    pub fov_deg: f64,
}

impl Default for GoalSensorConfig {
    fn default() -> Self {
        GoalSensorConfig {
            range: default_goal_range(),
            fov_deg: default_goal_fov(),
        }
    }
}

/// Gaussian sensor noise (standard deviations); zero means exact.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct NoiseConfig {
    /// Position noise in metres.
    #[serde(default)]
    pub pose: f64,
    /// Heading noise in radians.
    #[serde(default)]
    pub heading: f64,
    /// Lidar range noise in metres.
    #[serde(default)]
    pub lidar: f64,
}

/// How frames are lost.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum LossModel {
    /// Each copy is lost independently with probability `radio.loss`.
    #[default]
    Bernoulli,
    /// Two-state bursty loss per link, as netem's `loss gemodel p r 1-h 1-k`.
    GilbertElliott,
}

/// `[radio]` (DESIGN section 4).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RadioConfig {
    /// Frames reach robots within this distance (metres).
    #[serde(default = "default_radio_range")]
    pub range: f64,
    /// Bernoulli drop probability per copy.
    #[serde(default)]
    pub loss: f64,
    /// Which loss model applies.
    #[serde(default)]
    pub loss_model: LossModel,
    /// Gilbert-Elliott: probability Good -> Bad per copy on a link.
    #[serde(default = "default_ge_p")]
    pub ge_p: f64,
    /// Gilbert-Elliott: probability Bad -> Good per copy on a link (mean burst = 1/r).
    #[serde(default = "default_ge_r")]
    pub ge_r: f64,
    /// Gilbert-Elliott: loss probability in the Good state (netem's 1-k).
    #[serde(default)]
    pub ge_loss_good: f64,
    /// Gilbert-Elliott: loss probability in the Bad state (netem's 1-h).
    #[serde(default = "one")]
    pub ge_loss_bad: f64,
    /// Extra ticks between sending and delivery (0 = delivered with the next observation).
    #[serde(default)]
    pub delay_ticks: u32,
    /// Uniform extra delay in 0..=jitter_ticks per copy (this is what reorders frames).
    #[serde(default)]
    pub jitter_ticks: u32,
    /// Most frames one robot may send per tick; more are dropped as `capacity`.
    #[serde(default = "default_capacity")]
    pub capacity: u32,
    /// When true, obstacles between sender and receiver block a frame.
    #[serde(default)]
    pub line_of_sight: bool,
}

impl Default for RadioConfig {
    fn default() -> Self {
        RadioConfig {
            range: default_radio_range(),
            loss: 0.0,
            loss_model: LossModel::Bernoulli,
            ge_p: default_ge_p(),
            ge_r: default_ge_r(),
            ge_loss_good: 0.0,
            ge_loss_bad: 1.0,
            delay_ticks: 0,
            jitter_ticks: 0,
            capacity: default_capacity(),
            line_of_sight: false,
        }
    }
}

/// `[behaviour]`: which behaviour every robot runs, tagged by `kind`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "kebab-case", deny_unknown_fields)]
pub enum BehaviourConfig {
    /// Go to the goal with reactive lidar avoidance and periodic pose beacons.
    Goto(GotoConfig),
    /// Virtual-leader formation with three observer lidars and epsilon-greedy (seed 000).
    Formation(FormationConfig),
}

/// Parameters of the virtual-leader formation (seed 000). The desired formation is the start
/// layout (`robots.start`), centred on the virtual leader.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FormationConfig {
    /// Constant linear speed v in m/s (section 4.1: only the heading changes).
    #[serde(default = "default_formation_speed")]
    pub speed: f64,
    /// Turn angle w per step, degrees (the paper's "angle w": 1, 5, 10, 20).
    #[serde(default = "default_turn_deg")]
    pub turn_deg: f64,
    /// An observer reports an obstacle when a ray of its cone hits closer than this (metres).
    #[serde(default = "default_detect_range")]
    pub detect_range: f64,
    /// Half-width of each observer's lidar cone, degrees.
    #[serde(default = "default_cone_deg")]
    pub cone_deg: f64,
    /// How far the side observers' cones point outward, degrees ("slightly to either side").
    #[serde(default = "default_side_offset_deg")]
    pub side_offset_deg: f64,
    /// Epsilon-greedy probability of the opposite turn when an obstacle is seen (0.1 %).
    #[serde(default = "default_epsilon_obstacle")]
    pub epsilon_obstacle: f64,
    /// Epsilon-greedy probability of the opposite turn when nothing is seen (1 %).
    #[serde(default = "default_epsilon_clear")]
    pub epsilon_clear: f64,
    /// How far ahead of its slot, along the swarm heading, a robot steers (metres).
    #[serde(default = "one")]
    pub lookahead: f64,
    /// A neighbour whose last beacon is older than this many ticks is left out (down or gone).
    #[serde(default = "default_stale_ticks")]
    pub stale_ticks: u32,
    /// An observer's lidar verdict counts for this many ticks after it was sent.
    #[serde(default = "default_verdict_ticks")]
    pub verdict_ticks: u32,
}

impl Default for FormationConfig {
    fn default() -> Self {
        FormationConfig {
            speed: default_formation_speed(),
            turn_deg: default_turn_deg(),
            detect_range: default_detect_range(),
            cone_deg: default_cone_deg(),
            side_offset_deg: default_side_offset_deg(),
            epsilon_obstacle: default_epsilon_obstacle(),
            epsilon_clear: default_epsilon_clear(),
            lookahead: one(),
            stale_ticks: default_stale_ticks(),
            verdict_ticks: default_verdict_ticks(),
        }
    }
}

fn default_formation_speed() -> f64 {
    0.5
}
fn default_turn_deg() -> f64 {
    5.0
}
fn default_detect_range() -> f64 {
    2.0
}
fn default_cone_deg() -> f64 {
    25.0
}
fn default_side_offset_deg() -> f64 {
    20.0
}
fn default_epsilon_obstacle() -> f64 {
    0.001
}
fn default_epsilon_clear() -> f64 {
    0.01
}
fn default_stale_ticks() -> u32 {
    20
}
fn default_verdict_ticks() -> u32 {
    3
}

impl Default for BehaviourConfig {
    fn default() -> Self {
        BehaviourConfig::Goto(GotoConfig::default())
    }
}

/// Parameters of the go-to-goal behaviour.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GotoConfig {
    /// Cruise speed in m/s.
    #[serde(default = "default_cruise")]
    pub speed: f64,
    /// Obstacles closer than this (metres, from the robot centre) make the robot turn away.
    #[serde(default = "default_avoid")]
    pub avoid_distance: f64,
    /// Ticks between pose beacons (0 = no beacons).
    #[serde(default = "default_beacon_period")]
    pub beacon_period: u32,
    /// Distance between the goal slots robots spread into around the goal centre.
    #[serde(default = "default_slot_spacing")]
    pub slot_spacing: f64,
}

impl Default for GotoConfig {
    fn default() -> Self {
        GotoConfig {
            speed: default_cruise(),
            avoid_distance: default_avoid(),
            beacon_period: default_beacon_period(),
            slot_spacing: default_slot_spacing(),
        }
    }
}

fn default_dt() -> f64 {
    0.1
}
fn yes() -> bool {
    true
}
fn one() -> f64 {
    1.0
}
fn default_deadline_ms() -> u64 {
    2000
}
fn default_unresponsive_ms() -> u64 {
    30_000
}
fn default_radius() -> f64 {
    0.15
}
fn default_max_speed() -> f64 {
    1.0
}
fn default_max_turn_rate() -> f64 {
    3.0
}
fn default_rays() -> u32 {
    16
}
fn default_fov() -> f64 {
    180.0
}
fn default_lidar_range() -> f64 {
    3.0
}
fn default_rb_range() -> f64 {
    3.0
}
fn default_goal_range() -> f64 {
    1000.0
}
fn default_goal_fov() -> f64 {
    360.0
}
fn default_radio_range() -> f64 {
    10.0
}
fn default_ge_p() -> f64 {
    0.05
}
fn default_ge_r() -> f64 {
    0.25
}
fn default_capacity() -> u32 {
    4
}
fn default_cruise() -> f64 {
    0.5
}
fn default_avoid() -> f64 {
    0.9
}
fn default_beacon_period() -> u32 {
    5
}
fn default_slot_spacing() -> f64 {
    0.6
}

/// Largest coordinate magnitude in metres: keeps grid arithmetic far from overflow.
pub const MAX_COORD: f64 = 1e6;

/// Upper bound on robots in one run (process mode is limited by the machine long before).
pub const MAX_ROBOTS: u32 = 100_000;

impl Config {
    /// Reads `path`, applies `overrides` (`key=value`) and validates.
    pub fn load(path: &Path, overrides: &[String]) -> Result<Config, ConfigError> {
        let file = path.display().to_string();
        let text = std::fs::read_to_string(path).map_err(|e| ConfigError {
            file: file.clone(),
            key: String::new(),
            message: format!("cannot read: {e}"),
        })?;
        Self::from_toml_str(&file, &text, overrides)
    }

    /// Parses `text` (named `file` in errors), applies `overrides` and validates.
    pub fn from_toml_str(
        file: &str,
        text: &str,
        overrides: &[String],
    ) -> Result<Config, ConfigError> {
        let mut table: toml::Table = toml::from_str(text).map_err(|e| ConfigError {
            file: file.to_string(),
            key: String::new(),
            message: format!("not valid TOML: {}", one_line(&e.to_string())),
        })?;
        for ov in overrides {
            apply_override(&mut table, ov).map_err(|(key, message)| ConfigError {
                file: "--set".to_string(),
                key,
                message,
            })?;
        }
        let behaviour = table.get("behaviour").cloned();
        let config: Config =
            serde_path_to_error::deserialize(toml::Value::Table(table)).map_err(|e| {
                let key = e.path().to_string().trim_start_matches('.').to_string();
                // serde buffers a tagged enum, which hides the field's path: find it again.
                let (key, message) = match behaviour.as_ref().filter(|_| key == "behaviour") {
                    Some(b) => behaviour_error(b).unwrap_or((key, e.inner().to_string())),
                    None => (key, e.inner().to_string()),
                };
                ConfigError {
                    file: file.to_string(),
                    key,
                    message: one_line(&message),
                }
            })?;
        config.validate().map_err(|(key, message)| ConfigError {
            file: file.to_string(),
            key,
            message,
        })?;
        Ok(config)
    }

    /// The resolved config as TOML: running it again reproduces the run.
    pub fn to_toml(&self) -> String {
        toml::to_string(self).expect("a Config always serializes")
    }

    /// Checks every value against its bounds; the error names the key and the bounds.
    pub fn validate(&self) -> Result<(), (String, String)> {
        let s = &self.scenario;
        check(!s.name.is_empty(), "scenario.name", "a non-empty name")?;
        check(
            s.name
                .chars()
                .all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-'),
            "scenario.name",
            "letters, digits, '_' or '-' only (it becomes a directory name)",
        )?;
        range_u64("scenario.ticks", s.ticks, 1, 100_000_000)?;
        range_f("scenario.dt", s.dt, 1e-4, 10.0)?;
        range_u64("scenario.deadline_ms", s.deadline_ms, 1, 3_600_000)?;
        range_u64(
            "scenario.unresponsive_ms",
            s.unresponsive_ms,
            s.deadline_ms,
            86_400_000,
        )?;

        let m = &self.map;
        for (i, v) in m.bounds.iter().enumerate() {
            range_f(&format!("map.bounds[{i}]"), *v, -MAX_COORD, MAX_COORD)?;
        }
        check(
            m.bounds[2] > m.bounds[0] && m.bounds[3] > m.bounds[1],
            "map.bounds",
            "[min_x, min_y, max_x, max_y] with max > min",
        )?;
        finite("map.goal.x", m.goal.x)?;
        finite("map.goal.y", m.goal.y)?;
        range_f("map.goal.radius", m.goal.radius, 1e-3, 1e6)?;
        check(
            self.inside_bounds(m.goal.x, m.goal.y, 0.0),
            "map.goal",
            "a goal inside map.bounds",
        )?;
        // Obstacles stay within MAX_COORD like the bounds: a rectangle from -1e308 to 1e308
        // is finite, but its width is not, and the map's BVH panics on it.
        for (i, c) in m.circles.iter().enumerate() {
            range_f(&format!("map.circles[{i}].x"), c.x, -MAX_COORD, MAX_COORD)?;
            range_f(&format!("map.circles[{i}].y"), c.y, -MAX_COORD, MAX_COORD)?;
            range_f(&format!("map.circles[{i}].r"), c.r, 1e-3, 1e6)?;
        }
        for (i, r) in m.rectangles.iter().enumerate() {
            for (k, v) in [
                ("x_min", r.x_min),
                ("y_min", r.y_min),
                ("x_max", r.x_max),
                ("y_max", r.y_max),
            ] {
                range_f(
                    &format!("map.rectangles[{i}].{k}"),
                    v,
                    -MAX_COORD,
                    MAX_COORD,
                )?;
            }
            check(
                r.x_max > r.x_min && r.y_max > r.y_min,
                &format!("map.rectangles[{i}]"),
                "x_max > x_min and y_max > y_min",
            )?;
        }
        for (i, p) in m.polygons.iter().enumerate() {
            check(
                p.points.len() >= 3,
                &format!("map.polygons[{i}].points"),
                "at least 3 points",
            )?;
            for (j, pt) in p.points.iter().enumerate() {
                for (k, v) in pt.iter().enumerate() {
                    let key = format!("map.polygons[{i}].points[{j}][{k}]");
                    range_f(&key, *v, -MAX_COORD, MAX_COORD)?;
                }
            }
        }

        let r = &self.robots;
        range_u64("robots.count", r.count as u64, 1, MAX_ROBOTS as u64)?;
        range_f("robots.radius", r.radius, 1e-3, 100.0)?;
        range_f("robots.max_speed", r.max_speed, 0.0, 1000.0)?;
        range_f("robots.max_turn_rate", r.max_turn_rate, 0.0, 1000.0)?;
        range_f("robots.start.x", r.start.x, -MAX_COORD, MAX_COORD)?;
        range_f("robots.start.y", r.start.y, -MAX_COORD, MAX_COORD)?;
        range_f("robots.start.spacing", r.start.spacing, 2.0 * r.radius + 1e-6, 1e6)
            .map_err(|(k, _)| {
                (
                    k,
                    format!(
                        "a value above 2 * robots.radius = {} so robots do not start overlapping, got {}",
                        2.0 * r.radius,
                        short(r.start.spacing)
                    ),
                )
            })?;
        finite("robots.start.heading_deg", r.start.heading_deg)?;
        range_u64(
            "robots.lidar.rays",
            r.lidar.rays as u64,
            1,
            MAX_LIDAR_RAYS as u64,
        )?;
        range_f("robots.lidar.fov_deg", r.lidar.fov_deg, 0.0, 360.0)?;
        range_f("robots.lidar.range", r.lidar.range, 1e-3, 1e6)?;
        range_f(
            "robots.range_bearing.range",
            r.range_bearing.range,
            0.0,
            1e6,
        )?;
        range_f("robots.goal_sensor.range", r.goal_sensor.range, 0.0, 1e9)?;
        range_f(
            "robots.goal_sensor.fov_deg",
            r.goal_sensor.fov_deg,
            0.0,
            360.0,
        )?;
        range_f("robots.noise.pose", r.noise.pose, 0.0, 100.0)?;
        range_f("robots.noise.heading", r.noise.heading, 0.0, 10.0)?;
        range_f("robots.noise.lidar", r.noise.lidar, 0.0, 100.0)?;

        let q = &self.radio;
        range_f("radio.range", q.range, 0.0, 1e9)?;
        range_f("radio.loss", q.loss, 0.0, 1.0)?;
        range_f("radio.ge_p", q.ge_p, 0.0, 1.0)?;
        range_f("radio.ge_r", q.ge_r, 0.0, 1.0)?;
        range_f("radio.ge_loss_good", q.ge_loss_good, 0.0, 1.0)?;
        range_f("radio.ge_loss_bad", q.ge_loss_bad, 0.0, 1.0)?;
        range_u64("radio.delay_ticks", q.delay_ticks as u64, 0, 10_000)?;
        range_u64("radio.jitter_ticks", q.jitter_ticks as u64, 0, 10_000)?;
        range_u64("radio.capacity", q.capacity as u64, 1, MAX_OUTBOX as u64)?;

        self.faults.validate(self.robots.count)?;

        match &self.behaviour {
            BehaviourConfig::Goto(g) => {
                range_f("behaviour.speed", g.speed, 0.0, 1000.0)?;
                range_f("behaviour.avoid_distance", g.avoid_distance, 0.0, 1e6)?;
                range_u64(
                    "behaviour.beacon_period",
                    g.beacon_period as u64,
                    0,
                    1_000_000,
                )?;
                range_f("behaviour.slot_spacing", g.slot_spacing, 0.0, 1e6)?;
            }
            BehaviourConfig::Formation(f) => {
                range_f("behaviour.speed", f.speed, 0.0, self.robots.max_speed)?;
                let max_turn = (self.robots.max_turn_rate * self.scenario.dt).to_degrees();
                range_f("behaviour.turn_deg", f.turn_deg, 0.0, max_turn.min(180.0))?;
                range_f("behaviour.detect_range", f.detect_range, 0.0, 1e6)?;
                range_f("behaviour.cone_deg", f.cone_deg, 0.0, 180.0)?;
                range_f("behaviour.side_offset_deg", f.side_offset_deg, -90.0, 90.0)?;
                range_f("behaviour.epsilon_obstacle", f.epsilon_obstacle, 0.0, 1.0)?;
                range_f("behaviour.epsilon_clear", f.epsilon_clear, 0.0, 1.0)?;
                range_f("behaviour.lookahead", f.lookahead, 0.0, 1e6)?;
                range_u64("behaviour.stale_ticks", f.stale_ticks as u64, 1, 1_000_000)?;
                range_u64(
                    "behaviour.verdict_ticks",
                    f.verdict_ticks as u64,
                    1,
                    1_000_000,
                )?;
            }
        }
        if let Some(c) = &self.consensus {
            c.validate(self)?;
        }

        Ok(())
    }

    fn inside_bounds(&self, x: f64, y: f64, margin: f64) -> bool {
        let b = &self.map.bounds;
        x - margin > b[0] && x + margin < b[2] && y - margin > b[1] && y + margin < b[3]
    }

    /// Start positions: the `robots.count` points of a square grid of `start.spacing` nearest
    /// to `start.(x, y)` that lie inside the bounds and satisfy `clear` (the world passes its
    /// obstacle clearance), so any count that fits the map gives a valid layout. `None` when
    /// the map has no room for that many.
    pub fn start_positions(&self, clear: impl Fn(f64, f64) -> bool) -> Option<Vec<(f64, f64)>> {
        let r = &self.robots;
        nearest_grid_points(
            r.count as usize,
            (r.start.x, r.start.y),
            r.start.spacing,
            self.map.bounds,
            r.radius,
            clear,
        )
    }

    /// Initial heading of every robot, radians.
    pub fn start_heading(&self) -> f64 {
        self.robots.start.heading_deg.to_radians()
    }
}

/// Most grid candidates [`nearest_grid_points`] will consider (bounds a huge map with a tiny
/// spacing).
const MAX_GRID_CANDIDATES: i64 = 4_000_000;

/// The `n` points of a square grid of `spacing` through `centre` that are nearest to `centre`,
/// at least `margin` inside `bounds` and accepted by `ok`; ordered by grid distance, then row,
/// then column (integer keys, so the order is exact). `None` if fewer than `n` qualify.
pub fn nearest_grid_points(
    n: usize,
    centre: (f64, f64),
    spacing: f64,
    bounds: [f64; 4],
    margin: f64,
    ok: impl Fn(f64, f64) -> bool,
) -> Option<Vec<(f64, f64)>> {
    if n == 0 {
        return Some(Vec::new());
    }
    if !spacing.is_finite() || spacing <= 0.0 {
        return None;
    }
    // Index ranges in f64 first: a tiny spacing on a large map must not overflow i64.
    let lo_i = ((bounds[0] + margin - centre.0) / spacing).ceil();
    let hi_i = ((bounds[2] - margin - centre.0) / spacing).floor();
    let lo_j = ((bounds[1] + margin - centre.1) / spacing).ceil();
    let hi_j = ((bounds[3] - margin - centre.1) / spacing).floor();
    if !(hi_i >= lo_i && hi_j >= lo_j)
        || (hi_i - lo_i + 1.0) * (hi_j - lo_j + 1.0) > MAX_GRID_CANDIDATES as f64
    {
        return None;
    }
    let (lo_i, hi_i, lo_j, hi_j) = (lo_i as i64, hi_i as i64, lo_j as i64, hi_j as i64);
    let mut cells: Vec<(i64, i64, i64)> = Vec::new();
    for j in lo_j..=hi_j {
        for i in lo_i..=hi_i {
            cells.push((i * i + j * j, j, i));
        }
    }
    cells.sort_unstable();
    let mut out = Vec::with_capacity(n);
    for (_, j, i) in cells {
        let (x, y) = (centre.0 + spacing * i as f64, centre.1 + spacing * j as f64);
        if x - margin > bounds[0]
            && x + margin < bounds[2]
            && y - margin > bounds[1]
            && y + margin < bounds[3]
            && ok(x, y)
        {
            out.push((x, y));
            if out.len() == n {
                return Some(out);
            }
        }
    }
    None
}

fn one_line(s: &str) -> String {
    s.split_whitespace().collect::<Vec<_>>().join(" ")
}

/// Re-reads a `[behaviour]` table that failed as the struct its `kind` names, to report the
/// failing field as `behaviour.<field>`.
fn behaviour_error(b: &toml::Value) -> Option<(String, String)> {
    let mut fields = b.as_table()?.clone();
    let kind = fields.remove("kind")?;
    let fields = toml::Value::Table(fields);
    let err = match kind.as_str()? {
        "goto" => serde_path_to_error::deserialize::<_, GotoConfig>(fields).err()?,
        "formation" => serde_path_to_error::deserialize::<_, FormationConfig>(fields).err()?,
        _ => return None,
    };
    let path = err.path().to_string();
    let key = if path.is_empty() || path == "." {
        "behaviour".to_string()
    } else {
        format!("behaviour.{}", path.trim_start_matches('.'))
    };
    Some((key, err.inner().to_string()))
}

pub(crate) fn check(ok: bool, key: &str, expected: &str) -> Result<(), (String, String)> {
    if ok {
        Ok(())
    } else {
        Err((key.to_string(), format!("expected {expected}")))
    }
}

fn finite(key: &str, v: f64) -> Result<(), (String, String)> {
    check(
        v.is_finite(),
        key,
        &format!("a finite number, got {}", short(v)),
    )
}

pub(crate) fn range_f(key: &str, v: f64, lo: f64, hi: f64) -> Result<(), (String, String)> {
    check(
        v.is_finite() && v >= lo && v <= hi,
        key,
        &format!("a number in [{lo}, {hi}], got {}", short(v)),
    )
}

/// `v` for an error message: `-1e308`, not its 309 digits.
fn short(v: f64) -> String {
    if v.is_finite() && v != 0.0 && !(1e-6..1e15).contains(&v.abs()) {
        format!("{v:e}")
    } else {
        v.to_string()
    }
}

pub(crate) fn range_u64(key: &str, v: u64, lo: u64, hi: u64) -> Result<(), (String, String)> {
    check(
        v >= lo && v <= hi,
        key,
        &format!("an integer in [{lo}, {hi}], got {v}"),
    )
}

/// Applies one `key=value` override; the value is read as TOML (`0.2`, `true`, `"x"`, `[1, 2]`)
/// and, failing that, as a bare string.
fn apply_override(table: &mut toml::Table, ov: &str) -> Result<(), (String, String)> {
    let (key, raw) = ov.split_once('=').ok_or_else(|| {
        (
            ov.to_string(),
            "expected key=value, e.g. radio.loss=0.2".to_string(),
        )
    })?;
    let key = key.trim();
    let parts: Vec<&str> = key.split('.').collect();
    if key.is_empty() || parts.iter().any(|p| p.is_empty()) {
        return Err((
            key.to_string(),
            "expected a dotted key like radio.loss".to_string(),
        ));
    }
    let raw = raw.trim();
    let value = match toml::from_str::<toml::Table>(&format!("v = {raw}")) {
        Ok(mut t) => t.remove("v").expect("parsed key v"),
        // A number TOML cannot hold (`--seed 18446744073709551615`, `1e400`, `.5`) is not
        // meant as a string: say so instead of "invalid type: string".
        Err(_) if raw.parse::<f64>().is_ok() && raw.contains(|c: char| c.is_ascii_digit()) => {
            return Err((
                key.to_string(),
                format!(
                    "expected a TOML number (an integer in [{}, {}] or a float such as 0.5 or 1e3), got {raw}",
                    i64::MIN,
                    i64::MAX
                ),
            ));
        }
        Err(_) => toml::Value::String(raw.to_string()),
    };
    let mut cur = table;
    for part in &parts[..parts.len() - 1] {
        let entry = cur
            .entry(part.to_string())
            .or_insert_with(|| toml::Value::Table(toml::Table::new()));
        cur = entry.as_table_mut().ok_or_else(|| {
            (
                key.to_string(),
                format!("`{part}` is not a table, so it has no sub-keys"),
            )
        })?;
    }
    cur.insert(parts[parts.len() - 1].to_string(), value);
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    const MINIMAL: &str = r#"
[scenario]
name = "t"
ticks = 10
[map]
bounds = [0.0, 0.0, 10.0, 10.0]
goal = { x = 8.0, y = 8.0, radius = 1.0 }
[robots]
count = 4
"#;

    fn load(text: &str, ov: &[&str]) -> Result<Config, ConfigError> {
        let ov: Vec<String> = ov.iter().map(|s| s.to_string()).collect();
        Config::from_toml_str("t.toml", text, &ov)
    }

    #[test]
    fn minimal_config_gets_defaults() {
        let c = load(MINIMAL, &[]).unwrap();
        assert_eq!(c.scenario.dt, 0.1);
        assert_eq!(c.radio.capacity, 4);
        assert_eq!(c.start_positions(|_, _| true).unwrap().len(), 4);
        assert!(matches!(c.behaviour, BehaviourConfig::Goto(_)));
    }

    #[test]
    fn overrides_reach_nested_keys_and_round_trip() {
        let c = load(
            MINIMAL,
            &["radio.loss=0.3", "robots.count=9", "scenario.seed=7"],
        )
        .unwrap();
        assert_eq!(c.radio.loss, 0.3);
        assert_eq!(c.robots.count, 9);
        let again = load(&c.to_toml(), &[]).unwrap();
        assert_eq!(again, c);
    }

    #[test]
    fn unknown_key_names_file_and_key() {
        let e = load(MINIMAL, &["radio.los=0.3"]).unwrap_err();
        assert_eq!(e.file, "t.toml");
        assert_eq!(e.key, "radio.los");
        assert!(e.message.contains("unknown field `los`"), "{e}");
    }

    #[test]
    fn wrong_type_names_key() {
        let e = load(MINIMAL, &["robots.count=\"many\""]).unwrap_err();
        assert_eq!(e.key, "robots.count", "{e}");
    }

    #[test]
    fn negative_count_is_refused() {
        let e = load(MINIMAL, &["robots.count=-3"]).unwrap_err();
        assert_eq!(e.key, "robots.count", "{e}");
    }

    #[test]
    fn huge_coordinates_are_refused_not_overflowed() {
        let e = load(MINIMAL, &["map.bounds=[-5e18, 0.0, 5e18, 12.0]"]).unwrap_err();
        assert_eq!(e.key, "map.bounds[0]", "{e}");
        // Even called directly with absurd input, the grid search gives up instead of looping.
        assert_eq!(
            nearest_grid_points(3, (0.0, 0.0), 1e-9, [-1e6, -1e6, 1e6, 1e6], 0.1, |_, _| {
                true
            }),
            None
        );
    }

    #[test]
    fn issue_5_obstacle_wider_than_f64_is_refused_not_built() {
        // Finite corners, infinite width: parry's BVH build panicked on it.
        let e = load(
            MINIMAL,
            &["map.rectangles=[{ x_min = -1e308, y_min = 1.0, x_max = 1e308, y_max = 2.0 }]"],
        )
        .unwrap_err();
        assert_eq!(e.key, "map.rectangles[0].x_min", "{e}");
        assert!(e.message.contains("[-1000000, 1000000]"), "{e}");
        let e = load(MINIMAL, &["map.circles=[{ x = 1e300, y = 1.0, r = 0.5 }]"]).unwrap_err();
        assert_eq!(e.key, "map.circles[0].x", "{e}");
        let e = load(
            MINIMAL,
            &["map.polygons=[{ points = [[0.0, 0.0], [1e308, 0.0], [0.0, 1.0]] }]"],
        )
        .unwrap_err();
        assert_eq!(e.key, "map.polygons[0].points[1][0]", "{e}");
    }

    #[test]
    fn issue_5_control_characters_in_errors_are_escaped_to_keep_one_line() {
        // A newline in an override's key (or a quoted key in the file) reached the output.
        let e = load(MINIMAL, &["radio.lo\nss=1"]).unwrap_err();
        assert_eq!(e.key, "radio.lo\nss");
        assert_eq!(
            e.to_string().lines().next().unwrap(),
            e.to_string(),
            "one line"
        );
        assert!(e.to_string().contains("key `radio.lo\\nss`"), "{e}");
        let quoted = MINIMAL.replace("count = 4", "count = 4\n\"a\\u001b[2Jb\" = 1");
        let e = load(&quoted, &[]).unwrap_err();
        assert!(e.to_string().contains("key `robots.a\\u{1b}[2Jb`"), "{e}");
        // TOML's error echoes the offending line, NUL and all.
        let e = load("\u{0}[scenario]", &[]).unwrap_err();
        assert!(!e.to_string().chars().any(char::is_control), "{e}");
        assert!(e.to_string().contains("\\u{0}"), "{e}");
    }

    #[test]
    fn issue_5_a_number_toml_cannot_hold_is_not_read_as_a_string() {
        // `swarm run --seed 18446744073709551615` (a valid u64) said "invalid type: string".
        for (ov, key) in [
            ("scenario.seed=18446744073709551615", "scenario.seed"),
            ("radio.loss=1e400", "radio.loss"),
            ("radio.loss=.5", "radio.loss"),
        ] {
            let e = load(MINIMAL, &[ov]).unwrap_err();
            assert_eq!((e.file.as_str(), e.key.as_str()), ("--set", key), "{e}");
            assert!(e.message.contains("9223372036854775807"), "{e}");
        }
        // Words still become strings, even those Rust reads as numbers.
        let c = load(MINIMAL, &["radio.loss_model=gilbert-elliott"]).unwrap();
        assert_eq!(c.radio.loss_model, LossModel::GilbertElliott);
        let c = load(MINIMAL, &["scenario.name=Infinity"]).unwrap();
        assert_eq!(c.scenario.name, "Infinity");
    }

    #[test]
    fn issue_5_a_bad_fault_target_says_what_is_expected() {
        // Was "data did not match any variant of untagged enum FaultTarget".
        let e = load(MINIMAL, &["faults.kill=[{ tick = 1, robot = -1 }]"]).unwrap_err();
        assert_eq!(e.key, "faults.kill[0].robot", "{e}");
        assert!(e.message.contains("a robot id"), "{e}");
        assert!(e.message.contains("\"leader\""), "{e}");
    }

    #[test]
    fn issue_5_huge_numbers_are_shown_short() {
        // A 309-digit number made the "one clear line" several hundred characters long.
        let e = load(MINIMAL, &["robots.max_speed=-1e308"]).unwrap_err();
        assert!(e.message.ends_with("got -1e308"), "{e}");
        let e = load(
            MINIMAL,
            &["robots.start={ x = 2.0, y = 2.0, spacing = 1e300 }"],
        )
        .unwrap_err();
        assert!(e.message.ends_with("got 1e300"), "{e}");
        let e = load(MINIMAL, &["radio.loss=1.5"]).unwrap_err();
        assert!(e.message.ends_with("got 1.5"), "{e}");
    }

    #[test]
    fn loss_above_one_is_refused_with_bounds() {
        let e = load(MINIMAL, &["radio.loss=1.5"]).unwrap_err();
        assert_eq!(e.key, "radio.loss");
        assert!(e.message.contains("[0, 1]"), "{e}");
    }

    #[test]
    fn grid_points_nearest_first_inside_bounds_and_clear() {
        let all = |_: f64, _: f64| true;
        let g =
            nearest_grid_points(5, (0.0, 0.0), 1.0, [-10.0, -10.0, 10.0, 10.0], 0.1, all).unwrap();
        assert_eq!(
            g,
            vec![(0.0, -1.0), (-1.0, 0.0), (1.0, 0.0), (0.0, 1.0)]
                .into_iter()
                .fold(vec![(0.0, 0.0)], |mut v, p| {
                    v.push(p);
                    v
                })
        );
        // Near a wall the layout grows away from it instead of leaving the map.
        let g = nearest_grid_points(9, (0.5, 0.5), 1.0, [0.0, 0.0, 10.0, 10.0], 0.2, all).unwrap();
        assert!(g.iter().all(|&(x, y)| x > 0.2 && y > 0.2), "{g:?}");
        // Points refused by `ok` are skipped.
        let g = nearest_grid_points(
            3,
            (0.0, 0.0),
            1.0,
            [-10.0, -10.0, 10.0, 10.0],
            0.1,
            |x, _| x >= 0.0,
        )
        .unwrap();
        assert!(g.iter().all(|&(x, _)| x >= 0.0), "{g:?}");
        // No room: None.
        assert_eq!(
            nearest_grid_points(200, (1.0, 1.0), 1.0, [0.0, 0.0, 5.0, 5.0], 0.1, all),
            None
        );
    }

    #[test]
    fn too_many_robots_for_the_map_is_refused() {
        let c = load(MINIMAL, &["robots.count=400"]).unwrap();
        assert_eq!(c.start_positions(|_, _| true), None);
        let c = load(MINIMAL, &["robots.count=100"]).unwrap();
        assert_eq!(c.start_positions(|_, _| true).unwrap().len(), 100);
    }

    #[test]
    fn a_bad_behaviour_field_is_named_despite_the_tagged_enum() {
        let e = load(
            MINIMAL,
            &["behaviour.kind=\"formation\"", "behaviour.turn_deg=\"x\""],
        )
        .unwrap_err();
        assert_eq!(e.key, "behaviour.turn_deg", "{e}");
        let e = load(
            MINIMAL,
            &["behaviour.kind=\"formation\"", "behaviour.turn_dg=1"],
        )
        .unwrap_err();
        assert_eq!(e.key, "behaviour.turn_dg", "{e}");
        let e = load(
            MINIMAL,
            &["behaviour.kind=\"formation\"", "behaviour.speed=50"],
        )
        .unwrap_err();
        assert_eq!(e.key, "behaviour.speed", "{e}");
    }
}
