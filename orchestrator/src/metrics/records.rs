//! A run's records read back for metrics.

use std::path::Path;

use anyhow::Context;

/// One robot at one tick (a `trajectory.csv` row).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Row {
    /// Tick.
    pub tick: u64,
    /// Robot id.
    pub id: u32,
    /// x, metres.
    pub x: f64,
    /// y, metres.
    pub y: f64,
    /// Lidar on for this tick's observation.
    pub lidar: bool,
    /// Still active (not down, not dead).
    pub active: bool,
}

/// The parsed records of one run.
pub struct Records {
    /// Rows grouped by tick, in tick order; each holds every robot, in id order.
    pub ticks: Vec<Vec<Row>>,
    /// Every event line, parsed.
    pub events: Vec<serde_json::Value>,
}

impl Records {
    /// Reads `trajectory.csv` and `events.jsonl` from a run directory.
    pub fn read(dir: &Path) -> anyhow::Result<Records> {
        let csv = std::fs::read_to_string(dir.join("trajectory.csv"))
            .with_context(|| format!("reading {}", dir.join("trajectory.csv").display()))?;
        let mut ticks: Vec<Vec<Row>> = Vec::new();
        for line in csv.lines().skip(1) {
            let f: Vec<&str> = line.split(',').collect();
            if f.len() != 9 {
                continue;
            }
            let (Ok(tick), Ok(id), Ok(x), Ok(y)) =
                (f[0].parse(), f[1].parse(), f[2].parse(), f[3].parse())
            else {
                continue;
            };
            let row = Row {
                tick,
                id,
                x,
                y,
                lidar: f[7] == "1",
                active: f[8] == "active",
            };
            match ticks.last_mut() {
                Some(last) if last[0].tick == tick => last.push(row),
                _ => ticks.push(vec![row]),
            }
        }
        let events = std::fs::read_to_string(dir.join("events.jsonl"))
            .with_context(|| format!("reading {}", dir.join("events.jsonl").display()))?
            .lines()
            .filter_map(|l| serde_json::from_str(l).ok())
            .collect();
        Ok(Records { ticks, events })
    }

    /// Events of one kind (`"event"` field).
    pub fn events_of<'a>(&'a self, kind: &'a str) -> impl Iterator<Item = &'a serde_json::Value> {
        self.events.iter().filter(move |e| e["event"] == kind)
    }

    /// Tick at which the last robot that reached the target got there; `None` if none did.
    pub fn steps_to_target(&self) -> Option<u64> {
        self.events_of("reached")
            .filter_map(|e| e["tick"].as_u64())
            .max()
    }

    /// Share of lidar energy saved against every active robot having its lidar on every tick
    /// (seed 000, Fig. 7). Tick 0 is left out: every lidar starts on.
    pub fn energy_saving(&self) -> Option<f64> {
        let (mut on, mut all) = (0u64, 0u64);
        for row in self.ticks.iter().skip(1).flatten().filter(|r| r.active) {
            all += 1;
            on += row.lidar as u64;
        }
        (all > 0).then(|| 1.0 - on as f64 / all as f64)
    }
}
