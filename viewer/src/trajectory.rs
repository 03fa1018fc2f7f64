//! `trajectory.csv` read as it grows: where each whole tick starts, and a range of ticks packed
//! as binary frames for the page.
//!
//! The world writes each tick's rows with one `write_all`, so a tick is whole once all its
//! rows are there; a crashed run's torn last line, or a tick with fewer rows than robots, is
//! simply not a tick yet. Only the bytes past what was already scanned are read on a refresh,
//! so following a live run costs one `read` of the new rows.

use std::path::Path;

use swarmrt_protocol::RobotState;
use swarmrt_protocol::records::Columns;

use crate::tail::Tail;

/// Bytes of one robot in one frame: `f32` x, y, z, theta, then `u8` state, role, flags
/// (bit 0: lidar on) and one spare byte; little-endian.
pub const ROBOT_BYTES: usize = 20;
/// First four bytes of a frames response ("SWVF").
pub const FRAMES_MAGIC: u32 = u32::from_le_bytes(*b"SWVF");
/// Role byte of a robot whose behaviour gives it none.
pub const NO_ROLE: u8 = 255;

/// One robot's row, every column (what the page shows of a clicked robot).
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct FullRow {
    /// Tick.
    pub tick: u64,
    /// Robot id.
    pub id: u32,
    /// Position, metres.
    pub x: f64,
    /// Position, metres.
    pub y: f64,
    /// Height, metres (aerial robots).
    pub z: Option<f64>,
    /// Heading, radians.
    pub theta: f64,
    /// Forward (horizontal) speed, m/s.
    pub v: f64,
    /// Vertical speed, m/s (aerial robots).
    pub vz: Option<f64>,
    /// Turn rate, rad/s.
    pub omega: f64,
    /// Lidar on.
    pub lidar: bool,
    /// Lifecycle state (`active`, `down`, `dead`, `frozen`, `restarting`).
    pub state: String,
}

/// The whole ticks of a `trajectory.csv` found so far.
#[derive(Debug)]
pub struct TrajectoryIndex {
    tail: Tail,
    robots: usize,
    cols: Option<Columns>,
    /// The tick being read (not yet all rows): its number, first byte and rows seen.
    open: Option<(u64, u64, usize)>,
    /// Tick numbers of the whole ticks, in file order.
    ticks: Vec<u64>,
    /// First byte of each whole tick; `end` closes the last.
    starts: Vec<u64>,
    end: u64,
    /// Lines that were not a row of the expected shape.
    pub bad_lines: u64,
}

impl TrajectoryIndex {
    /// An index of `path` for `robots` robots; nothing is read until [`Self::refresh`].
    pub fn new(path: &Path, robots: usize) -> TrajectoryIndex {
        TrajectoryIndex {
            tail: Tail::new(path),
            robots,
            cols: None,
            open: None,
            ticks: Vec::new(),
            starts: Vec::new(),
            end: 0,
            bad_lines: 0,
        }
    }

    /// Whole ticks found.
    pub fn len(&self) -> usize {
        self.ticks.len()
    }

    /// No whole tick yet.
    pub fn is_empty(&self) -> bool {
        self.ticks.is_empty()
    }

    /// Tick number of frame `i`.
    pub fn tick(&self, i: usize) -> Option<u64> {
        self.ticks.get(i).copied()
    }

    /// Frame index of tick number `tick` (the last frame at or before it).
    pub fn frame_of(&self, tick: u64) -> Option<usize> {
        match self.ticks.binary_search(&tick) {
            Ok(i) => Some(i),
            Err(0) => None,
            Err(i) => Some(i - 1),
        }
    }

    /// True when the file has bytes past the last whole tick (a torn line, or a tick being
    /// written).
    pub fn has_tail(&self) -> bool {
        self.tail.pending() || self.open.is_some()
    }

    /// Lines longer than [`crate::tail::MAX_LINE`], skipped.
    pub fn long_lines(&self) -> u64 {
        self.tail.long_lines()
    }

    /// True when the file is aerial (has a `z` column).
    pub fn aerial(&self) -> bool {
        self.cols.map(|c| c.z.is_some()).unwrap_or(false)
    }

    /// Reads what was appended since the last call; returns the number of new whole ticks.
    pub fn refresh(&mut self) -> std::io::Result<usize> {
        let before = self.ticks.len();
        let mut tail = std::mem::take(&mut self.tail);
        let read = tail.read_new(|line, offset, next| self.line(line, offset, next));
        self.tail = tail;
        read?;
        Ok(self.ticks.len() - before)
    }

    fn line(&mut self, line: &[u8], offset: u64, next: u64) {
        let Ok(text) = std::str::from_utf8(line) else {
            self.bad_lines += 1;
            return;
        };
        let Some(cols) = self.cols else {
            match Columns::from_header(text) {
                Ok(c) => self.cols = Some(c),
                Err(_) => self.bad_lines += 1,
            }
            return;
        };
        let fields = text.split(',').count();
        let tick = text
            .split(',')
            .nth(cols.tick)
            .and_then(|t| t.parse::<u64>().ok());
        let Some(tick) = tick.filter(|_| fields == cols.count) else {
            self.bad_lines += 1;
            return;
        };
        let rows = match self.open {
            Some((t, start, rows)) if t == tick => {
                self.open = Some((t, start, rows + 1));
                rows + 1
            }
            _ => {
                self.open = Some((tick, offset, 1));
                1
            }
        };
        if rows == self.robots {
            let (t, start, _) = self.open.take().expect("just set");
            if self.ticks.last().is_some_and(|&last| last >= t) {
                self.bad_lines += 1;
                return;
            }
            self.ticks.push(t);
            self.starts.push(start);
            self.end = next;
        }
    }

    fn byte_range(&self, from: usize, to: usize) -> (u64, u64) {
        let start = self.starts[from];
        let end = if to < self.starts.len() {
            self.starts[to]
        } else {
            self.end
        };
        (start, end)
    }

    /// Calls `row(fields)` for each line of frames `from..to`, read a block at a time.
    fn each_row(
        &self,
        from: usize,
        to: usize,
        mut row: impl FnMut(&[&str]),
    ) -> std::io::Result<()> {
        let (start, end) = self.byte_range(from, to);
        crate::tail::lines_in(self.tail.path(), start, end, |line| {
            let text = String::from_utf8_lossy(line);
            let fields: Vec<&str> = text.split(',').collect();
            row(&fields);
        })
    }

    /// Frames `from..to` (clamped to the whole ticks) packed for the page: the header
    /// (magic, robots, first frame, frames: four `u32`), one `u32` tick number per frame, then
    /// [`ROBOT_BYTES`] per robot per frame in id order. `role(robot, tick)` colours them.
    pub fn frames(
        &self,
        from: usize,
        to: usize,
        role: impl Fn(u32, u64) -> u8,
    ) -> std::io::Result<Vec<u8>> {
        let to = to.min(self.ticks.len());
        let from = from.min(to);
        let n = self.robots;
        let count = to - from;
        let mut out = Vec::with_capacity(16 + 4 * count + count * n * ROBOT_BYTES);
        for v in [FRAMES_MAGIC, n as u32, from as u32, count as u32] {
            out.extend_from_slice(&v.to_le_bytes());
        }
        for i in from..to {
            out.extend_from_slice(&(self.ticks[i] as u32).to_le_bytes());
        }
        let data_at = out.len();
        out.resize(data_at + count * n * ROBOT_BYTES, 0);
        if count == 0 {
            return Ok(out);
        }
        let cols = self.cols.expect("a whole tick implies a header");
        let ticks = &self.ticks[from..to];
        self.each_row(from, to, |f| {
            if f.len() != cols.count {
                return;
            }
            let (Some(id), Some(tick)) = (
                f[cols.id].parse::<usize>().ok(),
                f[cols.tick].parse::<u64>().ok(),
            ) else {
                return;
            };
            // A row belongs to the frame of its own tick: rows of a tick the index refused
            // (never whole) are skipped, not shifted into the next frame.
            let Ok(frame) = ticks.binary_search(&tick) else {
                return;
            };
            if id >= n {
                return;
            }
            let num = |k: usize| f.get(k).and_then(|v| v.parse::<f32>().ok()).unwrap_or(0.0);
            let at = data_at + (frame * n + id) * ROBOT_BYTES;
            let rec = &mut out[at..at + ROBOT_BYTES];
            rec[0..4].copy_from_slice(&num(cols.x).to_le_bytes());
            rec[4..8].copy_from_slice(&num(cols.y).to_le_bytes());
            let z = cols.z.map(num).unwrap_or(0.0);
            rec[8..12].copy_from_slice(&z.to_le_bytes());
            rec[12..16].copy_from_slice(&num(cols.theta).to_le_bytes());
            let state = f
                .get(cols.state)
                .and_then(|s| RobotState::from_name(s))
                .unwrap_or(RobotState::Active);
            rec[16] = state as u8;
            rec[17] = role(id as u32, tick);
            rec[18] = u8::from(f.get(cols.lidar) == Some(&"1"));
        })?;
        Ok(out)
    }

    /// Robot `id`'s full row at frame `i`.
    pub fn row(&self, i: usize, id: u32) -> std::io::Result<Option<FullRow>> {
        if i >= self.ticks.len() {
            return Ok(None);
        }
        let cols = self.cols.expect("a whole tick implies a header");
        let tick = self.ticks[i];
        let mut found = None;
        self.each_row(i, i + 1, |f| {
            if found.is_some()
                || f.len() != cols.count
                || f[cols.id].parse::<u32>().ok() != Some(id)
                || f[cols.tick].parse::<u64>().ok() != Some(tick)
            {
                return;
            }
            let num = |k: usize| f.get(k).and_then(|v| v.parse::<f64>().ok()).unwrap_or(0.0);
            found = Some(FullRow {
                tick,
                id,
                x: num(cols.x),
                y: num(cols.y),
                z: cols.z.map(num),
                theta: num(cols.theta),
                v: num(cols.v),
                vz: cols.vz.map(num),
                omega: num(cols.omega),
                lidar: f.get(cols.lidar) == Some(&"1"),
                state: f.get(cols.state).unwrap_or(&"").to_string(),
            });
        })?;
        Ok(found)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::io::Write;

    fn write(path: &Path, text: &str) {
        let mut f = std::fs::OpenOptions::new()
            .create(true)
            .append(true)
            .open(path)
            .unwrap();
        f.write_all(text.as_bytes()).unwrap();
    }

    #[test]
    fn whole_ticks_only_and_frames_in_id_order() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("trajectory.csv");
        write(&path, "tick,id,x,y,theta,v,omega,lidar,state\n");
        write(&path, "0,0,1.00000,2.00000,0.50000,0.1,0,1,active\n");
        write(&path, "0,1,3.00000,4.00000,0.00000,0.1,0,0,down\n1,0,1.5");
        let mut idx = TrajectoryIndex::new(&path, 2);
        idx.refresh().unwrap();
        assert_eq!(idx.len(), 1, "tick 1 is torn");
        assert!(idx.has_tail());
        write(
            &path,
            "0000,2.00000,0.50000,0.1,0,1,active\n1,1,3.00000,4.00000,0.0,0,0,0,dead\n",
        );
        assert_eq!(idx.refresh().unwrap(), 1);
        assert_eq!(idx.len(), 2);
        let frames = idx.frames(0, 10, |id, _| id as u8).unwrap();
        assert_eq!(&frames[0..4], b"SWVF");
        let u32_at = |k: usize| u32::from_le_bytes(frames[k..k + 4].try_into().unwrap());
        assert_eq!((u32_at(4), u32_at(8), u32_at(12)), (2, 0, 2));
        assert_eq!((u32_at(16), u32_at(20)), (0, 1));
        let rec = |frame: usize, id: usize| {
            let at = 24 + (frame * 2 + id) * ROBOT_BYTES;
            let f = |k: usize| f32::from_le_bytes(frames[at + k..at + k + 4].try_into().unwrap());
            (
                f(0),
                f(4),
                frames[at + 16],
                frames[at + 17],
                frames[at + 18],
            )
        };
        assert_eq!(rec(0, 0), (1.0, 2.0, 0, 0, 1));
        assert_eq!(rec(0, 1), (3.0, 4.0, RobotState::Down as u8, 1, 0));
        assert_eq!(rec(1, 0), (1.5, 2.0, 0, 0, 1));
        assert_eq!(rec(1, 1).2, RobotState::Dead as u8);
        let row = idx.row(1, 1).unwrap().unwrap();
        assert_eq!(row.state, "dead");
        assert_eq!(idx.frame_of(7), Some(1));
    }
}
