//! The config reference (`docs/config.md`) and the bounds the validator checks, from one table.
//!
//! Every key of the config has one [`Key`] row in [`KEYS`]: its bounds, unit and meaning. The
//! validator reads its bounds from that row ([`check_f`], [`check_u`], [`lo`], [`hi`]), so the
//! numbers in the reference are the numbers that are checked. Everything else comes from the
//! code, through a [`Schema`]: a config with every key written ([`FULL`]) gives each key's type;
//! leaving one key out and letting serde fill it in gives its default (or says it is
//! required); an unknown enum name makes serde list the names it accepts. A behaviour's
//! `[behaviour]` parameters are its own table and schema (`swarmrt_agent::registry`), rendered
//! with the same [`render`].
//!
//! `scenario/tests/config_reference.rs` checks that the table and the serde schema hold the
//! same keys and that `docs/config.md` is what [`render`] writes.

use std::collections::BTreeSet;
use std::fmt::Write as _;

pub use crate::bounds::{Bounds, Key, Lim, check_f, check_u, concat, find, hi, k, lo, pattern, r};
use crate::config::{Config, MAX_COORD, MAX_ROBOTS};
use crate::error::{KeyError, one_line};
use crate::faults::MAX_RESTARTS;
use crate::limits::{MAX_CONFIG_BYTES, MAX_OBSTACLES, MAX_PROGRAMS};
use swarmrt_protocol::{MAX_LIDAR_RAYS, MAX_OUTBOX};

const C: f64 = MAX_COORD;
const COORD: Bounds = r(-C, C);
const TO_CEILING: Bounds = Bounds::Range(Lim::V(0.0), Lim::Of("map.height"));

/// The keys of the sections that do not own theirs yet (`[scenario]`, `[map]`, `[robots]`,
/// `[radio]`, `behaviour.kind`), in the order of the reference.
#[rustfmt::skip]
const SHARED_KEYS: &[Key] = &[
    // [scenario]
    k("scenario.name", Bounds::Rule("non-empty, at most 64 bytes; letters, digits, `_` or `-`"), "", "Scenario name, used in the run directory name."),
    k("scenario.seed", Bounds::Any, "", "The run seed: every random draw derives from it."),
    k("scenario.ticks", r(1.0, 100_000_000.0), "ticks", "Ticks to run at most."),
    k("scenario.dt", r(1e-4, 10.0), "s", "Seconds per tick."),
    k("scenario.stop_when_done", Bounds::Any, "", "End early once every robot reached the goal or is down or dead."),
    k("scenario.deadline_ms", r(1.0, 3_600_000.0), "ms", "A robot that has not answered within this is logged as late."),
    k("scenario.unresponsive_ms", Bounds::Range(Lim::Of("scenario.deadline_ms"), Lim::V(86_400_000.0)), "ms", "A robot silent this long is marked dead and killed, so it cannot hang the run."),
    k("scenario.stall_ticks", r(0.0, 100_000_000.0), "ticks", "With stop_when_done: end once no live robot short of its goal moved more than robots.radius for this long (0: off).").absent("600"),
    k("scenario.record_radio", Bounds::Any, "", "Write `radio.csv`: one line per radio copy delivered or dropped, with the reason.").absent("false"),
    // [map]
    k("map.bounds", COORD, "m", "The arena's walls.").also("max > min").ty("[min_x, min_y, max_x, max_y]"),
    k("map.height", r(1e-3, 1e6), "m", "Ceiling: aerial robots fly in `[0, height]`; required with `[robots.aerial]`."),
    k("map.goal.x", Bounds::Finite, "m", "Goal centre x.").also("inside `map.bounds`"),
    k("map.goal.y", Bounds::Finite, "m", "Goal centre y.").also("inside `map.bounds`"),
    k("map.goal.radius", r(1e-3, 1e6), "m", "A robot whose centre is this close has reached the goal."),
    k("map.goal.z", TO_CEILING, "m", "Goal height for aerial robots (unset: the robot's start height); reached in 3D."),
    k("map.circles[i].x", COORD, "m", "Centre x."),
    k("map.circles[i].y", COORD, "m", "Centre y."),
    k("map.circles[i].r", r(1e-3, 1e6), "m", "Radius."),
    k("map.circles[i].height", r(1e-3, 1e6), "m", "Height from the ground (unset: a wall of any height)."),
    k("map.rectangles[i].x_min", COORD, "m", "Left edge."),
    k("map.rectangles[i].y_min", COORD, "m", "Bottom edge."),
    k("map.rectangles[i].x_max", COORD, "m", "Right edge.").also("> x_min"),
    k("map.rectangles[i].y_max", COORD, "m", "Top edge.").also("> y_min"),
    k("map.rectangles[i].height", r(1e-3, 1e6), "m", "Height from the ground (unset: a wall of any height)."),
    k("map.polygons[i].points", COORD, "m", "Vertices `[x, y]` of a convex polygon, either winding.").also("3 to 256 points, not all on one line, whose convex hull has at least 1e-6 m²"),
    k("map.polygons[i].height", r(1e-3, 1e6), "m", "Height from the ground (unset: a wall of any height)."),
    // [robots]
    k("robots.count", r(1.0, MAX_ROBOTS as f64), "", "Number of robots, one process each."),
    k("robots.radius", r(1e-3, 100.0), "m", "Body radius."),
    k("robots.max_speed", r(0.0, 1000.0), "m/s", "Forward (aerial: horizontal) speed limit."),
    k("robots.max_turn_rate", r(0.0, 1000.0), "rad/s", "Turn-rate limit."),
    k("robots.program", Bounds::Rule("a command line whose first word is a program: 1 to 256 words of at most 4096 bytes, no NUL"), "", "Command line every robot runs instead of `swarm-agent` (unset: `swarm-agent`; docs/robot-interface.md).").ty("array of string"),
    k("robots.programs[i].robots", Bounds::Rule("ids below `robots.count`"), "", "One robot id, or a range `\"a..b\"` (end excluded).").ty("integer or string"),
    k("robots.programs[i].program", Bounds::Rule("a command line whose first word is a program: 1 to 256 words of at most 4096 bytes, no NUL"), "", "Command line of these robots; later entries win, `[\"swarm-agent\"]` is the built-in robot."),
    k("robots.start.x", COORD, "m", "Centre x of the grid of start positions.").also("not with `groups` or `path`"),
    k("robots.start.y", COORD, "m", "Centre y of the grid.").also("not with `groups` or `path`"),
    k("robots.start.spacing", Bounds::Range(Lim::Of("2 * robots.radius"), Lim::V(1e6)), "m", "Distance between neighbouring start positions.").also("above the lower end"),
    k("robots.start.heading_deg", Bounds::Finite, "deg", "Initial heading of every robot."),
    k("robots.start.group_sizes", Bounds::Rule("one positive size per group, summing to `robots.count`"), "", "Robots per start group in id order (`[]`: as even as the count allows).").ty("array of integer").absent("[]"),
    k("robots.start.jitter", Bounds::Range(Lim::V(0.0), Lim::Of("(spacing - 2 * radius) / 2")), "m", "Each robot starts up to this far off its grid point, per axis, drawn from the seed.").absent("0.0"),
    k("robots.start.heading_jitter_deg", r(0.0, 180.0), "deg", "Each robot's heading is off by up to this, drawn from the seed.").absent("0.0"),
    k("robots.start.scatter", r(0.0, C), "m", "Random placement in a disc of this radius around each group's centre, `spacing` apart (0: a grid).").absent("0.0"),
    k("robots.start.path", Bounds::Rule("2+ points inside `map.bounds`, at least `(count - 1) * spacing` long"), "m", "A chain along this polyline instead of a grid, each robot facing the one before.").also("not with x/y, `groups` or `scatter`").absent("[]"),
    k("robots.start.groups[i].x", COORD, "m", "Centre x of this group's grid."),
    k("robots.start.groups[i].y", COORD, "m", "Centre y of this group's grid."),
    k("robots.start.groups[i].heading_deg", Bounds::Finite, "deg", "Heading of its robots (unset: `robots.start.heading_deg`)."),
    k("robots.start.groups[i].goal", Bounds::Rule("a point `[x, y]` inside `map.bounds`"), "m", "A goal of its own colour, which only its robots see (unset: `map.goal`)."),
    k("robots.start.groups[i].z", TO_CEILING, "m", "Start height of its aerial robots (unset: `robots.aerial.start_z`)."),
    k("robots.start.groups[i].goal_z", TO_CEILING, "m", "Height of its goal for aerial robots (unset: `map.goal.z`, else the start height)."),
    k("robots.lidar.rays", r(1.0, MAX_LIDAR_RAYS as f64), "", "Number of rays.").also("the number of `angles_deg` when given"),
    k("robots.lidar.fov_deg", r(0.0, 360.0), "deg", "Field of view, rays evenly over it, centred on the heading."),
    k("robots.lidar.range", r(1e-3, 1e6), "m", "Maximum range, from the robot's centre."),
    k("robots.lidar.angles_deg", r(-360.0, 360.0), "deg", "Explicit ray angles from the heading, counter-clockwise (`fov_deg` unused).").absent("[]"),
    k("robots.range_bearing.range", r(0.0, 1e6), "m", "Neighbours within this distance are reported."),
    k("robots.goal_sensor.range", r(0.0, 1e9), "m", "The goal is seen up to this far."),
    k("robots.goal_sensor.fov_deg", r(0.0, 360.0), "deg", "Width of the camera cone, centred on the heading."),
    k("robots.goal_sensor.occlusion", Bounds::Any, "", "Obstacles hide the goal (a camera cannot see through walls).").absent("false"),
    k("robots.noise.pose", r(0.0, 100.0), "m", "Std dev of the position noise."),
    k("robots.noise.heading", r(0.0, 10.0), "rad", "Std dev of the heading noise."),
    k("robots.noise.lidar", r(0.0, 100.0), "m", "Std dev of the lidar range noise."),
    k("robots.noise.wheel_slip", r(0.0, 1.0), "", "Each wheel moves `1 + N(0, wheel_slip)` times its command: odometry drifts.").absent("0.0"),
    k("robots.aerial.max_vertical_speed", r(0.0, 1000.0), "m/s", "Climb and descent speed limit."),
    k("robots.aerial.start_z", TO_CEILING, "m", "Start height of robots whose group gives none."),
    // [radio]
    k("radio.range", r(0.0, 1e9), "m", "Frames reach robots within this distance."),
    k("radio.loss", r(0.0, 1.0), "", "Bernoulli drop probability per copy."),
    k("radio.loss_model", Bounds::Any, "", "How frames are lost: independently, or in bursts per link (netem's `gemodel`)."),
    k("radio.ge_p", r(0.0, 1.0), "", "Gilbert-Elliott: probability Good -> Bad per copy on a link."),
    k("radio.ge_r", r(0.0, 1.0), "", "Gilbert-Elliott: probability Bad -> Good per copy (mean burst 1/r)."),
    k("radio.ge_loss_good", r(0.0, 1.0), "", "Gilbert-Elliott: loss probability in the Good state."),
    k("radio.ge_loss_bad", r(0.0, 1.0), "", "Gilbert-Elliott: loss probability in the Bad state."),
    k("radio.delay_ticks", r(0.0, 10_000.0), "ticks", "Extra ticks between sending and delivery."),
    k("radio.jitter_ticks", r(0.0, 10_000.0), "ticks", "Uniform extra delay per copy in `0..=jitter_ticks` (reorders frames)."),
    k("radio.capacity", r(1.0, MAX_OUTBOX as f64), "frames", "Most frames one robot may send per tick; more are dropped."),
    k("radio.line_of_sight", Bounds::Any, "", "Obstacles between sender and receiver block a frame."),
    k("radio.rounds", r(0.0, 10_000.0), "rounds", "Most in-tick propagation rounds: frames a robot marks travel within the tick and wake their receivers to react before the world steps (0: none). Needs delay_ticks = jitter_ticks = 0 and the built-in robot.").absent("0"),
    // [behaviour]
    k("behaviour.kind", Bounds::Rule("a behaviour below"), "", "The behaviour every robot runs; its parameters are the other `[behaviour]` keys."),
];

/// `[ipc]`.
#[rustfmt::skip]
const IPC_KEYS: &[Key] = &[
    k("ipc.observers", r(0.0, 64.0), "", "Spare subscriber and listener slots per service, for tools attaching to a live run.").absent("2"),
];

/// Every table of rows, in the order of the reference: `[faults]` and `[consensus]` own theirs.
const TABLES: [&[Key]; 4] = [
    SHARED_KEYS,
    crate::faults::KEYS,
    crate::consensus::KEYS,
    IPC_KEYS,
];

const ROWS: usize =
    SHARED_KEYS.len() + crate::faults::KEYS.len() + crate::consensus::KEYS.len() + IPC_KEYS.len();

/// Every key of the config outside `[behaviour]`'s parameters, in the order of the reference.
pub const KEYS: &[Key] = &concat::<ROWS>(&TABLES);

/// The sections of the config, in the order of the reference, each with a line of meaning.
pub fn sections() -> Vec<(&'static str, String)> {
    [
        ("scenario", "Name, length, time step and seed. Required.".to_string()),
        ("map", "The arena; its bounds are walls. Required.".to_string()),
        ("map.goal", "The disc robots try to reach. Required.".to_string()),
        ("map.circles[i]", format!("Circular obstacles, at most {MAX_OBSTACLES}.")),
        ("map.rectangles[i]", format!("Axis-aligned rectangular obstacles, at most {MAX_OBSTACLES}.")),
        ("map.polygons[i]", format!("Convex polygon obstacles, at most {MAX_OBSTACLES}.")),
        ("robots", "Robot body and limits. Required.".to_string()),
        ("robots.programs[i]", format!("Programs for one robot or a range of them, at most {MAX_PROGRAMS} entries; later entries win (docs/robot-interface.md).")),
        ("robots.start", "Where robots start: one grid around `x, y` derived from `robots.count`, one grid per group, a random scatter, or a chain along a path.".to_string()),
        ("robots.start.groups[i]", "Start groups: robots split by id into contiguous blocks (flocks, teams), one grid each; not with `robots.start.x/y`.".to_string()),
        ("robots.lidar", "The range finder: rays evenly over a field of view, or at explicit angles.".to_string()),
        ("robots.range_bearing", "The range-and-bearing sensor (neighbours' distance, bearing and id).".to_string()),
        ("robots.goal_sensor", "The goal sensor: a camera cone.".to_string()),
        ("robots.noise", "Gaussian sensor noise, standard deviations; 0 is exact.".to_string()),
        ("robots.aerial", "Present: robots are UAVs (a height, a holonomic velocity in the world frame, 3D contacts). Needs `map.height`.".to_string()),
        ("radio", "The radio medium (docs/architecture.md).".to_string()),
        ("behaviour", "Which behaviour every robot runs; its parameters are listed per behaviour below.".to_string()),
        ("faults", "Faults applied by the world at tick boundaries (the orchestrator sends the real signal), so a faulted run still replays.".to_string()),
        ("faults.kill[i]", "SIGKILL a robot's process; it counts as dead from that tick.".to_string()),
        ("faults.freeze[i]", "SIGSTOP a robot from `from` to `to`: it stands still and silent.".to_string()),
        ("faults.restart[i]", format!("SIGKILL a robot and start a fresh process with the same id and no memory; at most {MAX_RESTARTS}.")),
        ("faults.partition[i]", "Split the radio from `from` to `to`.".to_string()),
        ("faults.blackout[i]", "All radio off from `from` to `to`.".to_string()),
        ("consensus", "Consensus among the robots; optional: without it they run none (docs/consensus.md).".to_string()),
        ("consensus.quadrant", "Timing of the quadrant leader choice.".to_string()),
        ("consensus.propose[i]", format!("Scheduled decisions, at most {}.", crate::consensus::MAX_PROPOSALS)),
        ("ipc", "How the run's iceoryx2 services are sized beyond the robots; left out of the resolved config while default.".to_string()),
    ]
    .into_iter()
    .collect()
}

/// A config with every key written, so each key's type shows; it parses but need not validate
/// (it has a grid centre, groups and a path at once).
pub const FULL: &str = r#"
[scenario]
name = "full"
seed = 1
ticks = 10
dt = 0.1
stop_when_done = true
deadline_ms = 2000
unresponsive_ms = 30000
record_radio = true
stall_ticks = 600

[map]
bounds = [0.0, 0.0, 10.0, 10.0]
height = 5.0
goal = { x = 8.0, y = 2.0, radius = 1.0, z = 1.0 }
circles = [{ x = 5.0, y = 5.0, r = 0.5, height = 1.0 }]
rectangles = [{ x_min = 1.0, y_min = 1.0, x_max = 2.0, y_max = 2.0, height = 1.0 }]
polygons = [{ points = [[3.0, 3.0], [4.0, 3.0], [3.5, 4.0]], height = 1.0 }]

[robots]
count = 4
radius = 0.15
max_speed = 1.0
max_turn_rate = 3.0
program = ["swarm-agent"]
programs = [{ robots = "0..2", program = ["swarm-agent"] }]
start = { x = 2.0, y = 2.0, spacing = 0.8, heading_deg = 0.0, group_sizes = [4], jitter = 0.1, heading_jitter_deg = 5.0, scatter = 1.0, path = [[1.0, 1.0], [5.0, 1.0]], groups = [{ x = 2.0, y = 2.0, heading_deg = 0.0, goal = [8.0, 2.0], z = 1.0, goal_z = 1.0 }] }
lidar = { rays = 1, fov_deg = 180.0, range = 3.0, angles_deg = [0.0] }
range_bearing = { range = 3.0 }
goal_sensor = { range = 1000.0, fov_deg = 360.0, occlusion = true }
noise = { pose = 0.1, heading = 0.1, lidar = 0.1, wheel_slip = 0.1 }
aerial = { max_vertical_speed = 1.0, start_z = 1.0 }

[radio]
range = 10.0
loss = 0.1
loss_model = "bernoulli"
ge_p = 0.05
ge_r = 0.25
ge_loss_good = 0.0
ge_loss_bad = 1.0
delay_ticks = 0
jitter_ticks = 0
capacity = 4
line_of_sight = true
rounds = 0

[behaviour]
kind = "goto"

[faults]
kill_rate = 0.1
freeze_rate = 0.1
freeze_ticks = 20
kill = [{ tick = 5, robot = 0 }]
freeze = [{ robot = 0, from = 1, to = 2 }]
restart = [{ tick = 5, robot = 0, down_ticks = 10 }]
partition = [{ from = 1, to = 2, groups = [[0, 1]] }]
blackout = [{ from = 1, to = 2 }]

[consensus]
algorithm = "raft"
election_timeout_min = 20
election_timeout_max = 40
heartbeat_ticks = 4
pre_vote = true
check_quorum = true
stats_every = 20
storage = false
quadrant = { claim_period = 3, decide_tick = 30 }
propose = [{ tick = 5, goal = [5.0, 5.0], speed = 0.5 }]

[ipc]
observers = 3
"#;

/// What the reference needs of a schema besides its table: a value with every key written,
/// and a round trip through serde (deserialize with defaults filled in, serialize again;
/// `Err((key, message))` as serde says it).
pub struct Schema {
    /// The key table.
    pub keys: &'static [Key],
    /// Every key written.
    pub full: toml::Table,
    /// Deserialize, then serialize; no bounds checks.
    pub round_trip: fn(&toml::Table) -> Result<toml::Table, KeyError>,
    /// Tables whose keys are not this schema's (`[behaviour]` is open in the core schema).
    pub open: &'static [&'static str],
}

fn config_round_trip(t: &toml::Table) -> Result<toml::Table, KeyError> {
    let c: Config =
        serde_path_to_error::deserialize(toml::Value::Table(t.clone())).map_err(|e| {
            let key = e.path().to_string().trim_start_matches('.').to_string();
            (key, one_line(&e.inner().to_string()))
        })?;
    Ok(toml::Table::try_from(&c).expect("a Config always serializes"))
}

impl Schema {
    /// The config outside `[behaviour]`'s parameters.
    pub fn core() -> Schema {
        Schema {
            keys: KEYS,
            full: toml::from_str(FULL).expect("FULL is TOML"),
            round_trip: config_round_trip,
            open: &["behaviour"],
        }
    }

    /// Every key of `full` that holds a value (arrays of tables are descended, `[i]`), in
    /// document order, with its value.
    pub fn leaves(&self) -> Vec<(String, toml::Value)> {
        let mut out = Vec::new();
        walk(&self.full, "", &mut |path, v| {
            if let Some(path) = path {
                out.push((path, v.clone()));
            }
        });
        out
    }

    /// Every table of `full` (`""` is the root, `map.circles[i]` an array's first element).
    pub fn tables(&self) -> Vec<String> {
        let mut out = vec![String::new()];
        walk(&self.full, "", &mut |path, v| {
            if path.is_none() {
                out.push(value_str(v));
            }
        });
        out
    }

    /// The keys serde accepts in the table at `path`, as its unknown-field error lists them;
    /// `None` when it accepts any key.
    pub fn accepted(&self, path: &str) -> Option<BTreeSet<String>> {
        let mut t = self.full.clone();
        let probe = "__probe__";
        let table = if path.is_empty() {
            &mut t
        } else {
            get_mut(&mut t, path)?.as_table_mut()?
        };
        table.insert(probe.into(), toml::Value::Integer(0));
        let (_, message) = (self.round_trip)(&t).err()?;
        message
            .contains("unknown field")
            .then(|| names_after_expected(&message))
    }

    /// The names serde accepts for the string at `key` (an enum), empty for a free string.
    pub fn variants(&self, key: &str) -> Vec<String> {
        let mut t = self.full.clone();
        match get_mut(&mut t, key) {
            Some(v @ toml::Value::String(_)) => *v = toml::Value::String("__probe__".into()),
            _ => return Vec::new(),
        }
        match (self.round_trip)(&t) {
            Err((_, m)) if m.contains("unknown variant") => {
                names_after_expected(&m).into_iter().collect()
            }
            _ => Vec::new(),
        }
    }

    /// `key`'s default as serde fills it in when the key is left out, and, when it differs,
    /// the value it has when its whole table is left out (`robots.start.spacing` is required
    /// in a written `[robots.start]`, 0.8 without one).
    pub fn default_of(&self, key: &str) -> (Default, Option<toml::Value>) {
        let left_out = |path: &str| {
            let mut t = self.full.clone();
            remove(&mut t, path);
            (self.round_trip)(&t).map(|mut t| get_mut(&mut t, key).cloned())
        };
        let own = match left_out(key) {
            Ok(Some(v)) => Default::Value(v),
            Ok(None) => Default::Absent,
            Err(_) => Default::Required,
        };
        let parent = key.rsplit_once('.').map_or("", |(p, _)| p);
        if parent.is_empty() || parent.ends_with(']') {
            return (own, None);
        }
        let without_table = left_out(parent).ok().flatten();
        match (&own, without_table) {
            (Default::Value(v), Some(w)) if *v == w => (own, None),
            (_, w) => (own, w),
        }
    }
}

/// A key's default as the schema gives it.
#[derive(Debug, Clone, PartialEq)]
pub enum Default {
    /// Filled in with this value.
    Value(toml::Value),
    /// Left out of the resolved config (see [`Key::absent`]).
    Absent,
    /// Must be written.
    Required,
}

/// `f(Some(path), value)` for each leaf, `f(None, String(path))` for each table.
fn walk(t: &toml::Table, prefix: &str, f: &mut dyn FnMut(Option<String>, &toml::Value)) {
    for (name, v) in t {
        let path = if prefix.is_empty() {
            name.clone()
        } else {
            format!("{prefix}.{name}")
        };
        match v {
            toml::Value::Table(sub) => {
                f(None, &toml::Value::String(path.clone()));
                walk(sub, &path, f);
            }
            toml::Value::Array(a) if a.first().is_some_and(toml::Value::is_table) => {
                let path = format!("{path}[i]");
                f(None, &toml::Value::String(path.clone()));
                walk(a[0].as_table().expect("a table"), &path, f);
            }
            _ => f(Some(path), v),
        }
    }
}

fn value_str(v: &toml::Value) -> String {
    v.as_str().unwrap_or_default().to_string()
}

/// The value at `path` (`[i]`: the first element).
fn get_mut<'a>(t: &'a mut toml::Table, path: &str) -> Option<&'a mut toml::Value> {
    let mut parts = path.split('.');
    let first = parts.next()?;
    let mut cur = step(t, first)?;
    for part in parts {
        cur = step(cur.as_table_mut()?, part)?;
    }
    Some(cur)
}

fn step<'a>(t: &'a mut toml::Table, part: &str) -> Option<&'a mut toml::Value> {
    match part.strip_suffix("[i]") {
        Some(name) => t.get_mut(name)?.as_array_mut()?.first_mut(),
        None => t.get_mut(part),
    }
}

fn remove(t: &mut toml::Table, path: &str) {
    let (parent, name) = path.rsplit_once('.').unwrap_or(("", path));
    let table = if parent.is_empty() {
        Some(t)
    } else {
        get_mut(t, parent).and_then(toml::Value::as_table_mut)
    };
    if let Some(table) = table {
        table.remove(name);
    }
}

/// The backquoted names after "expected" in a serde error.
fn names_after_expected(message: &str) -> BTreeSet<String> {
    let tail = message.split_once("expected").map_or("", |(_, t)| t);
    let parts: Vec<&str> = tail.split('`').collect();
    // Names sit at odd positions; one after " in " or " for key " says where the error was.
    (1..parts.len())
        .step_by(2)
        .filter(|&i| !parts[i - 1].ends_with(" in ") && !parts[i - 1].ends_with(" for key "))
        .map(|i| parts[i].to_string())
        .collect()
}

/// `1e6` rather than `1000000`, `1e-4` rather than `0.0001`.
fn num(v: f64) -> String {
    let a = v.abs();
    let power_of_ten = a >= 1e5 && a.log10().fract() == 0.0;
    if v != 0.0 && (power_of_ten || a < 1e-3) {
        format!("{v:e}")
    } else {
        v.to_string()
    }
}

fn lim(l: Lim) -> String {
    match l {
        Lim::V(v) => num(v),
        Lim::Of(e) => format!("`{e}`"),
    }
}

fn type_of(v: &toml::Value) -> String {
    match v {
        toml::Value::String(_) => "string".into(),
        toml::Value::Integer(_) => "integer".into(),
        toml::Value::Float(_) => "float".into(),
        toml::Value::Boolean(_) => "bool".into(),
        toml::Value::Datetime(_) => "datetime".into(),
        toml::Value::Array(a) => match a.first() {
            Some(toml::Value::Array(inner)) if inner.len() == 2 && inner[0].is_float() => {
                "array of [x, y]".into()
            }
            Some(first) => format!("array of {}", type_of(first)),
            None => "array".into(),
        },
        toml::Value::Table(_) => "table".into(),
    }
}

fn cell(s: &str) -> String {
    s.replace('|', "\\|").replace('\n', " ")
}

/// One schema's keys grouped by section, as Markdown: a heading, a line and a table per
/// section. `sections` are `(path, meaning)`; `prefix` is put before every key shown.
fn render_schema(out: &mut String, schema: &Schema, sections: &[(&str, String)], headings: bool) {
    let leaves = schema.leaves();
    for (section, about) in sections {
        let rows: Vec<&(String, toml::Value)> = leaves
            .iter()
            .filter(|(path, _)| path.rsplit_once('.').map_or("", |(p, _)| p) == *section)
            .collect();
        let heading = match section.strip_suffix("[i]") {
            Some(array) => format!("`[[{array}]]`"),
            None => format!("`[{section}]`"),
        };
        if headings && !heading.is_empty() {
            let _ = writeln!(out, "### {heading}\n");
        }
        if !about.is_empty() {
            let _ = writeln!(out, "{about}\n");
        }
        if rows.is_empty() {
            continue;
        }
        out.push_str("| key | type | default | bounds | unit | meaning |\n");
        out.push_str("|---|---|---|---|---|---|\n");
        for (path, value) in rows {
            let key = find(schema.keys, path);
            let variants = schema.variants(path);
            let ty = if !key.ty.is_empty() {
                key.ty.to_string()
            } else {
                type_of(value)
            };
            let (own, without_table) = schema.default_of(path);
            let mut default = match own {
                Default::Value(v) => format!("`{v}`"),
                Default::Absent if key.absent == "unset" => "unset".to_string(),
                Default::Absent => format!("`{}`", key.absent),
                Default::Required => "required".to_string(),
            };
            if let Some(w) = without_table {
                let table = path.rsplit_once('.').map_or("", |(p, _)| p);
                let _ = write!(default, "; `{w}` without `[{table}]`");
            }
            let mut bounds = match key.bounds {
                Bounds::Any if !variants.is_empty() => {
                    let names: Vec<String> =
                        variants.iter().map(|n| format!("`\"{n}\"`")).collect();
                    format!("one of {}", names.join(", "))
                }
                Bounds::Any => String::new(),
                Bounds::Finite => "finite".to_string(),
                Bounds::Range(lo, hi) => format!("[{}, {}]", lim(lo), lim(hi)),
                Bounds::Rule(rule) => rule.to_string(),
            };
            if !key.also.is_empty() {
                if !bounds.is_empty() {
                    bounds.push_str("; ");
                }
                bounds.push_str(key.also);
            }
            let _ = writeln!(
                out,
                "| `{}` | {} | {} | {} | {} | {} |",
                path,
                cell(&ty),
                cell(&default),
                cell(&bounds),
                cell(key.unit),
                cell(key.meaning)
            );
        }
        out.push('\n');
    }
}

/// One behaviour's part of the reference: its `kind` and its schema (keys `behaviour.<name>`).
pub struct BehaviourDoc {
    /// `behaviour.kind`.
    pub kind: &'static str,
    /// Its parameters.
    pub schema: Schema,
}

/// `docs/config.md`: the core schema, then each behaviour's parameters.
pub fn render(core: &Schema, behaviours: &[BehaviourDoc]) -> String {
    let mut out = String::new();
    out.push_str(&format!(
        "# Config reference\n\n\
         <!-- Generated by swarmrt_scenario::reference; do not edit. Regenerate with\n\
         SWARMRT_UPDATE_DOCS=1 cargo test -p swarmrt-agent --test agent config_reference -->\n\n\
         TOML, SI units (m, s, rad; degrees only where a key ends in `_deg`). Unknown keys are\n\
         errors, and every value is checked against the bounds below before any process starts;\n\
         the error names the file, the key and the bounds. `--set key=value` overrides any key.\n\
         `swarm check <config>` prints the resolved config, every default filled in.\n\n\
         A config is a regular file of UTF-8 text of at most {max} bytes (1 MiB), and so is\n\
         each `--set` argument; a FIFO, a device or a directory is refused before a byte is\n\
         read. Lists are bounded too (obstacles, vertices, command lines: see their rows).\n\n\
         Keys are dotted paths; `[i]` is any element of an array of tables. *default*: the value\n\
         used when the key is not written (*unset*: no value, what it means is in the meaning;\n\
         *required*: must be written). *bounds*: ends included; a bound in `code` depends on\n\
         other keys.\n\n\
         ## Sections\n\n",
        max = MAX_CONFIG_BYTES
    ));
    let sections = sections();
    render_schema(&mut out, core, &sections, true);
    out.push_str(
        "## Behaviour parameters\n\n\
         The keys of `[behaviour]` besides `kind` belong to the behaviour `kind` names; each\n\
         behaviour checks its own (docs/behaviours.md).\n\n",
    );
    for b in behaviours {
        let _ = writeln!(out, "### `kind = \"{}\"`\n", b.kind);
        render_schema(&mut out, &b.schema, &[("behaviour", String::new())], false);
    }
    out
}
