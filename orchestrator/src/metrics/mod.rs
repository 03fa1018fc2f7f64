//! Where a run's behaviour metrics are computed: from its records (`trajectory.csv`,
//! `events.jsonl`) and config, after the run. Both modes write identical records, so both get
//! identical metrics.

pub mod formation;
pub mod records;

use std::path::Path;

use serde_json::{Value, json};
use swarmrt_protocol::config::{BehaviourConfig, Config};

/// Names of the metrics [`from_records`] adds for this scenario (for checking `--metric`).
pub fn names(cfg: &Config) -> Vec<&'static str> {
    let mut names = vec!["steps_to_target", "energy_saving", "robots_lost"];
    if let BehaviourConfig::Formation(_) = &cfg.behaviour {
        names.extend(formation::NAMES);
    }
    names
}

/// Metrics every run gets, plus the behaviour's own, as a JSON object to merge into
/// metrics.json.
pub fn from_records(cfg: &Config, dir: &Path) -> anyhow::Result<Value> {
    let rec = records::Records::read(dir)?;
    let mut out = json!({
        "steps_to_target": rec.steps_to_target(),
        "energy_saving": rec.energy_saving(),
    });
    if let BehaviourConfig::Formation(_) = &cfg.behaviour {
        let f = formation::metrics(cfg, &rec);
        for (k, v) in f.as_object().into_iter().flatten() {
            out[k] = v.clone();
        }
    }
    Ok(out)
}
