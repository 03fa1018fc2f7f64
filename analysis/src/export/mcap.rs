//! A run directory as an MCAP file that opens in the Foxglove app, Lichtblick or any MCAP
//! reader (`swarm export <run-dir> --mcap <file>`).
//!
//! # Encoding: JSON with Foxglove's JSON Schemas
//!
//! Every channel has message encoding `json` and a schema of encoding `jsonschema` whose data
//! is Foxglove's own JSON Schema of that message (`schemas/*.json`, copied from the Foxglove
//! SDK; see `schemas/README.md`). Foxglove and Lichtblick recognise the well-known schemas by
//! name and decode JSON as readily as protobuf. The alternative, the `foxglove` SDK crate's
//! generated protobuf types (`foxglove` 0.30), can leave out its TLS and websocket server
//! (`default-features = false`, by its manifest), but still brings the SDK's logging context,
//! prost and a dozen crates for three message types. JSON needs only the `mcap` crate (the
//! container, never written by hand here) and `serde_json`, which the workspace has, and any
//! reader decodes the messages without protobuf (the end-to-end test reads them with plain
//! Python). The cost is size, which lz4 chunk compression mostly takes back (lz4 rather than
//! zstd: its C library builds in seconds).
//!
//! # Channels
//!
//! | topic | schema | messages |
//! |---|---|---|
//! | `/scene/map` | `foxglove.SceneUpdate` | one, at time 0: the bounds (line loops, and the ceiling's for an aerial map), circles (cylinders), rectangles (cubes), polygons (triangle-list prisms with an outline), each goal (a disc, or a sphere at its height for aerial robots). Obstacles are as tall as their `height`, else the map's ceiling, else 1 m |
//! | `/scene/robots` | `foxglove.SceneUpdate` | one per tick: each robot a cylinder of its radius with an arrow along its heading and its id as a label, coloured by state (active blue, down red, dead grey, frozen cyan, restarting orange) |
//! | `/tf` | `foxglove.FrameTransforms` | one per tick: a transform per robot, frame `robot_<id>` in `world` |
//! | `/events` | `foxglove.Log` | one per line of `events.jsonl`, at its tick's time |
//!
//! The map is a topic of its own so that it stays in the 3D panel after a seek: Foxglove
//! shows the last message of each topic before the seek time, and the map's is the one at 0.
//!
//! **Poses as `FrameTransforms`, not `PoseInFrame` per robot.** Foxglove's 3D panel takes
//! transforms from every topic into one frame tree without any panel settings: each robot is
//! a frame that can be followed (display frame `robot_3`) or plotted
//! (`/tf.transforms[:]{child_frame_id=="robot_3"}.translation.x`), and is interpolated
//! between ticks. A `PoseInFrame` topic per robot is a separate layer per robot that has to be
//! switched on one by one, and lies in no frame other data can be attached to.
//!
//! Timestamps are `tick * scenario.dt` seconds from 0 (dt rounded to whole nanoseconds), as
//! log and publish time and in every message. The output depends only on the run directory:
//! the same run gives the same bytes.
//!
//! # Input
//!
//! A directory without `config.toml` or `trajectory.csv`, or whose config or trajectory
//! header cannot be read, is a [`BadInput`] (the user's mistake, not a failure). The last line
//! of a crashed run is often torn: rows that are not whole and a last tick that misses robots
//! are left out, the export ends at the last whole tick, and [`Summary::warnings`] says so.

use std::collections::BTreeMap;
use std::fmt;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

use ::mcap::records::{MessageHeader, Metadata};
use ::mcap::{Attachment, Compression, WriteOptions, Writer};
use anyhow::Context;
use serde::Deserialize;
use serde_json::{Value, json};
use swarmrt_protocol::RobotState;
use swarmrt_protocol::records::{Columns, Event, FaultKind, Row};
use swarmrt_scenario::Config;
use swarmrt_scenario::safe_fs::{self, Open, OutDir};

/// `foxglove.SceneUpdate`'s JSON Schema (Foxglove SDK, `schemas/jsonschema/`).
pub const SCENE_UPDATE_SCHEMA: &str = include_str!("schemas/SceneUpdate.json");
/// `foxglove.FrameTransforms`'s JSON Schema.
pub const FRAME_TRANSFORMS_SCHEMA: &str = include_str!("schemas/FrameTransforms.json");
/// `foxglove.Log`'s JSON Schema.
pub const LOG_SCHEMA: &str = include_str!("schemas/Log.json");

/// Topic of the map (one `foxglove.SceneUpdate` at time 0).
pub const MAP_TOPIC: &str = "/scene/map";
/// Topic of the robots' bodies (one `foxglove.SceneUpdate` per tick).
pub const ROBOTS_TOPIC: &str = "/scene/robots";
/// Topic of the robots' poses (one `foxglove.FrameTransforms` per tick).
pub const TF_TOPIC: &str = "/tf";
/// Topic of the events (one `foxglove.Log` per event).
pub const EVENTS_TOPIC: &str = "/events";
/// The fixed frame everything is drawn in.
pub const WORLD_FRAME: &str = "world";

/// Height of an obstacle with no `height` on a map with no ceiling, metres.
const DEFAULT_WALL_HEIGHT: f64 = 1.0;

/// `foxglove.Log` levels.
const LOG_DEBUG: u8 = 1;
const LOG_INFO: u8 = 2;
const LOG_WARNING: u8 = 3;

/// The input is not an exportable run directory (a user error, not a failure): its message
/// is one line.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct BadInput(pub String);

impl fmt::Display for BadInput {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for BadInput {}

/// What [`write_mcap`] wrote.
#[derive(Debug, Clone, PartialEq)]
pub struct Summary {
    /// The file written.
    pub path: PathBuf,
    /// Its size in bytes.
    pub bytes: u64,
    /// Ticks exported.
    pub ticks: u64,
    /// Robots in the run.
    pub robots: usize,
    /// Every channel in the file: topic, schema name and messages written, in channel order.
    pub channels: Vec<ChannelCount>,
    /// What was left out and why (a torn last line, unreadable event lines); empty for a
    /// whole run.
    pub warnings: Vec<String>,
}

/// One channel of the file and its message count.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ChannelCount {
    /// The topic.
    pub topic: String,
    /// The schema's name (`foxglove.SceneUpdate`, ...).
    pub schema: String,
    /// Messages written on it.
    pub messages: u64,
}

/// Writes the run in `run_dir` to `out` as MCAP (see the module documentation). The file is
/// written beside `out` (`<out>.partial`) through a handle on `out`'s directory, checked as a
/// run directory is (`safe_fs::OutDir`), and renamed into place, so a failed export leaves no
/// partial file. Refused as [`BadInput`]: a symbolic link at either name (never followed,
/// never replaced) and an `out` that is one of the run's own files (the export would destroy
/// what it reads).
pub fn write_mcap(run_dir: &Path, out: &Path) -> anyhow::Result<Summary> {
    let (parent, name) = out_parts(out)?;
    let dir = OutDir::create(&parent).map_err(|e| BadInput(format!("--mcap: {e}")))?;
    refuse_run_file(run_dir, &dir, &name, out)?;
    let partial = format!("{name}.partial");
    for n in [&name, &partial] {
        if dir.stat(n).is_some_and(|e| e.is_symlink) {
            return Err(BadInput(safe_fs::symlink_error(&dir.join(n)).to_string()).into());
        }
    }
    let run = RunInput::read(run_dir)?;
    let file = dir.file(&partial, Open::Create).map_err(|e| {
        BadInput(format!(
            "cannot create {}: {e}",
            dir.join(&partial).display()
        ))
    })?;
    let result = write_run(&run, BufWriter::new(file));
    let counts = match result {
        Ok(c) => c,
        Err(e) => {
            let _ = dir.remove_file(&partial);
            return Err(e.context(format!("writing {}", out.display())));
        }
    };
    dir.rename(&partial, &name).with_context(|| {
        format!(
            "renaming {} to {}",
            dir.join(&partial).display(),
            out.display()
        )
    })?;
    let bytes = dir
        .file(&name, Open::Read)
        .and_then(|f| f.metadata())
        .with_context(|| format!("reading back {}", out.display()))?
        .len();
    Ok(Summary {
        path: out.to_path_buf(),
        bytes,
        ticks: run.ticks.len() as u64,
        robots: run.robots(),
        channels: counts,
        warnings: run.warnings,
    })
}

/// `out`'s directory (`.` for a bare name) and file name.
fn out_parts(out: &Path) -> anyhow::Result<(PathBuf, String)> {
    let name = out
        .file_name()
        .and_then(|n| n.to_str())
        .filter(|n| *n != "." && *n != "..")
        .ok_or_else(|| BadInput(format!("--mcap {}: not a file name", out.display())))?;
    let parent = match out.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    };
    Ok((parent, name.to_string()))
}

/// Refuses `name` in `dir` when it is (the same file as) one of the files at the top of the
/// run directory the export reads: writing there would replace the run's own record.
fn refuse_run_file(run_dir: &Path, dir: &OutDir, name: &str, out: &Path) -> anyhow::Result<()> {
    use std::os::unix::fs::MetadataExt;
    let Ok(target) = dir.file(name, Open::Read).and_then(|f| f.metadata()) else {
        return Ok(());
    };
    let Ok(entries) = std::fs::read_dir(run_dir) else {
        return Ok(());
    };
    for e in entries.flatten() {
        if let Ok(m) = std::fs::symlink_metadata(e.path())
            && m.is_file()
            && (m.dev(), m.ino()) == (target.dev(), target.ino())
        {
            return Err(BadInput(format!(
                "--mcap {}: that is the run's own {}; the export would replace what it reads; \
                 choose another file",
                out.display(),
                e.file_name().to_string_lossy()
            ))
            .into());
        }
    }
    Ok(())
}

/// One line of `events.jsonl`, parsed.
#[derive(Debug, Clone, PartialEq)]
struct EventLine {
    /// 1-based line number in `events.jsonl`.
    line: u64,
    tick: u64,
    event: Logged,
}

/// An event line as the world writes it ([`Event`]), or one this build does not read as
/// such (another kind, a field missing), which is logged as the JSON it is.
#[derive(Debug, Clone, PartialEq)]
enum Logged {
    Known(Event<Value>),
    Other(Value),
}

impl Logged {
    fn of(v: Value) -> Logged {
        match Event::<Value>::deserialize(&v) {
            Ok(e) => Logged::Known(e),
            Err(_) => Logged::Other(v),
        }
    }
}

/// What the export reads from a run directory.
#[derive(Debug, Clone)]
struct RunInput {
    cfg: Config,
    config_text: String,
    /// Whole ticks, in order; each holds every robot, in file order.
    ticks: Vec<Vec<Row>>,
    /// Events in file order.
    events: Vec<EventLine>,
    warnings: Vec<String>,
}

impl RunInput {
    fn read(dir: &Path) -> anyhow::Result<RunInput> {
        if !dir.is_dir() {
            return Err(BadInput(format!("{}: no such run directory", dir.display())).into());
        }
        for name in ["config.toml", "trajectory.csv"] {
            if !dir.join(name).is_file() {
                return Err(BadInput(format!(
                    "{}: not a run directory (it has no {name})",
                    dir.display()
                ))
                .into());
            }
        }
        let read = |name: &str| {
            std::fs::read_to_string(dir.join(name))
                .with_context(|| format!("reading {}", dir.join(name).display()))
        };
        let config_path = dir.join("config.toml");
        let config_text = read("config.toml")?;
        let cfg = Config::from_toml_str(&config_path.display().to_string(), &config_text, &[])
            .map_err(|e| BadInput(e.to_string()))?;
        let mut warnings = Vec::new();
        let trajectory_path = dir.join("trajectory.csv");
        let (ticks, torn) = parse_trajectory(&read("trajectory.csv")?, &mut warnings)
            .map_err(|e| BadInput(format!("{}: {e}", trajectory_path.display())))?;
        let events_path = dir.join("events.jsonl");
        let mut events = if events_path.is_file() {
            parse_events(&read("events.jsonl")?, &mut warnings)
        } else {
            warnings.push(format!(
                "{}: missing; no events exported",
                events_path.display()
            ));
            Vec::new()
        };
        if torn && let Some(last) = ticks.last().map(|t| t[0].tick) {
            let before = events.len();
            events.retain(|e| e.tick <= last);
            let dropped = before - events.len();
            if dropped > 0 {
                warnings.push(format!(
                    "{dropped} event(s) after tick {last}, the last whole tick, left out"
                ));
            }
        }
        Ok(RunInput {
            cfg,
            config_text,
            ticks,
            events,
            warnings,
        })
    }

    fn robots(&self) -> usize {
        self.ticks.first().map_or(0, Vec::len)
    }

    fn aerial(&self) -> bool {
        self.cfg.robots.aerial.is_some()
    }
}

/// `trajectory.csv`'s whole ticks and whether anything was torn off its end. A last line
/// without its newline and a last tick with fewer rows than the others are left out (a
/// crashed run's); rows that do not parse elsewhere are skipped. Both are noted in
/// `warnings`. `Err` for a header that is not `trajectory.csv`'s.
fn parse_trajectory(
    text: &str,
    warnings: &mut Vec<String>,
) -> Result<(Vec<Vec<Row>>, bool), String> {
    let mut lines: Vec<&str> = text.split('\n').collect();
    // `split` leaves "" after a final newline; anything else there is a line cut short.
    let last = lines.pop().unwrap_or("");
    let cut_line = !last.is_empty();
    let header = lines.first().copied().unwrap_or(last);
    let cols = Columns::from_header(header)?;
    let mut ticks: Vec<Vec<Row>> = Vec::new();
    let mut bad = 0usize;
    for line in lines.iter().skip(1).filter(|l| !l.is_empty()) {
        let Some(row) = cols.parse(line) else {
            bad += 1;
            continue;
        };
        match ticks.last_mut() {
            Some(t) if t[0].tick == row.tick => t.push(row),
            _ => ticks.push(vec![row]),
        }
    }
    if bad > 0 {
        warnings.push(format!(
            "trajectory.csv: {bad} row(s) that are not whole skipped"
        ));
    }
    let whole = ticks.iter().map(Vec::len).max().unwrap_or(0);
    let short_tick = ticks.len() > 1 && ticks.last().is_some_and(|t| t.len() < whole);
    if short_tick {
        ticks.pop();
    }
    let torn = cut_line || short_tick;
    if torn {
        let upto = match ticks.last() {
            Some(t) => format!("up to tick {}, the last whole one", t[0].tick),
            None => "no tick".to_string(),
        };
        warnings.push(format!(
            "trajectory.csv ends in a torn line (a crashed run?): exported {upto}"
        ));
    }
    Ok((ticks, torn))
}

/// Every line of `events.jsonl` that is a JSON object with a `tick`; others are skipped and
/// counted in `warnings` (a torn last line is the usual one).
fn parse_events(text: &str, warnings: &mut Vec<String>) -> Vec<EventLine> {
    let mut out = Vec::new();
    let mut bad = 0usize;
    for (i, line) in text.lines().enumerate() {
        if line.trim().is_empty() {
            continue;
        }
        let parsed: Option<Value> = serde_json::from_str(line).ok();
        match parsed
            .as_ref()
            .and_then(|v| v.get("tick"))
            .and_then(Value::as_u64)
        {
            Some(tick) => out.push(EventLine {
                line: i as u64 + 1,
                tick,
                event: Logged::of(parsed.expect("parsed above")),
            }),
            None => bad += 1,
        }
    }
    if bad > 0 {
        warnings.push(format!(
            "events.jsonl: {bad} line(s) that are not whole events skipped"
        ));
    }
    out
}

/// The channels, in the order they are registered: (topic, schema name, schema JSON).
const CHANNELS: [(&str, &str, &str); 4] = [
    (MAP_TOPIC, "foxglove.SceneUpdate", SCENE_UPDATE_SCHEMA),
    (ROBOTS_TOPIC, "foxglove.SceneUpdate", SCENE_UPDATE_SCHEMA),
    (
        TF_TOPIC,
        "foxglove.FrameTransforms",
        FRAME_TRANSFORMS_SCHEMA,
    ),
    (EVENTS_TOPIC, "foxglove.Log", LOG_SCHEMA),
];
const MAP: usize = 0;
const ROBOTS: usize = 1;
const TF: usize = 2;
const EVENTS: usize = 3;

/// The MCAP writer with one sequence counter per channel.
struct Out<W: Write + std::io::Seek> {
    writer: Writer<W>,
    ids: [u16; 4],
    counts: [u64; 4],
}

impl<W: Write + std::io::Seek> Out<W> {
    fn write(&mut self, channel: usize, time_ns: u64, msg: &Value) -> anyhow::Result<()> {
        let data = serde_json::to_vec(msg)?;
        self.writer.write_to_known_channel(
            &MessageHeader {
                channel_id: self.ids[channel],
                sequence: self.counts[channel] as u32,
                log_time: time_ns,
                publish_time: time_ns,
            },
            &data,
        )?;
        self.counts[channel] += 1;
        Ok(())
    }
}

fn write_run<W: Write + std::io::Seek>(
    run: &RunInput,
    sink: W,
) -> anyhow::Result<Vec<ChannelCount>> {
    let mut writer = WriteOptions::new()
        .compression(Some(Compression::Lz4))
        .create(sink)?;
    let mut schema_ids: BTreeMap<&str, u16> = BTreeMap::new();
    let mut ids = [0u16; 4];
    for (k, (topic, schema, data)) in CHANNELS.iter().enumerate() {
        let schema_id = match schema_ids.get(schema) {
            Some(&id) => id,
            None => {
                let id = writer.add_schema(schema, "jsonschema", data.as_bytes())?;
                schema_ids.insert(schema, id);
                id
            }
        };
        ids[k] = writer.add_channel(schema_id, topic, "json", &BTreeMap::new())?;
    }
    let cfg = &run.cfg;
    let dt_ns = (cfg.scenario.dt * 1e9).round().max(0.0) as u64;
    let time = |tick: u64| tick.saturating_mul(dt_ns);
    writer.write_metadata(&Metadata {
        name: "swarmrt".to_string(),
        metadata: BTreeMap::from([
            ("scenario".to_string(), cfg.scenario.name.clone()),
            ("seed".to_string(), cfg.scenario.seed.to_string()),
            ("dt".to_string(), cfg.scenario.dt.to_string()),
            ("robots".to_string(), run.robots().to_string()),
            ("ticks".to_string(), run.ticks.len().to_string()),
            ("aerial".to_string(), run.aerial().to_string()),
        ]),
    })?;
    writer.attach(&Attachment {
        log_time: 0,
        create_time: 0,
        name: "config.toml".to_string(),
        media_type: "application/toml".to_string(),
        data: std::borrow::Cow::Borrowed(run.config_text.as_bytes()),
    })?;
    let mut out = Out {
        writer,
        ids,
        counts: [0; 4],
    };
    out.write(MAP, 0, &map_update(cfg))?;

    let mut events = run.events.clone();
    // Stable: events of one tick stay in file order.
    events.sort_by_key(|e| e.tick);
    let mut next_event = events.iter().peekable();
    for rows in &run.ticks {
        let tick = rows[0].tick;
        // Events of earlier ticks than this one (before the first row, or between rows).
        while let Some(e) = next_event.next_if(|e| e.tick < tick) {
            out.write(EVENTS, time(e.tick), &log_message(e, time(e.tick)))?;
        }
        let t = time(tick);
        out.write(TF, t, &frame_transforms(rows, t))?;
        out.write(ROBOTS, t, &robots_update(cfg, rows, t))?;
        while let Some(e) = next_event.next_if(|e| e.tick == tick) {
            out.write(EVENTS, t, &log_message(e, t))?;
        }
    }
    for e in next_event {
        out.write(EVENTS, time(e.tick), &log_message(e, time(e.tick)))?;
    }
    out.writer.finish()?;
    out.writer.into_inner().flush()?;
    Ok(CHANNELS
        .iter()
        .zip(out.counts)
        .map(|((topic, schema, _), messages)| ChannelCount {
            topic: topic.to_string(),
            schema: schema.to_string(),
            messages,
        })
        .collect())
}

/// `foxglove.Time` / `foxglove.Duration` of `ns` nanoseconds.
fn time_json(ns: u64) -> Value {
    json!({"sec": ns / 1_000_000_000, "nsec": ns % 1_000_000_000})
}

fn vec3(x: f64, y: f64, z: f64) -> Value {
    json!({"x": x, "y": y, "z": z})
}

/// A rotation of `yaw` radians about +z.
fn yaw_quaternion(yaw: f64) -> Value {
    let h = yaw / 2.0;
    json!({"x": 0.0, "y": 0.0, "z": h.sin(), "w": h.cos()})
}

fn pose(x: f64, y: f64, z: f64, yaw: f64) -> Value {
    json!({"position": vec3(x, y, z), "orientation": yaw_quaternion(yaw)})
}

fn colour([r, g, b]: [f64; 3], a: f64) -> Value {
    json!({"r": r, "g": g, "b": b, "a": a})
}

const OBSTACLE: [f64; 3] = [0.62, 0.62, 0.62];
const BOUNDS: [f64; 3] = [0.25, 0.25, 0.25];
const GOAL: [f64; 3] = [0.0, 0.59, 0.0];

/// Colour of a robot in `state`.
fn state_colour(state: RobotState) -> [f64; 3] {
    match state {
        RobotState::Active => [0.12, 0.47, 0.71],
        RobotState::Down => [0.84, 0.15, 0.16],
        RobotState::Dead => [0.35, 0.35, 0.35],
        RobotState::Frozen => [0.09, 0.75, 0.81],
        RobotState::Restarting => [1.0, 0.5, 0.05],
    }
}

/// A `foxglove.SceneEntity` in the world frame with every list the schema requires; `fill`
/// sets the primitives it has.
fn entity(
    id: String,
    time_ns: u64,
    metadata: &[(&str, String)],
    fill: &[(&str, Vec<Value>)],
) -> Value {
    let mut e = json!({
        "timestamp": time_json(time_ns),
        "frame_id": WORLD_FRAME,
        "id": id,
        "lifetime": time_json(0),
        "frame_locked": false,
        "metadata": metadata
            .iter()
            .map(|(k, v)| json!({"key": k, "value": v}))
            .collect::<Vec<_>>(),
        "arrows": [],
        "cubes": [],
        "spheres": [],
        "cylinders": [],
        "lines": [],
        "triangles": [],
        "texts": [],
        "models": [],
    });
    for (kind, list) in fill {
        e[*kind] = Value::Array(list.clone());
    }
    e
}

fn scene_update(entities: Vec<Value>) -> Value {
    json!({"deletions": [], "entities": entities})
}

/// A `foxglove.LinePrimitive` through `points` (`kind` 1: a loop, 2: pairs), in pixels.
fn line(kind: u8, points: &[[f64; 3]], rgb: [f64; 3]) -> Value {
    json!({
        "type": kind,
        "pose": pose(0.0, 0.0, 0.0, 0.0),
        "thickness": 2.0,
        "scale_invariant": true,
        "points": points.iter().map(|p| vec3(p[0], p[1], p[2])).collect::<Vec<_>>(),
        "color": colour(rgb, 1.0),
        "colors": [],
        "indices": [],
    })
}

fn cylinder(
    x: f64,
    y: f64,
    z: f64,
    diameter: f64,
    height: f64,
    rgb: [f64; 3],
    alpha: f64,
) -> Value {
    json!({
        "pose": pose(x, y, z, 0.0),
        "size": vec3(diameter, diameter, height),
        "bottom_scale": 1.0,
        "top_scale": 1.0,
        "color": colour(rgb, alpha),
    })
}

/// The map: bounds, obstacles and goals, to stay until replaced (lifetime 0).
fn map_update(cfg: &Config) -> Value {
    let map = &cfg.map;
    let aerial = cfg.robots.aerial.is_some();
    let wall = map.height.unwrap_or(DEFAULT_WALL_HEIGHT).abs();
    let height = |h: Option<f64>| h.unwrap_or(wall).abs();
    let mut entities = Vec::new();

    let [x0, y0, x1, y1] = map.bounds;
    let ring = |z: f64| [[x0, y0, z], [x1, y0, z], [x1, y1, z], [x0, y1, z]];
    let mut bounds = vec![line(1, &ring(0.0), BOUNDS)];
    if let Some(top) = map.height.filter(|_| aerial) {
        bounds.push(line(1, &ring(top), BOUNDS));
        let verticals: Vec<[f64; 3]> = ring(0.0)
            .iter()
            .flat_map(|&[x, y, _]| [[x, y, 0.0], [x, y, top]])
            .collect();
        bounds.push(line(2, &verticals, BOUNDS));
    }
    entities.push(entity("bounds".into(), 0, &[], &[("lines", bounds)]));

    for (i, c) in map.circles.iter().enumerate() {
        let h = height(c.height);
        let body = cylinder(c.x, c.y, h / 2.0, 2.0 * c.r.abs(), h, OBSTACLE, 1.0);
        entities.push(entity(
            format!("circle_{i}"),
            0,
            &[],
            &[("cylinders", vec![body])],
        ));
    }
    for (i, r) in map.rectangles.iter().enumerate() {
        let h = height(r.height);
        let cube = json!({
            "pose": pose((r.x_min + r.x_max) / 2.0, (r.y_min + r.y_max) / 2.0, h / 2.0, 0.0),
            "size": vec3((r.x_max - r.x_min).abs(), (r.y_max - r.y_min).abs(), h),
            "color": colour(OBSTACLE, 1.0),
        });
        entities.push(entity(
            format!("rectangle_{i}"),
            0,
            &[],
            &[("cubes", vec![cube])],
        ));
    }
    for (i, p) in map.polygons.iter().enumerate() {
        let h = height(p.height);
        let pts = &p.points;
        let mut tris: Vec<[f64; 3]> = Vec::new();
        // Top cap as a fan (the polygon is convex), then two triangles per side.
        for k in 1..pts.len().saturating_sub(1) {
            for q in [pts[0], pts[k], pts[k + 1]] {
                tris.push([q[0], q[1], h]);
            }
        }
        for k in 0..pts.len() {
            let (a, b) = (pts[k], pts[(k + 1) % pts.len()]);
            tris.extend([[a[0], a[1], 0.0], [b[0], b[1], 0.0], [b[0], b[1], h]]);
            tris.extend([[a[0], a[1], 0.0], [b[0], b[1], h], [a[0], a[1], h]]);
        }
        let prism = json!({
            "pose": pose(0.0, 0.0, 0.0, 0.0),
            "points": tris.iter().map(|q| vec3(q[0], q[1], q[2])).collect::<Vec<_>>(),
            "color": colour(OBSTACLE, 1.0),
            "colors": [],
            "indices": [],
        });
        let top: Vec<[f64; 3]> = pts.iter().map(|q| [q[0], q[1], h]).collect();
        entities.push(entity(
            format!("polygon_{i}"),
            0,
            &[],
            &[
                ("triangles", vec![prism]),
                ("lines", vec![line(1, &top, BOUNDS)]),
            ],
        ));
    }
    for (i, g) in cfg.goals().iter().enumerate() {
        let d = 2.0 * g.radius.abs();
        let fill = match g.z.filter(|_| aerial) {
            Some(z) => (
                "spheres",
                json!({
                    "pose": pose(g.x, g.y, z, 0.0),
                    "size": vec3(d, d, d),
                    "color": colour(GOAL, 0.25),
                }),
            ),
            None => ("cylinders", cylinder(g.x, g.y, 0.005, d, 0.01, GOAL, 0.35)),
        };
        entities.push(entity(
            format!("goal_{i}"),
            0,
            &[],
            &[(fill.0, vec![fill.1])],
        ));
    }
    scene_update(entities)
}

/// Every robot at one tick, coloured by state.
fn robots_update(cfg: &Config, rows: &[Row], time_ns: u64) -> Value {
    let r = cfg.robots.radius.abs();
    let aerial = cfg.robots.aerial.is_some();
    // A ground robot is a puck on the floor; an aerial one a disc centred at its height.
    let body_h = if aerial { 0.4 * r } else { r };
    let entities = rows
        .iter()
        .map(|row| {
            let rgb = state_colour(row.state);
            let zc = if aerial { row.z } else { body_h / 2.0 };
            let top = zc + body_h / 2.0 + 0.02 * r;
            let arrow = json!({
                "pose": pose(row.x, row.y, top, row.theta),
                "shaft_length": 1.2 * r,
                "shaft_diameter": 0.25 * r,
                "head_length": 0.5 * r,
                "head_diameter": 0.55 * r,
                "color": colour(rgb.map(|c| c * 0.6), 1.0),
            });
            let label = json!({
                "pose": pose(row.x, row.y, top + r, 0.0),
                "billboard": true,
                "font_size": 14.0,
                "scale_invariant": true,
                "color": colour([1.0, 1.0, 1.0], 1.0),
                "text": row.id.to_string(),
            });
            entity(
                format!("robot_{}", row.id),
                time_ns,
                &[("state", row.state.as_str().to_string())],
                &[
                    (
                        "cylinders",
                        vec![cylinder(row.x, row.y, zc, 2.0 * r, body_h, rgb, 1.0)],
                    ),
                    ("arrows", vec![arrow]),
                    ("texts", vec![label]),
                ],
            )
        })
        .collect();
    scene_update(entities)
}

/// One transform per robot: frame `robot_<id>` in `world`, at its position, turned by its
/// heading.
fn frame_transforms(rows: &[Row], time_ns: u64) -> Value {
    let transforms: Vec<Value> = rows
        .iter()
        .map(|row| {
            json!({
                "timestamp": time_json(time_ns),
                "parent_frame_id": WORLD_FRAME,
                "child_frame_id": format!("robot_{}", row.id),
                "translation": vec3(row.x, row.y, row.z),
                "rotation": yaw_quaternion(row.theta),
            })
        })
        .collect();
    json!({ "transforms": transforms })
}

/// An event as a `foxglove.Log`: warning for collisions, deaths and rejected commands, debug
/// for notes (a robot's chatter, often many), info for the rest; `name` is `robot_<id>` for a
/// robot's event, else `world`; `file`/`line` point into `events.jsonl`.
fn log_message(e: &EventLine, time_ns: u64) -> Value {
    let (robot, level, message) = match &e.event {
        Logged::Known(ev) => {
            let (robot, level, message) = known_log(ev);
            (robot.map(u64::from), level, message)
        }
        Logged::Other(ev) => other_log(ev),
    };
    json!({
        "timestamp": time_json(time_ns),
        "level": level,
        "message": message,
        "name": robot.map_or("world".to_string(), |r| format!("robot_{r}")),
        "file": "events.jsonl",
        "line": e.line,
    })
}

/// The robot, level and message of an event the world writes.
fn known_log(ev: &Event<Value>) -> (Option<u32>, u8, String) {
    match ev {
        Event::Collision { robot, other, .. } => (
            Some(*robot),
            LOG_WARNING,
            match other {
                Some(o) => format!("collision: robot {robot} hit robot {o}"),
                None => format!("collision: robot {robot} hit an obstacle or a wall"),
            },
        ),
        Event::Reached { robot, .. } => (
            Some(*robot),
            LOG_INFO,
            format!("reached: robot {robot} reached its goal"),
        ),
        Event::Died { robot, reason, .. } => (
            Some(*robot),
            LOG_WARNING,
            format!("died: robot {robot}: {reason}"),
        ),
        Event::Rejected { robot, reason, .. } => (
            Some(*robot),
            LOG_WARNING,
            format!("rejected: robot {robot}'s command: {reason}"),
        ),
        Event::Fault {
            fault,
            robot,
            random,
            ..
        } => {
            let random = if *random { " (random)" } else { "" };
            let target = robot.map_or(String::new(), |r| format!(" robot {r}"));
            let name = fault_name(*fault);
            (*robot, LOG_INFO, format!("fault: {name}{target}{random}"))
        }
        Event::Note { robot, note, .. } => (
            Some(*robot),
            LOG_DEBUG,
            format!("note: robot {robot}: {note}"),
        ),
    }
}

/// The name of `fault` in `events.jsonl` (its serde name, so never spelled twice).
fn fault_name(fault: FaultKind) -> String {
    match serde_json::to_value(fault) {
        Ok(Value::String(name)) => name,
        _ => String::new(),
    }
}

/// An event line this build does not read as an [`Event`]: logged at info as its kind and
/// its JSON, named for its `robot` when it has one.
fn other_log(ev: &Value) -> (Option<u64>, u8, String) {
    let kind = ev["event"].as_str().unwrap_or("event");
    let robot = ev.get("robot").and_then(Value::as_u64);
    (robot, LOG_INFO, format!("{kind}: {ev}"))
}

#[cfg(test)]
mod tests;
