//! Records change only on purpose: every config in `configs/`, in both modes, with a clean and
//! a lossy, delayed, jittery radio (and the README's fault mix on the Raft scenario), must
//! write exactly the `trajectory.csv`, `events.jsonl` and resolved `config.toml` whose hashes
//! are checked in under `tests/golden/`, and the same `metrics.json` apart from wall-clock keys.
//!
//! A change that alters a record on purpose regenerates the hashes with
//! `SWARMRT_UPDATE_PINS=1 cargo test -p swarmrt-tests --test e2e records_pinned::` and says
//! why in its commit; the diff of `tests/golden/` then shows exactly which runs changed.

use std::path::{Path, PathBuf};
use std::time::Duration;

use swarmrt_tests::{assert_ok, bytes, swarm, workspace};

const LIMIT: Duration = Duration::from_secs(300);

/// Runs longer than this are cut here: enough ticks for every scenario's events (the Raft
/// leader kill at 200, proposals, epsilon flips) while keeping the test to seconds a run.
const MAX_TICKS: u64 = 900;

/// Radio settings each config runs with, as `--set` overrides.
const RADIOS: &[(&str, &[&str])] = &[
    ("clean", &[]),
    (
        "lossy",
        &[
            "radio.loss=0.3",
            "radio.delay_ticks=3",
            "radio.jitter_ticks=2",
        ],
    ),
];

/// The README's fault example (freeze, restart of the leader, random kills and freezes).
const FAULTS: &[&str] = &[
    "faults.freeze=[{robot=3,from=100,to=150}]",
    "faults.restart=[{tick=400,robot=\"leader\",down_ticks=10}]",
    "faults.kill_rate=0.0005",
    "faults.freeze_rate=0.002",
];

/// Keys of `metrics.json` that depend on the wall clock or the machine, never on the seed.
const WALL_CLOCK_KEYS: &[&str] = &[
    "wall_seconds",
    "ticks_per_second",
    "run_id",
    "startup_ms",
    "processes",
    "shell",
];

fn config_ticks(config: &str) -> u64 {
    let text = std::fs::read_to_string(workspace().join(config)).unwrap();
    let value: toml::Value = toml::from_str(&text).unwrap();
    value["scenario"]["ticks"].as_integer().unwrap() as u64
}

fn sha1(data: &[u8]) -> String {
    sha1_smol::Sha1::from(data).digest().to_string()
}

/// `metrics.json` without its wall-clock keys, as canonical JSON (keys sorted).
fn seeded_metrics(dir: &Path) -> String {
    let text = std::fs::read_to_string(dir.join("metrics.json")).unwrap();
    let mut value: serde_json::Value = serde_json::from_str(&text).unwrap();
    let map = value.as_object_mut().unwrap();
    for key in WALL_CLOCK_KEYS {
        map.remove(*key);
    }
    // The planner re-times its plan after the run (metrics only, never a record).
    if let Some(planner) = map.get_mut("planner").and_then(|p| p.as_object_mut()) {
        planner.remove("plan_ms");
    }
    serde_json::to_string(&value).unwrap()
}

/// Runs one case and returns its lines for the golden file: `<case> <file> <sha1>`.
fn run_case(
    tmp: &Path,
    config: &str,
    case: &str,
    sets: &[&str],
    in_process: bool,
    max_ticks: u64,
) -> Vec<String> {
    let dir: PathBuf = tmp.join(case);
    let ticks = config_ticks(config).min(max_ticks).to_string();
    let mut args = vec![
        "run",
        config,
        "--ticks",
        &ticks,
        "--out",
        dir.to_str().unwrap(),
    ];
    for s in sets {
        args.extend(["--set", s]);
    }
    if in_process {
        args.push("--in-process");
    }
    assert_ok(&swarm(&args, LIMIT));
    vec![
        format!("{case} config.toml {}", sha1(&bytes(&dir, "config.toml"))),
        format!(
            "{case} trajectory.csv {}",
            sha1(&bytes(&dir, "trajectory.csv"))
        ),
        format!("{case} events.jsonl {}", sha1(&bytes(&dir, "events.jsonl"))),
        format!(
            "{case} metrics.json {}",
            sha1(seeded_metrics(&dir).as_bytes())
        ),
    ]
}

/// Runs every case of `name` (a file in `configs/`) and compares with `tests/golden/<name>.txt`.
fn check(name: &str, with_faults: bool) {
    check_ticks(name, with_faults, MAX_TICKS)
}

/// [`check`] cut at `max_ticks`: for the hundreds-of-robots scenarios, whose first ticks
/// already exercise every rule (a debug build steps 451 robot processes at a few ticks/s).
fn check_ticks(name: &str, with_faults: bool, max_ticks: u64) {
    let config = format!("configs/{name}.toml");
    let tmp = tempfile::tempdir().unwrap();
    let mut variants: Vec<(String, Vec<&str>)> = RADIOS
        .iter()
        .map(|(radio, sets)| (radio.to_string(), sets.to_vec()))
        .collect();
    if with_faults {
        let mut sets = RADIOS[1].1.to_vec();
        sets.extend_from_slice(FAULTS);
        variants.push(("lossy+faults".to_string(), sets));
    }
    let mut lines = Vec::new();
    for (variant, sets) in &variants {
        for (mode, in_process) in [("processes", false), ("in-process", true)] {
            let case = format!("{variant}/{mode}");
            lines.extend(run_case(
                tmp.path(),
                &config,
                &case,
                sets,
                in_process,
                max_ticks,
            ));
        }
    }
    let got = lines.join("\n") + "\n";
    let golden = workspace().join("tests/golden").join(format!("{name}.txt"));
    if std::env::var_os("SWARMRT_UPDATE_PINS").is_some() {
        std::fs::create_dir_all(golden.parent().unwrap()).unwrap();
        std::fs::write(&golden, &got).unwrap();
        return;
    }
    let want = std::fs::read_to_string(&golden).unwrap_or_else(|e| {
        panic!(
            "{}: {e} (create it with SWARMRT_UPDATE_PINS=1)",
            golden.display()
        )
    });
    let differ: Vec<String> = want
        .lines()
        .zip(got.lines())
        .filter(|(w, g)| w != g)
        .map(|(w, g)| format!("  pinned {w}\n  now    {g}"))
        .collect();
    assert!(
        differ.is_empty() && want.lines().count() == got.lines().count(),
        "records of {config} changed:\n{}\n(if that is the point of the change, regenerate with \
         SWARMRT_UPDATE_PINS=1 and say why in the commit)",
        differ.join("\n")
    );
}

#[test]
fn goto_simple() {
    check("goto_simple", false);
}

#[test]
fn formation_simple() {
    check("formation_simple", false);
}

#[test]
fn formation_complex() {
    check("formation_complex", false);
}

#[test]
fn formation_deadlock() {
    check("formation_deadlock", false);
}

#[test]
fn quadrant_leader() {
    check("quadrant_leader", false);
}

#[test]
fn grouping_s1() {
    check("grouping_s1", false);
}

#[test]
fn grouping_s2() {
    check("grouping_s2", false);
}

#[test]
fn grouping_s3() {
    check("grouping_s3", false);
}

#[test]
fn grouping_s4() {
    check("grouping_s4", false);
}

#[test]
fn flocking_obstacles() {
    check("flocking_obstacles", false);
}

#[test]
fn flocking_crossing() {
    check("flocking_crossing", false);
}

#[test]
fn flocking_calibrated() {
    check("flocking_calibrated", false);
}

#[test]
fn flocking_pso() {
    check("flocking_pso", false);
}

#[test]
fn planner_uav3() {
    check("planner_uav3", false);
}

#[test]
fn planner_uav3_leader_dies() {
    check("planner_uav3_leader_dies", false);
}

#[test]
fn chain_corridor() {
    check("chain_corridor", false);
}

#[test]
fn chain_stationary() {
    check("chain_stationary", false);
}

#[test]
fn chain_middle() {
    check("chain_middle", false);
}

#[test]
fn chain_snake_140() {
    check_ticks("chain_snake_140", false, 300);
}

#[test]
fn chain_450() {
    check_ticks("chain_450", false, 100);
}

#[test]
fn raft_election() {
    check("raft_election", true);
}

/// Every config in `configs/` has a test above, so a new scenario cannot go unpinned.
#[test]
fn every_config_is_pinned() {
    let mut names: Vec<String> = std::fs::read_dir(workspace().join("configs"))
        .unwrap()
        .flatten()
        .filter_map(|e| {
            e.file_name()
                .to_str()?
                .strip_suffix(".toml")
                .map(str::to_string)
        })
        .collect();
    names.sort();
    let source = include_str!("records_pinned.rs");
    for name in names {
        assert!(
            source.contains(&format!("check(\"{name}\""))
                || source.contains(&format!("check_ticks(\"{name}\"")),
            "configs/{name}.toml has no pinned-records test in tests/tests/e2e/records_pinned.rs"
        );
    }
}
