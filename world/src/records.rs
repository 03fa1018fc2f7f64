//! The run records the world owns: `trajectory.csv` and `events.jsonl` (DESIGN section 7).
//!
//! Each tick's lines are formatted into one buffer and written with a single `write_all`, so
//! a process killed mid-run leaves whole lines up to its last tick, never a torn one.

use std::fs::File;
use std::io::Write;
use std::path::Path;

use crate::world::{Event, Robot};

pub use swarmrt_protocol::records::{TRAJECTORY_HEADER, TRAJECTORY_HEADER_AERIAL};

/// The header for robots that are `aerial` or not.
pub fn trajectory_header(aerial: bool) -> &'static str {
    if aerial {
        TRAJECTORY_HEADER_AERIAL
    } else {
        TRAJECTORY_HEADER
    }
}

/// Appends one row per robot for `tick` to `out` (fixed decimals: identical bytes in both
/// modes), with the aerial columns when `aerial`.
pub fn trajectory_rows(out: &mut String, tick: u64, robots: &[Robot], aerial: bool) {
    use std::fmt::Write as _;
    if aerial {
        for r in robots {
            let _ = writeln!(
                out,
                "{tick},{},{:.5},{:.5},{:.5},{:.5},{:.5},{:.5},{:.5},{},{}",
                r.id,
                r.x,
                r.y,
                r.z,
                r.theta,
                r.v,
                r.vz,
                r.omega,
                r.lidar_on as u8,
                r.state.as_str()
            );
        }
        return;
    }
    for r in robots {
        let _ = writeln!(
            out,
            "{tick},{},{:.5},{:.5},{:.5},{:.5},{:.5},{},{}",
            r.id,
            r.x,
            r.y,
            r.theta,
            r.v,
            r.omega,
            r.lidar_on as u8,
            r.state.as_str()
        );
    }
}

/// Appends one JSON line per event to `out`.
pub fn event_lines(out: &mut String, events: &[Event]) {
    for e in events {
        out.push_str(&serde_json::to_string(e).expect("events always serialize"));
        out.push('\n');
    }
}

/// Writes `trajectory.csv` and `events.jsonl` into a run directory, tick by tick.
pub struct Recorder {
    trajectory: File,
    events: File,
    buf: String,
    aerial: bool,
}

impl Recorder {
    /// Creates both files (truncating) in `dir` and writes the CSV header (with the aerial
    /// columns when `aerial`).
    pub fn create(dir: &Path, aerial: bool) -> std::io::Result<Recorder> {
        let mut trajectory = File::create(dir.join("trajectory.csv"))?;
        trajectory.write_all(trajectory_header(aerial).as_bytes())?;
        let events = File::create(dir.join("events.jsonl"))?;
        Ok(Recorder {
            trajectory,
            events,
            buf: String::new(),
            aerial,
        })
    }

    /// Appends events without a trajectory row (e.g. a death noticed after the last tick).
    pub fn record_events(&mut self, events: &[Event]) -> std::io::Result<()> {
        if events.is_empty() {
            return Ok(());
        }
        self.buf.clear();
        event_lines(&mut self.buf, events);
        self.events.write_all(self.buf.as_bytes())
    }

    /// Records the robots' state at `tick` and the events that led to it.
    pub fn record(&mut self, tick: u64, robots: &[Robot], events: &[Event]) -> std::io::Result<()> {
        self.record_events(events)?;
        self.buf.clear();
        trajectory_rows(&mut self.buf, tick, robots, self.aerial);
        self.trajectory.write_all(self.buf.as_bytes())
    }
}
