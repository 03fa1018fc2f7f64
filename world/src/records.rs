//! The run records the world owns: `trajectory.csv` and `events.jsonl` (DESIGN section 7), and
//! with `scenario.record_radio` the opt-in `radio.csv` (one line per radio copy whose fate is
//! decided, [`swarmrt_protocol::records::RADIO_HEADER`]).
//!
//! Each tick's lines are formatted into one buffer per file and written with a single
//! `write_all`, events and radio lines before the trajectory rows, so a process killed mid-run
//! leaves whole lines up to its last tick, never a torn one (the orchestrator trims what the
//! kernel cut short).

use std::fs::File;
use std::io::Write;

use swarmrt_protocol::records::RadioRow;
use swarmrt_scenario::Config;
use swarmrt_scenario::safe_fs::{Open, OutDir};

use crate::world::{Event, Robot};

pub use swarmrt_protocol::records::{RADIO_HEADER, TRAJECTORY_HEADER, TRAJECTORY_HEADER_AERIAL};

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

/// Appends one `radio.csv` line per row to `out`.
pub fn radio_lines(out: &mut String, rows: &[RadioRow]) {
    for r in rows {
        r.write_line(out);
    }
}

/// Writes `trajectory.csv` and `events.jsonl` (and `radio.csv` when asked) into a run
/// directory, tick by tick.
pub struct Recorder {
    trajectory: File,
    events: File,
    radio: Option<File>,
    buf: String,
    aerial: bool,
}

impl Recorder {
    /// Creates both files (truncating) in `dir` and writes the CSV header (with the aerial
    /// columns when `aerial`), through the directory's handle. A symbolic link planted at a
    /// record's name is refused, never followed ([`swarmrt_scenario::safe_fs`]).
    pub fn create(dir: &OutDir, aerial: bool) -> std::io::Result<Recorder> {
        let mut trajectory = dir.file("trajectory.csv", Open::Create)?;
        trajectory.write_all(trajectory_header(aerial).as_bytes())?;
        let events = dir.file("events.jsonl", Open::Create)?;
        Ok(Recorder {
            trajectory,
            events,
            radio: None,
            buf: String::new(),
            aerial,
        })
    }

    /// The records `cfg` asks for: [`Recorder::create`] (aerial columns for aerial robots),
    /// plus `radio.csv` with its header when `scenario.record_radio` is set.
    pub fn for_run(dir: &OutDir, cfg: &Config) -> std::io::Result<Recorder> {
        let mut recorder = Recorder::create(dir, cfg.robots.aerial.is_some())?;
        if cfg.scenario.record_radio {
            let mut radio = dir.file("radio.csv", Open::Create)?;
            radio.write_all(RADIO_HEADER.as_bytes())?;
            recorder.radio = Some(radio);
        }
        Ok(recorder)
    }

    /// Appends `radio.csv` lines (nothing when the recorder writes no `radio.csv`).
    pub fn record_radio(&mut self, rows: &[RadioRow]) -> std::io::Result<()> {
        let Some(file) = self.radio.as_mut() else {
            return Ok(());
        };
        if rows.is_empty() {
            return Ok(());
        }
        self.buf.clear();
        radio_lines(&mut self.buf, rows);
        file.write_all(self.buf.as_bytes())
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
        self.record_tick(tick, robots, events, &[])
    }

    /// [`Recorder::record`] with the radio rows of the step that led to `tick`, written after
    /// the events and before the trajectory rows.
    pub fn record_tick(
        &mut self,
        tick: u64,
        robots: &[Robot],
        events: &[Event],
        radio: &[RadioRow],
    ) -> std::io::Result<()> {
        self.record_events(events)?;
        self.record_radio(radio)?;
        self.buf.clear();
        trajectory_rows(&mut self.buf, tick, robots, self.aerial);
        self.trajectory.write_all(self.buf.as_bytes())
    }
}

/// What the [`RecordWriter`] thread is asked to write.
enum Job {
    Tick(u64, Vec<Robot>, Vec<Event>, Vec<RadioRow>),
    Events(Vec<Event>),
}

/// Ticks the writer may fall behind before [`RecordWriter::record`] waits for it.
const WRITER_BACKLOG: usize = 64;

/// A [`Recorder`] on its own thread: the world hands over a copy of each tick's robots and
/// its events and goes on, so formatting and writing the rows (~17 us of a ~300 us tick at
/// 10 robots) overlap the robots' turn instead of adding to the tick. One writer takes the
/// jobs in order, so the files hold the same bytes as with a [`Recorder`]; dropping the
/// writer (or [`RecordWriter::finish`]) waits until everything handed over is written.
pub struct RecordWriter {
    tx: Option<std::sync::mpsc::SyncSender<Job>>,
    thread: Option<std::thread::JoinHandle<std::io::Result<()>>>,
}

impl RecordWriter {
    /// Creates the files as [`Recorder::create`] does and starts the writer thread.
    pub fn create(dir: &OutDir, aerial: bool) -> std::io::Result<RecordWriter> {
        RecordWriter::start(Recorder::create(dir, aerial)?)
    }

    /// Creates the files as [`Recorder::for_run`] does and starts the writer thread.
    pub fn for_run(dir: &OutDir, cfg: &Config) -> std::io::Result<RecordWriter> {
        RecordWriter::start(Recorder::for_run(dir, cfg)?)
    }

    fn start(mut recorder: Recorder) -> std::io::Result<RecordWriter> {
        let (tx, rx) = std::sync::mpsc::sync_channel::<Job>(WRITER_BACKLOG);
        let thread = std::thread::Builder::new()
            .name("records".into())
            .spawn(move || {
                for job in rx {
                    match job {
                        Job::Tick(tick, robots, events, radio) => {
                            recorder.record_tick(tick, &robots, &events, &radio)?
                        }
                        Job::Events(events) => recorder.record_events(&events)?,
                    }
                }
                Ok(())
            })?;
        Ok(RecordWriter {
            tx: Some(tx),
            thread: Some(thread),
        })
    }

    /// [`Recorder::record`], written by the thread. An error is the thread's first write
    /// error (after which it has stopped).
    pub fn record(
        &mut self,
        tick: u64,
        robots: &[Robot],
        events: Vec<Event>,
    ) -> std::io::Result<()> {
        self.record_tick(tick, robots, events, Vec::new())
    }

    /// [`Recorder::record_tick`], written by the thread.
    pub fn record_tick(
        &mut self,
        tick: u64,
        robots: &[Robot],
        events: Vec<Event>,
        radio: Vec<RadioRow>,
    ) -> std::io::Result<()> {
        self.send(Job::Tick(tick, robots.to_vec(), events, radio))
    }

    /// [`Recorder::record_events`], written by the thread.
    pub fn record_events(&mut self, events: Vec<Event>) -> std::io::Result<()> {
        if events.is_empty() {
            return Ok(());
        }
        self.send(Job::Events(events))
    }

    /// Waits until everything handed over is written; the first write error, if any.
    pub fn finish(mut self) -> std::io::Result<()> {
        self.join()
    }

    fn send(&mut self, job: Job) -> std::io::Result<()> {
        let sent = self.tx.as_ref().map(|tx| tx.send(job).is_ok());
        if sent == Some(true) {
            return Ok(());
        }
        // The thread is gone: it stopped at a write error, which joining returns.
        self.join()?;
        Err(std::io::Error::other("the record writer has stopped"))
    }

    fn join(&mut self) -> std::io::Result<()> {
        self.tx = None;
        match self.thread.take().map(std::thread::JoinHandle::join) {
            None => Ok(()),
            Some(Ok(result)) => result,
            Some(Err(_)) => Err(std::io::Error::other("the record writer panicked")),
        }
    }
}

impl Drop for RecordWriter {
    fn drop(&mut self) {
        // A run ending in an error still leaves every tick it handed over on disk.
        let _ = self.join();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A record name that is a symbolic link to a file outside the run directory is refused,
    /// naming it; the file it points to keeps its bytes.
    #[test]
    fn a_planted_link_at_a_records_name_is_refused_not_followed() {
        let cfg = Config::from_toml_str(
            "links.toml",
            r#"
                [scenario]
                name = "links"
                ticks = 3
                record_radio = true
                [map]
                bounds = [0.0, 0.0, 10.0, 10.0]
                goal = { x = 3.5, y = 3.0, radius = 1.0 }
                [robots]
                count = 2
            "#,
            &[],
        )
        .unwrap();
        for name in ["trajectory.csv", "events.jsonl", "radio.csv"] {
            let root = tempfile::tempdir().unwrap();
            let victim = root.path().join("victim");
            std::fs::write(&victim, "keep").unwrap();
            let dir = root.path().join("run");
            std::fs::create_dir(&dir).unwrap();
            let link = dir.join(name);
            std::os::unix::fs::symlink(&victim, &link).unwrap();
            let out = OutDir::open(&dir).unwrap();
            let e = Recorder::for_run(&out, &cfg).err().expect("refused");
            assert_eq!(
                e.to_string(),
                format!(
                    "{} is a symbolic link; refusing to follow it",
                    link.display()
                )
            );
            assert!(RecordWriter::for_run(&out, &cfg).is_err());
            assert_eq!(std::fs::read_to_string(&victim).unwrap(), "keep", "{name}");
        }
        // Without links: the usual files and headers.
        let root = tempfile::tempdir().unwrap();
        drop(Recorder::for_run(&OutDir::open(root.path()).unwrap(), &cfg).unwrap());
        assert_eq!(
            std::fs::read_to_string(root.path().join("radio.csv")).unwrap(),
            RADIO_HEADER
        );
    }
}
