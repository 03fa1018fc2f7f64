//! The scenario config (DESIGN section 8): TOML, SI units, unknown keys refused.
//!
//! Loading is three steps so every error can name the file, the key and what was expected:
//! parse the TOML into a table, apply `--set key=value` overrides to that table, then
//! deserialize (with the failing key path) and [`Config::validate`] the bounds. A section
//! whose every key has a default is `#[serde(default)]` with one `impl Default`; sections with
//! required keys (`scenario.name`, `map.bounds`, `robots.count`, ...) default key by key.

use serde::{Deserialize, Serialize};
use std::path::Path;

use crate::behaviour::BehaviourSection;
use crate::consensus::ConsensusConfig;
use crate::error::{ConfigError, one_line};
use crate::faults::FaultsConfig;
use crate::input::{read_bounded, too_big};
use crate::limits::MAX_CONFIG_BYTES;
use crate::overrides::apply_override;

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
    /// Which behaviour every robot runs; its parameters are the behaviour's own business.
    #[serde(default)]
    pub behaviour: BehaviourSection,
    /// Scheduled faults.
    #[serde(default)]
    pub faults: FaultsConfig,
    /// Consensus among the robots (none when absent).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub consensus: Option<ConsensusConfig>,
    /// The iceoryx2 transport; left out of the resolved config while it has its defaults (it
    /// changes no record).
    #[serde(default, skip_serializing_if = "IpcConfig::is_default")]
    pub ipc: IpcConfig,
}

/// `[ipc]`: how the run's iceoryx2 services are sized beyond the robots.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct IpcConfig {
    /// Spare read-only subscriber and listener slots on every service, so a tool
    /// (`iox2 service hz`, a recorder, a viewer) can attach to a live run.
    pub observers: u32,
}

impl Default for IpcConfig {
    fn default() -> Self {
        IpcConfig { observers: 2 }
    }
}

impl IpcConfig {
    fn is_default(&self) -> bool {
        *self == IpcConfig::default()
    }
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
    /// Write `radio.csv`: one line per radio copy whose fate is decided (delivered, or dropped
    /// with its reason). Off by default; left out of the resolved config while off, so a run
    /// that does not ask for it writes the same `config.toml` as before the key existed. It
    /// changes no other record.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub record_radio: bool,
    /// With `stop_when_done`: end the run once, for this many ticks, no live robot that has
    /// not reached its goal moved more than `robots.radius` (every one hovering or stuck), so
    /// a run that can make no further progress says so instead of waiting out `ticks`. 0: off.
    /// Left out of the resolved config at its default.
    #[serde(
        default = "default_stall_ticks",
        skip_serializing_if = "is_default_stall_ticks"
    )]
    pub stall_ticks: u64,
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
    /// Ceiling in metres: aerial robots fly in `[0, height]` (required with
    /// `[robots.aerial]`; ground robots ignore it).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub height: Option<f64>,
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
    /// Height of the goal's centre for aerial robots (default: the robot's start height);
    /// an aerial robot reaches it within `radius` in 3D.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub z: Option<f64>,
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
    /// Height in metres from the ground (default: a wall of any height). An aerial robot
    /// flies over an obstacle lower than itself; ground robots treat every obstacle as a wall.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub height: Option<f64>,
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
    /// Height in metres from the ground (default: a wall of any height). An aerial robot
    /// flies over an obstacle lower than itself; ground robots treat every obstacle as a wall.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub height: Option<f64>,
}

/// A convex polygon obstacle.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PolygonObstacle {
    /// Vertices `[x, y]`, at least three.
    pub points: Vec<[f64; 2]>,
    /// Height in metres from the ground (default: a wall of any height). An aerial robot
    /// flies over an obstacle lower than itself; ground robots treat every obstacle as a wall.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub height: Option<f64>,
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
    /// Present for aerial robots (UAVs): a height, a holonomic velocity command in the world
    /// frame, 3D contacts; absent for ground robots (unicycles in the plane).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub aerial: Option<AerialConfig>,
    /// The command line every robot runs instead of the built-in `swarm-agent` (its
    /// arguments are appended): a controller in any language (docs/robot-interface.md).
    #[serde(
        default,
        skip_serializing_if = "Vec::is_empty",
        deserialize_with = "crate::programs::command_line"
    )]
    pub program: Vec<String>,
    /// Programs for one robot or a range of them; later entries win
    /// (`program = ["swarm-agent"]` puts the built-in robot back).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub programs: Vec<crate::programs::ProgramFor>,
}

/// `[robots.aerial]`: what makes robots aerial. Their horizontal speed is limited by
/// `robots.max_speed`, their climb and descent by `max_vertical_speed`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct AerialConfig {
    /// Climb and descent speed limit in m/s.
    pub max_vertical_speed: f64,
    /// Start height in metres of robots whose start group gives none.
    pub start_z: f64,
}

impl Default for AerialConfig {
    fn default() -> Self {
        AerialConfig {
            max_vertical_speed: 1.0,
            start_z: 1.0,
        }
    }
}

/// Start layout: derived from the count, so changing `robots.count` alone stays valid.
/// Either one grid around `(x, y)` or, with `groups`, one grid per group (robots split by id
/// into contiguous blocks, as flocks or teams that start apart).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StartLayout {
    /// Centre of the grid of start positions, x (not with `groups`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub x: Option<f64>,
    /// Centre of the grid, y (not with `groups`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub y: Option<f64>,
    /// Distance between neighbouring start positions.
    pub spacing: f64,
    /// Initial heading of every robot, degrees.
    #[serde(default)]
    pub heading_deg: f64,
    /// Start groups: robot `i` of `n` belongs to group `i * groups.len() / n`.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub groups: Vec<StartGroup>,
    /// Robots per start group, in id order (their sum is `robots.count`); default: as even
    /// as the count allows.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub group_sizes: Vec<u32>,
    /// Each robot starts up to this far (metres, per axis, uniform from the seed) off its grid
    /// point; at most `(spacing - 2 * radius) / 2`, so robots never start overlapping.
    #[serde(default, skip_serializing_if = "is_zero")]
    pub jitter: f64,
    /// Each robot's heading is off by up to this many degrees (uniform from the seed).
    #[serde(default, skip_serializing_if = "is_zero")]
    pub heading_jitter_deg: f64,
    /// Random placement instead of the grid: each group's robots are drawn uniformly (from
    /// the seed's `start_scatter` stream) in a disc of this radius around the group's centre,
    /// at least `spacing` apart, and no three of a group on one line (seed 001 assumes it).
    #[serde(default, skip_serializing_if = "is_zero")]
    pub scatter: f64,
    /// A chain instead of a grid: robot 0 at the first point `[x, y]` of this polyline and
    /// each next robot `spacing` further along it (arc length), every robot facing the one
    /// before it (the head back along the first segment), as a snake laid along a corridor.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub path: Vec<[f64; 2]>,
}

/// One start group: the centre of its grid and its robots' heading.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StartGroup {
    /// Centre x in metres.
    pub x: f64,
    /// Centre y in metres.
    pub y: f64,
    /// Heading of its robots in degrees (default: `robots.start.heading_deg`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub heading_deg: Option<f64>,
    /// `[x, y]`: this group's own goal (a goal of its own colour: its robots' goal sensor sees
    /// only it, and only it counts as reached); default `map.goal`. Radius: `map.goal.radius`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub goal: Option<[f64; 2]>,
    /// Start height of its robots when they are aerial (default `robots.aerial.start_z`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub z: Option<f64>,
    /// Height of its goal when its robots are aerial (default `map.goal.z`, else the start
    /// height).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub goal_z: Option<f64>,
}

impl Default for StartLayout {
    fn default() -> Self {
        StartLayout {
            x: Some(2.0),
            y: Some(2.0),
            spacing: 0.8,
            heading_deg: 0.0,
            groups: Vec::new(),
            group_sizes: Vec::new(),
            jitter: 0.0,
            heading_jitter_deg: 0.0,
            scatter: 0.0,
            path: Vec::new(),
        }
    }
}

fn is_zero(v: &f64) -> bool {
    *v == 0.0
}

/// The lidar: `rays` beams evenly over `fov_deg`, centred on the heading, or at the given
/// `angles_deg` (a ring of short-range proximity sensors such as the e-puck's eight IR sensors).
/// Ranges are measured from the robot's centre.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct LidarConfig {
    /// Number of rays (1..=64).
    pub rays: u32,
    /// Field of view in degrees (0..=360).
    pub fov_deg: f64,
    /// Maximum range in metres.
    pub range: f64,
    /// Explicit ray angles in degrees relative to the heading, counter-clockwise positive
    /// (ray k at `angles_deg[k]`); `rays` must equal their number and `fov_deg` is unused.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub angles_deg: Vec<f64>,
}

impl Default for LidarConfig {
    fn default() -> Self {
        LidarConfig {
            rays: 16,
            fov_deg: 180.0,
            range: 3.0,
            angles_deg: Vec::new(),
        }
    }
}

impl LidarConfig {
    /// Angle of ray `k` relative to the heading: `angles_deg[k]` when given, else evenly over
    /// the field of view, ray 0 at `-fov/2`; a full circle does not repeat its first ray at
    /// the end.
    pub fn ray_angle(&self, k: usize) -> f64 {
        if let Some(a) = self.angles_deg.get(k) {
            return a.to_radians();
        }
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
#[serde(default, deny_unknown_fields)]
pub struct RangeBearingConfig {
    /// Neighbours within this distance are reported.
    pub range: f64,
}

impl Default for RangeBearingConfig {
    fn default() -> Self {
        RangeBearingConfig { range: 3.0 }
    }
}

/// The goal sensor: sees the goal inside a cone and a range.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct GoalSensorConfig {
    /// Maximum distance in metres.
    pub range: f64,
    /// Cone width in degrees, centred on the heading.
    pub fov_deg: f64,
    /// Obstacles hide the goal (a camera cannot see through walls): the goal is seen only when
    /// the line from the robot to the goal's edge is clear of the map.
    #[serde(skip_serializing_if = "is_false")]
    pub occlusion: bool,
}

fn is_false(v: &bool) -> bool {
    !*v
}

impl Default for GoalSensorConfig {
    fn default() -> Self {
        GoalSensorConfig {
            range: 1000.0,
            fov_deg: 360.0,
            occlusion: false,
        }
    }
}

/// Gaussian sensor noise (standard deviations); zero means exact.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct NoiseConfig {
    /// Position noise in metres.
    pub pose: f64,
    /// Heading noise in radians.
    pub heading: f64,
    /// Lidar range noise in metres.
    pub lidar: f64,
    /// Wheel slip: each tick each wheel moves `1 + N(0, wheel_slip)` times what it was
    /// commanded (axle = the body diameter). This is what makes odometry drift: a robot that
    /// integrates its own commands no longer knows its true heading.
    #[serde(skip_serializing_if = "is_zero")]
    pub wheel_slip: f64,
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
#[serde(default, deny_unknown_fields)]
pub struct RadioConfig {
    /// Frames reach robots within this distance (metres).
    pub range: f64,
    /// Bernoulli drop probability per copy.
    pub loss: f64,
    /// Which loss model applies.
    pub loss_model: LossModel,
    /// Gilbert-Elliott: probability Good -> Bad per copy on a link.
    pub ge_p: f64,
    /// Gilbert-Elliott: probability Bad -> Good per copy on a link (mean burst = 1/r).
    pub ge_r: f64,
    /// Gilbert-Elliott: loss probability in the Good state (netem's 1-k).
    pub ge_loss_good: f64,
    /// Gilbert-Elliott: loss probability in the Bad state (netem's 1-h).
    pub ge_loss_bad: f64,
    /// Extra ticks between sending and delivery (0 = delivered with the next observation).
    pub delay_ticks: u32,
    /// Uniform extra delay in 0..=jitter_ticks per copy (this is what reorders frames).
    pub jitter_ticks: u32,
    /// Most frames one robot may send per tick; more are dropped as `capacity`.
    pub capacity: u32,
    /// When true, obstacles between sender and receiver block a frame.
    pub line_of_sight: bool,
    /// Most propagation rounds inside one tick (0: none, the default). A robot may mark
    /// frames to travel within the tick; their receivers are woken to react before the world
    /// steps, round after round, until no such frame is in flight or this cap is reached
    /// (seed 003's Appendix A: a master's motion passes along the whole chain in one step).
    #[serde(skip_serializing_if = "is_zero_u32")]
    pub rounds: u32,
}

fn is_zero_u32(v: &u32) -> bool {
    *v == 0
}

impl Default for RadioConfig {
    fn default() -> Self {
        RadioConfig {
            range: 10.0,
            loss: 0.0,
            loss_model: LossModel::Bernoulli,
            ge_p: 0.05,
            ge_r: 0.25,
            ge_loss_good: 0.0,
            ge_loss_bad: 1.0,
            delay_ticks: 0,
            jitter_ticks: 0,
            capacity: 4,
            line_of_sight: false,
            rounds: 0,
        }
    }
}

fn default_dt() -> f64 {
    0.1
}
fn yes() -> bool {
    true
}
/// 60 s at the usual 0.1 s tick: longer than any wait a behaviour of `configs/` plans (a
/// planner's settle and re-plan, a chain's veto), short against a run that is stuck for good.
pub const DEFAULT_STALL_TICKS: u64 = 600;

fn default_stall_ticks() -> u64 {
    DEFAULT_STALL_TICKS
}

fn is_default_stall_ticks(v: &u64) -> bool {
    *v == DEFAULT_STALL_TICKS
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

/// Largest coordinate magnitude in metres: keeps grid arithmetic far from overflow.
pub const MAX_COORD: f64 = 1e6;

/// Upper bound on robots in one run (process mode is limited by the machine long before).
pub const MAX_ROBOTS: u32 = 100_000;

impl Config {
    /// Reads `path`, applies `overrides` (`key=value`) and validates. `[behaviour]` stays
    /// opaque: resolve it with the behaviour registry (`swarmrt_agent::registry`). This is
    /// the one read of a config every command and process shares, so its bounds are here: a
    /// regular file (opened without blocking, so a FIFO or a device is refused at once) of at
    /// most [`MAX_CONFIG_BYTES`] bytes.
    pub fn load(path: &Path, overrides: &[String]) -> Result<Config, ConfigError> {
        let file = path.display().to_string();
        let text = read_bounded(path, MAX_CONFIG_BYTES)
            .map_err(|message| ConfigError::new(&file, "", message))?;
        Self::from_toml_str(&file, &text, overrides)
    }

    /// Parses `text` (named `file` in errors), applies `overrides` and validates. The text
    /// and each override are at most [`MAX_CONFIG_BYTES`] bytes, as a file is.
    pub fn from_toml_str(
        file: &str,
        text: &str,
        overrides: &[String],
    ) -> Result<Config, ConfigError> {
        if text.len() as u64 > MAX_CONFIG_BYTES {
            let got = format!("{} bytes", text.len());
            return Err(ConfigError::new(file, "", too_big(MAX_CONFIG_BYTES, &got)));
        }
        if let Some(ov) = overrides
            .iter()
            .find(|ov| ov.len() as u64 > MAX_CONFIG_BYTES)
        {
            let key = ov.split_once('=').map_or("", |(k, _)| k).trim();
            let got = format!("{} bytes", ov.len());
            return Err(ConfigError::new(
                "--set",
                key,
                too_big(MAX_CONFIG_BYTES, &got),
            ));
        }
        let mut table: toml::Table = toml::from_str(text).map_err(|e| {
            ConfigError::new(
                file,
                "",
                format!("not valid TOML: {}", one_line(&e.to_string())),
            )
        })?;
        for ov in overrides {
            apply_override(&mut table, ov)
                .map_err(|(key, message)| ConfigError::new("--set", key, message))?;
        }
        let config: Config =
            serde_path_to_error::deserialize(toml::Value::Table(table)).map_err(|e| {
                let key = e.path().to_string().trim_start_matches('.').to_string();
                ConfigError::new(file, key, one_line(&e.inner().to_string()))
            })?;
        config
            .validate()
            .map_err(|(key, message)| ConfigError::new(file, key, message))?;
        Ok(config)
    }

    /// The resolved config as TOML: running it again reproduces the run.
    pub fn to_toml(&self) -> String {
        toml::to_string(self).expect("a Config always serializes")
    }
}
