//! `radio.csv` (the opt-in radio record, `scenario.record_radio`) read as it grows: per tick,
//! how many copies were delivered and dropped, and the copies themselves packed for the page
//! (who to whom, and what became of it).

use std::path::Path;

use serde::Serialize;

use crate::tail::Tail;

/// First four bytes of a radio response ("SWVR").
pub const RADIO_MAGIC: u32 = u32::from_le_bytes(*b"SWVR");

/// What became of a copy, as the page's outcome byte: index into this list.
pub const OUTCOMES: [&str; 9] = [
    "delivered",
    "loss",
    "out_of_range",
    "capacity",
    "line_of_sight",
    "receiver_down",
    "inbox_full",
    "partition",
    "other",
];

fn outcome_code(name: &str) -> u32 {
    OUTCOMES
        .iter()
        .position(|o| *o == name)
        .unwrap_or(OUTCOMES.len() - 1) as u32
}

#[derive(Debug, Clone, Copy)]
struct Columns {
    tick: usize,
    from: usize,
    to: usize,
    outcome: usize,
    count: usize,
}

/// Per tick delivered and dropped copies, for the page's strip.
#[derive(Debug, Clone, Default, PartialEq, Serialize)]
pub struct Strip {
    /// Tick numbers with traffic, ascending.
    pub ticks: Vec<u64>,
    /// Copies delivered at each.
    pub delivered: Vec<u32>,
    /// Copies dropped at each (any reason).
    pub dropped: Vec<u32>,
}

/// The ticks of a `radio.csv` read so far.
#[derive(Debug)]
pub struct RadioIndex {
    tail: Tail,
    cols: Option<Columns>,
    /// First byte of each tick's lines, and the byte after the last line read.
    starts: Vec<u64>,
    end: u64,
    strip: Strip,
    /// Lines that were not a radio row.
    pub bad_lines: u64,
}

impl RadioIndex {
    /// An index of `path`; nothing is read until [`Self::refresh`].
    pub fn new(path: &Path) -> RadioIndex {
        RadioIndex {
            tail: Tail::new(path),
            cols: None,
            starts: Vec::new(),
            end: 0,
            strip: Strip::default(),
            bad_lines: 0,
        }
    }

    /// Ticks with traffic read so far.
    pub fn ticks(&self) -> usize {
        self.strip.ticks.len()
    }

    /// The strip from its `from`-th tick on.
    pub fn strip_from(&self, from: usize) -> Strip {
        let from = from.min(self.strip.ticks.len());
        Strip {
            ticks: self.strip.ticks[from..].to_vec(),
            delivered: self.strip.delivered[from..].to_vec(),
            dropped: self.strip.dropped[from..].to_vec(),
        }
    }

    /// Reads the whole lines appended since the last call.
    pub fn refresh(&mut self) -> std::io::Result<()> {
        let mut tail = std::mem::take(&mut self.tail);
        let read = tail
            .read_new(|line, offset, next| self.line(&String::from_utf8_lossy(line), offset, next));
        self.tail = tail;
        read
    }

    /// Lines longer than [`crate::tail::MAX_LINE`], skipped.
    pub fn long_lines(&self) -> u64 {
        self.tail.long_lines()
    }

    /// True once the file's header was read (the run records its radio).
    pub fn recorded(&self) -> bool {
        self.cols.is_some()
    }

    fn line(&mut self, line: &str, offset: u64, next: u64) {
        let Some(cols) = self.cols else {
            let names: Vec<&str> = line.trim_end().split(',').collect();
            let at = |n: &str| names.iter().position(|c| *c == n);
            match (at("tick"), at("from"), at("to"), at("outcome")) {
                (Some(tick), Some(from), Some(to), Some(outcome)) => {
                    self.cols = Some(Columns {
                        tick,
                        from,
                        to,
                        outcome,
                        count: names.len(),
                    })
                }
                _ => self.bad_lines += 1,
            }
            return;
        };
        let f: Vec<&str> = line.split(',').collect();
        let tick = f.get(cols.tick).and_then(|t| t.parse::<u64>().ok());
        let Some(tick) = tick.filter(|_| f.len() == cols.count) else {
            self.bad_lines += 1;
            return;
        };
        let delivered = f[cols.outcome] == "delivered";
        match self.strip.ticks.last() {
            Some(&last) if last == tick => {}
            Some(&last) if last > tick => {
                self.bad_lines += 1;
                return;
            }
            _ => {
                self.strip.ticks.push(tick);
                self.strip.delivered.push(0);
                self.strip.dropped.push(0);
                self.starts.push(offset);
            }
        }
        let k = self.strip.ticks.len() - 1;
        if delivered {
            self.strip.delivered[k] += 1;
        } else {
            self.strip.dropped[k] += 1;
        }
        self.end = next;
    }

    /// The copies of ticks `from..=to` (tick numbers) packed for the page: magic, number of
    /// ticks `K` (two `u32`), then per tick its number and copy count (two `u32`), then per
    /// copy `from`, `to`, outcome (three `u32`, outcome an index into [`OUTCOMES`]).
    pub fn links(&self, from: u64, to: u64) -> std::io::Result<Vec<u8>> {
        let a = self.strip.ticks.partition_point(|&t| t < from);
        let b = self.strip.ticks.partition_point(|&t| t <= to).max(a);
        let mut out = Vec::new();
        out.extend_from_slice(&RADIO_MAGIC.to_le_bytes());
        out.extend_from_slice(&((b - a) as u32).to_le_bytes());
        if a == b {
            return Ok(out);
        }
        let cols = self.cols.expect("a tick implies a header");
        // Per tick its copies, counted here from the lines themselves so the counts always
        // match what follows (a line the index refused is left out of both).
        let ticks = &self.strip.ticks[a..b];
        let mut counts = vec![0u32; b - a];
        let mut copies: Vec<[u32; 3]> = Vec::new();
        let start = self.starts[a];
        let end = if b < self.starts.len() {
            self.starts[b]
        } else {
            self.end
        };
        let mut k = 0usize;
        crate::tail::lines_in(self.tail.path(), start, end, |line| {
            let line = String::from_utf8_lossy(line);
            let f: Vec<&str> = line.split(',').collect();
            let Some(tick) = f
                .get(cols.tick)
                .and_then(|t| t.parse::<u64>().ok())
                .filter(|_| f.len() == cols.count)
            else {
                return;
            };
            while k < ticks.len() && ticks[k] < tick {
                k += 1;
            }
            if k == ticks.len() || ticks[k] != tick {
                return;
            }
            // A copy with no receiver (a broadcast dropped for capacity before fan-out) is
            // counted in the strip but has no link to draw.
            let (Ok(src), Ok(dst)) = (f[cols.from].parse::<u32>(), f[cols.to].parse::<u32>())
            else {
                return;
            };
            counts[k] += 1;
            copies.push([src, dst, outcome_code(f[cols.outcome])]);
        })?;
        for (tick, n) in ticks.iter().zip(&counts) {
            out.extend_from_slice(&(*tick as u32).to_le_bytes());
            out.extend_from_slice(&n.to_le_bytes());
        }
        for c in copies.iter().flatten() {
            out.extend_from_slice(&c.to_le_bytes());
        }
        Ok(out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn strip_and_links_per_tick() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("radio.csv");
        std::fs::write(
            &path,
            "tick,sent_tick,from,to,bytes,outcome\n1,0,0,1,9,delivered\n1,0,1,0,9,loss\n3,2,2,0,9,partition\n4,3,0,2,9,deliv",
        )
        .unwrap();
        let mut r = RadioIndex::new(&path);
        r.refresh().unwrap();
        assert_eq!(r.strip_from(0).ticks, [1, 3]);
        assert_eq!(r.strip_from(0).delivered, [1, 0]);
        assert_eq!(r.strip_from(0).dropped, [1, 1]);
        let b = r.links(0, 3).unwrap();
        let u = |k: usize| u32::from_le_bytes(b[k * 4..k * 4 + 4].try_into().unwrap());
        assert_eq!((u(1), u(2), u(3), u(4), u(5)), (2, 1, 2, 3, 1));
        assert_eq!((u(6), u(7), u(8)), (0, 1, 0));
        assert_eq!((u(9), u(10), u(11)), (1, 0, 1));
        assert_eq!((u(12), u(13), u(14)), (2, 0, 7));
    }
}
