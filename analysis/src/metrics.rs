//! The metrics registry: what a run's records (`trajectory.csv`, `events.jsonl`) and config
//! give after the run. Both modes write identical records, so both get identical metrics.
//! Metrics every run gets are here; a behaviour's own live in its folder
//! (`agent/src/behaviours/<name>/`) and are found through the agent's registry.

use std::collections::BTreeMap;
use std::path::Path;

use serde::Serialize;
use serde_json::Value;
use swarmrt_protocol::records::Records;
use swarmrt_scenario::Config;

/// Names of the metrics [`from_records`] adds for this scenario (for checking `--metric`).
pub fn names(cfg: &Config) -> Vec<&'static str> {
    let mut names = vec!["steps_to_target", "energy_saving", "robots_lost"];
    if let Some(p) = swarmrt_agent::registry::plugin(&cfg.behaviour.kind) {
        names.extend(p.metric_names());
    }
    names
}

/// What a run's records say (`metrics.json`'s `steps_to_target`, `energy_saving` and the
/// behaviour's own keys, side by side at the top).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct RecordMetrics {
    /// See [`steps_to_target`].
    pub steps_to_target: Option<u64>,
    /// See [`energy_saving`].
    pub energy_saving: Option<f64>,
    /// The behaviour's metrics as its registry entry names them (`flocking`,
    /// `formation_error_rms`, ...); none for a behaviour without metrics of its own.
    #[serde(flatten)]
    pub behaviour: BTreeMap<&'static str, Value>,
}

/// Metrics every run gets, plus the behaviour's own.
pub fn from_records(cfg: &Config, dir: &Path) -> anyhow::Result<RecordMetrics> {
    let rec = crate::run_dir::read(dir)?;
    let behaviour = match swarmrt_agent::registry::plugin(&cfg.behaviour.kind) {
        Some(p) => p
            .configure(cfg)
            .map_err(|(key, message)| anyhow::anyhow!("key `{key}`: {message}"))?
            .metrics(&rec)
            .into_iter()
            .collect(),
        None => BTreeMap::new(),
    };
    Ok(RecordMetrics {
        steps_to_target: steps_to_target(&rec),
        energy_saving: energy_saving(&rec),
        behaviour,
    })
}

/// Tick at which the last robot that reached the target got there; `None` if none did.
pub fn steps_to_target(rec: &Records) -> Option<u64> {
    rec.reached().map(|(tick, _)| tick).max()
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

/// The number at a dotted path of a run's `metrics.json` (`steps_to_target`,
/// `radio.dropped`, `flocking.fitness`): each segment descends into an object, and a key that
/// itself holds dots (`"flocking.fitness"` at the top) is found too. Booleans read as 0 and 1;
/// anything else (missing, null, a string, an object) is `None`.
pub fn lookup(metrics: &Value, path: &str) -> Option<f64> {
    let obj = metrics.as_object()?;
    if let Some(v) = obj.get(path) {
        return match v {
            Value::Number(n) => n.as_f64(),
            Value::Bool(b) => Some(*b as u8 as f64),
            _ => None,
        };
    }
    path.match_indices('.').find_map(|(i, _)| {
        let inner = obj.get(&path[..i]).filter(|v| v.is_object())?;
        lookup(inner, &path[i + 1..])
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    #[test]
    fn lookup_follows_dotted_paths() {
        let m = json!({
            "steps_to_target": 412,
            "radio": {"dropped": 3, "sent": 10},
            "flocking": {"fitness": 0.25},
            "a.b": 1.5,
            "reached_target": true,
            "scenario": "x",
            "energy_saving": null,
        });
        assert_eq!(lookup(&m, "steps_to_target"), Some(412.0));
        assert_eq!(lookup(&m, "radio.dropped"), Some(3.0));
        assert_eq!(lookup(&m, "flocking.fitness"), Some(0.25));
        assert_eq!(lookup(&m, "a.b"), Some(1.5));
        assert_eq!(lookup(&m, "reached_target"), Some(1.0));
        assert_eq!(lookup(&m, "scenario"), None);
        assert_eq!(lookup(&m, "energy_saving"), None);
        assert_eq!(lookup(&m, "radio"), None);
        assert_eq!(lookup(&m, "radio.nope"), None);
        assert_eq!(lookup(&m, "nope.x"), None);
    }
}
