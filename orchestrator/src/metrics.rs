//! `metrics.json`: what a run reports, as one struct serialised once ([`Metrics::to_json`]).
//!
//! Each section is typed by the crate that computes it: the world's counters by
//! `swarmrt_world`, the consensus section by the checker (`swarmrt_harness::consensus_check`), what the
//! records say by `swarmrt_analysis` (a behaviour's own metrics as its registry entry names
//! them). The file's keys are sorted at every level, as they always have been (serde_json's
//! map orders by key), so the field order here follows the run, not the file.

use serde::{Deserialize, Serialize};
use serde_json::Value;
use swarmrt_analysis::metrics::RecordMetrics;
use swarmrt_harness::consensus_check::ConsensusReport;
use swarmrt_world::WorldMetrics;

use crate::processes::RobotProcess;

/// The whole of `metrics.json`.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Metrics {
    /// What was asked for.
    #[serde(flatten)]
    pub run: RunHeader,
    /// The world's report, when it made one (not when it died or the run failed early).
    #[serde(flatten)]
    pub world: Option<WorldSection>,
    /// Ticks the records hold when no world report says (a failed run's, trimmed to its last
    /// whole tick); see [`Metrics::set_ticks`].
    #[serde(skip_serializing_if = "Option::is_none")]
    ticks: Option<u64>,
    /// How the run ended; absent for a run that failed before it did.
    #[serde(flatten)]
    pub ended: Option<Ended>,
    /// The run failed (its records stop at the last whole tick).
    pub failed: bool,
    /// Why, when it failed.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub failure: Option<String>,
    /// Wall-clock seconds from the start of the run, start-up included.
    pub wall_seconds: f64,
}

/// The run as asked for, known before it starts.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct RunHeader {
    /// `scenario.name`.
    pub scenario: String,
    /// `scenario.seed`.
    pub seed: u64,
    /// How it ran.
    pub mode: Mode,
    /// `robots.count`.
    pub agents: u32,
}

/// How a run ran (`swarm run` with `--in-process`, `--realtime` or neither).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Mode {
    /// Lock-step, one process per robot.
    Processes,
    /// By the wall clock, one process per robot.
    Realtime,
    /// Lock-step, world and robots in this process.
    InProcess,
}

/// The world's final report: its counters and, from a world process, the shell's own.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct WorldSection {
    /// Ticks, contacts, radio, faults, ... (`swarmrt_world`).
    #[serde(flatten)]
    pub metrics: WorldMetrics,
    /// The world process's own counters and timing (wall clock; `swarmrt_runtime` types
    /// them), forwarded as it reported them; absent in process.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub shell: Option<Value>,
}

/// What a run that ran to its end (or was stopped) reports besides the world's counters.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Ended {
    /// Stopped early (Ctrl-C or a Stop).
    pub interrupted: bool,
    /// The same config and seed give the same records.
    pub reproducible: bool,
    /// Ticks over `wall_seconds`.
    pub ticks_per_second: f64,
    /// Robots whose process is gone, by the schedule or by a crash (the world's `dead`).
    pub robots_lost: u32,
    /// What the supervisor saw of the processes (not in process).
    #[serde(flatten)]
    pub processes: Option<ProcessSection>,
    /// From the records, when they could be read.
    #[serde(flatten)]
    pub records: Option<RecordMetrics>,
    /// The consensus checker's findings (with `[consensus]`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub consensus: Option<ConsensusReport>,
}

/// What the supervisor learned about a run's processes.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ProcessSection {
    /// The run id naming its iceoryx2 resources.
    pub run_id: String,
    /// Milliseconds from the world listening until every robot said hello (`null`: never).
    pub startup_ms: Option<u64>,
    /// Every robot process, in start order.
    pub processes: Vec<RobotProcess>,
    /// Robots whose process ended before the run did.
    pub unscheduled_deaths: Vec<UnscheduledDeath>,
    /// Each remote host's counters, by name (`--hosts` runs).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub hosts: Option<Value>,
    /// What the link between hosts trusted (`--hosts` runs; docs/security.md).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub link: Option<Link>,
}

/// A robot whose process ended before the run did.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct UnscheduledDeath {
    /// The robot.
    pub robot: u32,
    /// How its process ended.
    pub how: String,
}

/// The link between the world and its hosts.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub enum Link {
    /// Plain TCP, asked for with `--insecure-link`.
    #[serde(rename = "tcp (insecure)")]
    InsecureTcp,
    /// Mutual TLS with the run's certificates.
    #[serde(rename = "mutual tls")]
    MutualTls,
}

impl Metrics {
    /// A run that ended (or was stopped), before anything is read back from its records.
    pub fn ended(run: RunHeader, world: Option<WorldSection>, ended: Ended, wall: f64) -> Self {
        Metrics {
            run,
            world,
            ticks: None,
            ended: Some(ended),
            failed: false,
            failure: None,
            wall_seconds: wall,
        }
    }

    /// A run that failed before it ended: what was asked, why, and the ticks it recorded.
    pub fn failed_early(run: RunHeader, failure: String, ticks: u64, wall: f64) -> Self {
        Metrics {
            run,
            world: None,
            ticks: Some(ticks),
            ended: None,
            failed: true,
            failure: Some(failure),
            wall_seconds: wall,
        }
    }

    /// The ticks the run stepped: the world's count, or the records' without a world report.
    pub fn ticks(&self) -> Option<u64> {
        self.world.as_ref().map(|w| w.metrics.ticks).or(self.ticks)
    }

    /// Sets the ticks (the records were trimmed to their last whole tick): in the world's
    /// report when there is one, so the file holds the key once.
    pub fn set_ticks(&mut self, ticks: u64) {
        match &mut self.world {
            Some(w) => w.metrics.ticks = ticks,
            None => self.ticks = Some(ticks),
        }
    }

    /// The text of `metrics.json`: pretty JSON, keys sorted at every level, one newline.
    pub fn to_json(&self) -> serde_json::Result<String> {
        // Through one `Value`, whose maps order by key: the file's order since the first run.
        Ok(serde_json::to_string_pretty(&serde_json::to_value(self)?)? + "\n")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn header() -> RunHeader {
        RunHeader {
            scenario: "s".to_string(),
            seed: 7,
            mode: Mode::InProcess,
            agents: 2,
        }
    }

    #[test]
    fn a_run_that_failed_early_says_what_was_asked_why_and_its_ticks_only() {
        let m = Metrics::failed_early(header(), "disk full".to_string(), 12, 0.5);
        assert_eq!(
            m.to_json().unwrap(),
            "{\n  \"agents\": 2,\n  \"failed\": true,\n  \"failure\": \"disk full\",\n  \
             \"mode\": \"in-process\",\n  \"scenario\": \"s\",\n  \"seed\": 7,\n  \
             \"ticks\": 12,\n  \"wall_seconds\": 0.5\n}\n"
        );
    }

    #[test]
    fn trimmed_ticks_land_in_the_world_report_so_the_key_is_written_once() {
        let world = WorldSection {
            metrics: WorldMetrics {
                ticks: 40,
                ..WorldMetrics::default()
            },
            shell: None,
        };
        let ended = Ended {
            interrupted: false,
            reproducible: true,
            ticks_per_second: 80.0,
            robots_lost: 0,
            processes: None,
            records: None,
            consensus: None,
        };
        let mut m = Metrics::ended(header(), Some(world), ended, 0.5);
        m.set_ticks(31);
        assert_eq!(m.ticks(), Some(31));
        let text = m.to_json().unwrap();
        assert_eq!(text.matches("\"ticks\"").count(), 1, "{text}");
        let v: Value = serde_json::from_str(&text).unwrap();
        assert_eq!(v["ticks"], 31);
        assert_eq!(v["radio"]["sent"], 0, "the world's sections, flattened");
    }

    #[test]
    fn a_world_process_report_reads_back_as_it_was_written() {
        let mut world = serde_json::to_value(WorldMetrics::default()).unwrap();
        world["shell"] = serde_json::json!({"late": 3});
        let section: WorldSection = serde_json::from_value(world.clone()).unwrap();
        assert_eq!(section.shell, Some(serde_json::json!({"late": 3})));
        assert_eq!(serde_json::to_value(&section).unwrap(), world);
    }
}
