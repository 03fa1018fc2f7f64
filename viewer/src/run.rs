//! One run directory as the viewer sees it: its config (the map, the robots), its records read
//! as they grow, and whether it is still going, finished, or ended without its report.

use std::path::{Path, PathBuf};

use serde::Serialize;
use serde_json::{Value, json};
use swarmrt_scenario::Config;

use crate::ViewError;
use crate::events::EventsModel;
use crate::overlay::RoleDef;
use crate::radio::RadioIndex;
use crate::trajectory::{ROBOT_BYTES, TrajectoryIndex};

/// Bytes of frames the page fetches at once (a chunk): small enough to arrive in a few
/// milliseconds, large enough that a 3,000-tick run is a few dozen requests.
const CHUNK_BYTES: usize = 1 << 20;

/// What the page needs once: the map, the robots, the behaviour's roles.
#[derive(Debug, Clone, Serialize)]
pub struct Meta {
    /// Scenario name.
    pub name: String,
    /// The run directory's name (never its absolute path: the page has no use for it).
    pub dir: String,
    /// Seconds per tick.
    pub dt: f64,
    /// Ticks the config asks for.
    pub ticks_planned: u64,
    /// Robots.
    pub robots: u32,
    /// Robot radius, metres.
    pub radius: f64,
    /// Aerial robots (records have z; the page adds a side view).
    pub aerial: bool,
    /// The map section of the config: bounds, goal, circles, rectangles, polygons, heights.
    pub map: Value,
    /// The goal and every start group's own goal.
    pub goals: Vec<Value>,
    /// `behaviour.kind`.
    pub behaviour: String,
    /// The behaviour's roles, indexed by the frames' role byte.
    pub roles: &'static [RoleDef],
    /// Frames per `/api/frames` chunk.
    pub chunk_frames: usize,
    /// Bytes per robot per frame.
    pub robot_bytes: usize,
    /// Radio range, metres (drawn around a selected robot).
    pub radio_range: f64,
    /// Whether the run records consensus notes (Raft or quadrant lanes).
    pub consensus: bool,
}

/// Where a run is in its life, and how much of it can be shown.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Status {
    /// `live` (still being written), `complete`, `failed` (the run reported a failure) or
    /// `crashed` (it ended without a report).
    pub state: &'static str,
    /// Whole ticks that can be shown.
    pub frames: usize,
    /// Tick number of the first frame.
    pub first_tick: u64,
    /// Tick number of the last whole frame.
    pub last_tick: u64,
    /// Timeline markers so far.
    pub markers: usize,
    /// Consensus lane points so far.
    pub lanes: usize,
    /// Frames of radio traffic recorded so far (`radio.csv`), if the run has it.
    pub radio_frames: Option<usize>,
    /// Something the page must say above the map (a crashed run, a torn record).
    pub banner: Option<String>,
}

/// A run directory being shown.
pub struct Run {
    dir: PathBuf,
    /// What the page needs once.
    pub meta: Meta,
    /// `trajectory.csv`.
    pub trajectory: TrajectoryIndex,
    /// `events.jsonl`.
    pub events: EventsModel,
    /// `radio.csv` (empty unless the run records it).
    pub radio: RadioIndex,
    /// Why the last refresh could not read a record (shown above the map).
    read_error: Option<String>,
}

/// The largest `metrics.json` read (a 10,000-robot run's is a few megabytes); a larger one
/// is treated as unreadable.
const METRICS_CAP: u64 = 64 << 20;

/// Refuses what is not a run directory, with one line saying why.
fn check_dir(dir: &Path) -> Result<(), ViewError> {
    let not_run = |why: &str| ViewError::NotARun(format!("{}: {why}", dir.display()));
    if !dir.is_dir() {
        return Err(not_run("no such directory"));
    }
    match crate::files::open_record(&dir.join("config.toml")) {
        Ok(Some(_)) => Ok(()),
        Ok(None) => Err(not_run(
            "not a run directory (no config.toml; `swarm run` prints the directory it writes)",
        )),
        Err(e) => Err(ViewError::NotARun(e.to_string())),
    }
}

impl Run {
    /// Opens `dir`: its config must load; its records may still be empty (a run that is
    /// starting).
    pub fn open(dir: &Path) -> Result<Run, ViewError> {
        check_dir(dir)?;
        let config_path = dir.join("config.toml");
        let cfg = swarmrt_agent::registry::load(&config_path, &[])
            .map_err(|e| ViewError::NotARun(e.to_string()))?;
        let robots = cfg.robots.count as usize;
        let overlay = crate::agent_overlay::for_config(&cfg);
        let roles = overlay.roles();
        let events = EventsModel::new(&dir.join("events.jsonl"), robots, overlay);
        let meta = meta(dir, &cfg, roles);
        // Always looked for: a live run creates radio.csv after the viewer opened it.
        let radio = RadioIndex::new(&dir.join("radio.csv"));
        let mut run = Run {
            dir: dir.to_path_buf(),
            meta,
            trajectory: TrajectoryIndex::new(&dir.join("trajectory.csv"), robots),
            events,
            radio,
            read_error: None,
        };
        run.refresh().map_err(|e| {
            ViewError::NotARun(format!("{}: cannot read the run: {e}", dir.display()))
        })?;
        if run.status().state != "live" && run.trajectory.is_empty() {
            return Err(ViewError::NotARun(format!(
                "{}: the run recorded no whole tick (trajectory.csv is missing or empty)",
                dir.display()
            )));
        }
        Ok(run)
    }

    /// Reads what the run appended since the last call; an error is also kept for the
    /// page's banner until a refresh succeeds.
    pub fn refresh(&mut self) -> std::io::Result<()> {
        let read = self.read_new();
        self.read_error = read.as_ref().err().map(|e| e.to_string());
        read
    }

    fn read_new(&mut self) -> std::io::Result<()> {
        self.trajectory.refresh()?;
        self.meta.aerial |= self.trajectory.aerial();
        self.events.refresh()?;
        self.radio.refresh()?;
        if self.events.has_lanes() {
            self.meta.consensus = true;
        }
        Ok(())
    }

    /// Whether the run is going on: its orchestrator holds the directory's lock.
    fn locked(&self) -> bool {
        // Never a FIFO or a link at its name: only a regular file is a lock.
        let Ok(Some(file)) = crate::files::open_record(&self.dir.join(".lock")) else {
            return false;
        };
        matches!(
            file.try_lock_shared(),
            Err(std::fs::TryLockError::WouldBlock)
        )
    }

    /// Where the run is now.
    pub fn status(&self) -> Status {
        let metrics = crate::files::read_capped(&self.dir.join("metrics.json"), METRICS_CAP)
            .ok()
            .flatten()
            .and_then(|t| serde_json::from_slice::<Value>(&t).ok());
        let frames = self.trajectory.len();
        let last = frames
            .checked_sub(1)
            .and_then(|i| self.trajectory.tick(i))
            .unwrap_or(0);
        let (state, mut banner) = match &metrics {
            Some(m) if m["failed"] == json!(true) => (
                "failed",
                Some(format!(
                    "The run failed ({}): shown up to its last whole tick, {last}.",
                    m["failure"].as_str().unwrap_or("no reason given")
                )),
            ),
            Some(_) => ("complete", None),
            None if self.locked() => ("live", None),
            None => (
                "crashed",
                Some(format!(
                    "The run ended without its report (crashed or killed): shown up to its last whole tick, {last}."
                )),
            ),
        };
        if state != "live" && banner.is_none() && self.trajectory.has_tail() {
            banner = Some(format!(
                "trajectory.csv ends in a torn line: shown up to its last whole tick, {last}."
            ));
        }
        let mut notes: Vec<String> = banner.into_iter().collect();
        if let Some(e) = &self.read_error {
            notes.push(format!("Cannot read the run's records: {e}."));
        }
        let long = [
            ("trajectory.csv", self.trajectory.long_lines()),
            ("events.jsonl", self.events.long_lines()),
            ("radio.csv", self.radio.long_lines()),
        ];
        for (name, n) in long.into_iter().filter(|&(_, n)| n > 0) {
            let lines = if n == 1 { "line" } else { "lines" };
            notes.push(format!(
                "{name}: {n} {lines} longer than {} KiB skipped.",
                crate::tail::MAX_LINE >> 10
            ));
        }
        let banner = (!notes.is_empty()).then(|| notes.join(" "));
        Status {
            state,
            frames,
            first_tick: self.trajectory.tick(0).unwrap_or(0),
            last_tick: last,
            markers: self.events.markers.len(),
            lanes: self.events.lanes.len(),
            radio_frames: self.radio.recorded().then(|| self.radio.ticks()),
            banner,
        }
    }
}

fn meta(dir: &Path, cfg: &Config, roles: &'static [RoleDef]) -> Meta {
    let mut goals = vec![json!({
        "x": cfg.map.goal.x, "y": cfg.map.goal.y, "radius": cfg.map.goal.radius,
        "z": cfg.map.goal.z,
    })];
    for g in &cfg.robots.start.groups {
        if let Some([x, y]) = g.goal {
            goals.push(json!({"x": x, "y": y, "radius": cfg.map.goal.radius, "z": g.goal_z}));
        }
    }
    let robots = cfg.robots.count as usize;
    Meta {
        name: cfg.scenario.name.clone(),
        dir: dir
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default(),
        dt: cfg.scenario.dt,
        ticks_planned: cfg.scenario.ticks,
        robots: cfg.robots.count,
        radius: cfg.robots.radius,
        aerial: cfg.robots.aerial.is_some(),
        map: serde_json::to_value(&cfg.map).unwrap_or(Value::Null),
        goals,
        behaviour: cfg.behaviour.kind.clone(),
        roles,
        chunk_frames: (CHUNK_BYTES / (robots.max(1) * ROBOT_BYTES)).clamp(1, 256),
        robot_bytes: ROBOT_BYTES,
        radio_range: cfg.radio.range,
        consensus: cfg.consensus.is_some(),
    }
}
