//! A run's records read back for metrics (the schema is `swarmrt_protocol::records`).

use std::path::Path;

use anyhow::Context;
use swarmrt_protocol::records::Records;

/// Reads `trajectory.csv` and `events.jsonl` from a run directory.
pub fn read(dir: &Path) -> anyhow::Result<Records> {
    let text = |name: &str| {
        std::fs::read_to_string(dir.join(name))
            .with_context(|| format!("reading {}", dir.join(name).display()))
    };
    Records::parse(&text("trajectory.csv")?, &text("events.jsonl")?).map_err(anyhow::Error::msg)
}

/// Tick at which the last robot that reached the target got there; `None` if none did.
pub fn steps_to_target(rec: &Records) -> Option<u64> {
    rec.events_of("reached")
        .filter_map(|e| e["tick"].as_u64())
        .max()
}

/// Share of lidar energy saved against every active robot having its lidar on every tick
/// (seed 000, Fig. 7). Tick 0 is left out: every lidar starts on.
pub fn energy_saving(rec: &Records) -> Option<f64> {
    let (mut on, mut all) = (0u64, 0u64);
    for row in rec.ticks.iter().skip(1).flatten().filter(|r| r.active) {
        all += 1;
        on += row.lidar as u64;
    }
    (all > 0).then(|| 1.0 - on as f64 / all as f64)
}
