//! Where a run's metrics are computed after the run: from its records (`trajectory.csv`,
//! `events.jsonl`) and config. Both modes write identical records, so both get identical
//! metrics. Metrics every run gets are here; a behaviour's own live in its folder
//! (`agent/src/behaviours/<name>/`) and are found through the registry.

pub mod records;

use std::path::Path;

use serde_json::{Value, json};
use swarmrt_scenario::Config;

/// Names of the metrics [`from_records`] adds for this scenario (for checking `--metric`).
pub fn names(cfg: &Config) -> Vec<&'static str> {
    let mut names = vec!["steps_to_target", "energy_saving", "robots_lost"];
    if let Some(p) = swarmrt_agent::registry::plugin(&cfg.behaviour.kind) {
        names.extend(p.metric_names());
    }
    names
}

/// Metrics every run gets, plus the behaviour's own, as a JSON object to merge into
/// metrics.json.
pub fn from_records(cfg: &Config, dir: &Path) -> anyhow::Result<Value> {
    let rec = records::read(dir)?;
    let mut out = json!({
        "steps_to_target": records::steps_to_target(&rec),
        "energy_saving": records::energy_saving(&rec),
    });
    if let Some(p) = swarmrt_agent::registry::plugin(&cfg.behaviour.kind) {
        let own = p
            .metrics(cfg, &rec)
            .map_err(|(key, message)| anyhow::anyhow!("key `{key}`: {message}"))?;
        for (k, v) in own {
            out[k] = v;
        }
    }
    Ok(out)
}
