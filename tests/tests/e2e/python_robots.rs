//! Robots written in Python (issue 17): the package in `bindings/python` and the examples in
//! `examples/python`, run as real robot processes beside Rust ones.
//!
//! The Python messages have the Rust layout; Python go-to and flocking robots write the Rust
//! robots' records byte for byte, alone and mixed with Rust robots; a Python robot that sends
//! garbage is refused and counted, one that crashes is a death without leftovers, and frozen,
//! killed and restarted Python robots replay as Rust ones do.

use std::path::Path;
use std::process::{Command, Stdio};
use std::time::Duration;

use swarmrt_tests::python::{self, program};
use swarmrt_tests::*;

const LIMIT: Duration = Duration::from_secs(120);

/// `robots.program=<all robots run this>`.
fn all_robots(program: &str) -> String {
    format!("robots.program={program}")
}

/// `robots.programs=[{robots=<ids>, program=<this>}]`.
fn some_robots(ids: &str, program: &str) -> String {
    format!("robots.programs=[{{robots={ids:?}, program={program}}}]")
}

/// Robot `robot`'s state column at `tick` in `dir`'s trajectory.
fn state(dir: &Path, tick: u64, robot: u32) -> String {
    let csv = String::from_utf8(bytes(dir, "trajectory.csv")).unwrap();
    csv.lines()
        .find(|l| l.starts_with(&format!("{tick},{robot},")))
        .map(|l| l.rsplit(',').next().unwrap().to_string())
        .unwrap_or_else(|| panic!("no row for robot {robot} at tick {tick}"))
}

#[test]
fn the_python_messages_have_the_rust_layout() {
    // Prints what `layout_lines` prints, read from the ctypes structures themselves.
    let script = r#"
import ctypes
from swarmrt import _messages as m
for name in m.LAYOUT:
    s = getattr(m, name)
    print(f"{name} size {ctypes.sizeof(s)} align {ctypes.alignment(s)} type {s.type_name()}")
    for field, _ in s._fields_:
        if field.startswith("_pad"):
            continue
        d = getattr(s, field)
        print(f"{name}.{field} offset {d.offset} size {d.size}")
"#;
    let out = Command::new(python::python())
        .args(["-c", script])
        .stdin(Stdio::null())
        .output()
        .expect("the venv's python runs");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let have: Vec<String> = String::from_utf8(out.stdout)
        .unwrap()
        .lines()
        .map(str::to_string)
        .collect();
    assert_eq!(have, swarmrt_protocol::layout::layout_lines());
}

/// The orchestrator sends SIGCONT right after SIGTERM (a stopped robot acts on SIGTERM only
/// once continued); iceoryx2's handler keeps only the last signal, so the request was lost.
#[test]
fn a_python_robot_keeps_a_sigterm_that_a_sigcont_follows() {
    let script = r#"
import os, signal
import iceoryx2 as iox2
from swarmrt import robot
node = iox2.NodeBuilder.new().create(iox2.ServiceType.Local)
robot._note_termination_signals()
os.kill(os.getpid(), signal.SIGCONT)
print("after SIGCONT", robot._terminated)
os.kill(os.getpid(), signal.SIGTERM)
os.kill(os.getpid(), signal.SIGCONT)
print("after SIGTERM, SIGCONT", robot._terminated)
"#;
    let out = Command::new(python::python())
        .args(["-c", script])
        .stdin(Stdio::null())
        .output()
        .expect("the venv's python runs");
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert_eq!(
        stdout.lines().collect::<Vec<_>>(),
        ["after SIGCONT False", "after SIGTERM, SIGCONT True"]
    );
}

#[test]
fn the_python_package_pins_the_iceoryx2_of_cargo_lock() {
    let lock: toml::Table = std::fs::read_to_string(workspace().join("Cargo.lock"))
        .unwrap()
        .parse()
        .unwrap();
    let locked = lock["package"]
        .as_array()
        .unwrap()
        .iter()
        .find(|p| p["name"].as_str() == Some("iceoryx2"))
        .and_then(|p| p["version"].as_str())
        .expect("Cargo.lock has iceoryx2")
        .to_string();
    let project: toml::Table =
        std::fs::read_to_string(python::package_dir().join("pyproject.toml"))
            .unwrap()
            .parse()
            .unwrap();
    let deps: Vec<&str> = project["project"]["dependencies"]
        .as_array()
        .unwrap()
        .iter()
        .filter_map(|d| d.as_str())
        .filter(|d| d.starts_with("iceoryx2"))
        .collect();
    assert_eq!(deps, vec![format!("iceoryx2=={locked}")]);
    // And that is what the venv runs.
    let out = Command::new(python::python())
        .args([
            "-c",
            "import importlib.metadata as m; print(m.version('iceoryx2'))",
        ])
        .output()
        .unwrap();
    assert_eq!(String::from_utf8_lossy(&out.stdout).trim(), locked);
}

#[test]
fn python_goto_robots_write_the_rust_robots_records_alone_and_mixed() {
    let tmp = tempfile::tempdir().unwrap();
    let t = tmp.path();
    let goto = program("goto.py", &[]);
    let ticks = ["--ticks", "200"];
    let rust = run_config("configs/goto_simple.toml", &t.join("rust"), &ticks);
    assert_eq!(rust["ticks"], 200);

    let all = all_robots(&goto);
    let m = run_config(
        "configs/goto_simple.toml",
        &t.join("python"),
        &["--ticks", "200", "--set", &all],
    );
    assert_eq!(m["rejected"], 0, "{m}");
    assert_eq!(m["unscheduled_deaths"], serde_json::json!([]), "{m}");
    assert_same_records(&t.join("rust"), &t.join("python"), "all-Python goto");

    // Robots 0..4 in Python, the rest Rust: twice, the same bytes, and the Rust run's.
    let mixed = some_robots("0..4", &goto);
    for name in ["mixed-1", "mixed-2"] {
        let m = run_config(
            "configs/goto_simple.toml",
            &t.join(name),
            &["--ticks", "200", "--set", &mixed],
        );
        assert_eq!(m["rejected"], 0, "{m}");
        assert_same_records(&t.join("rust"), &t.join(name), name);
    }
}

#[test]
fn python_flocking_robots_flock_with_rust_ones_bit_for_bit() {
    let tmp = tempfile::tempdir().unwrap();
    let t = tmp.path();
    let flocking = program("flocking.py", &[]);
    let cfg = "configs/flocking_obstacles.toml";
    run_config(cfg, &t.join("rust"), &["--ticks", "300"]);
    let all = all_robots(&flocking);
    let m = run_config(cfg, &t.join("python"), &["--ticks", "300", "--set", &all]);
    assert_eq!(m["rejected"], 0, "{m}");
    assert_same_records(&t.join("rust"), &t.join("python"), "all-Python flocking");
    // Robots 0 and 1 in Python hear the Rust robots' headings and are heard by them.
    let mixed = some_robots("0..2", &flocking);
    run_config(cfg, &t.join("mixed"), &["--ticks", "300", "--set", &mixed]);
    assert_same_records(&t.join("rust"), &t.join("mixed"), "mixed flocking");
}

#[test]
fn a_python_robot_sending_garbage_is_refused_and_the_others_are_unaffected() {
    let tmp = tempfile::tempdir().unwrap();
    let t = tmp.path();
    // Robot 3 answers each tick with one of: a NaN speed, the wrong tick, a frame that is no
    // message, another robot's id.
    let bad = some_robots("3", &program("misbehave.py", &["garbage"]));
    let m = run_config(
        "configs/goto_simple.toml",
        &t.join("python"),
        &["--ticks", "60", "--set", &bad],
    );
    assert_eq!(m["ticks"], 60, "{m}");
    assert_eq!(m["rejected"], 60, "every command of robot 3: {m}");
    assert_eq!(m["shell"]["unknown_sender"], 0, "{m}");
    assert_eq!(m["unscheduled_deaths"], serde_json::json!([]), "{m}");
    let events = String::from_utf8(bytes(&t.join("python"), "events.jsonl")).unwrap();
    let mut reasons: Vec<(u64, String)> = events
        .lines()
        .map(|l| serde_json::from_str::<serde_json::Value>(l).unwrap())
        .filter(|e| e["event"] == "rejected")
        .map(|e| {
            (
                e["robot"].as_u64().unwrap(),
                e["reason"].as_str().unwrap().to_string(),
            )
        })
        .collect();
    reasons.sort();
    let want: Vec<(u64, String)> = [
        "command for another tick",
        "malformed radio frame",
        "non-finite speed",
        "robot id does not match its slot",
    ]
    .iter()
    .map(|r| (3, r.to_string()))
    .collect();
    assert_eq!(reasons, want, "each reason logged once, all for robot 3");

    // Refused commands move nothing and send nothing: the swarm is the one whose Rust robot
    // 3 sends NaN speeds, to the byte.
    let out = Command::new(swarm_bin())
        .current_dir(workspace())
        .args(["run", "configs/goto_simple.toml", "--ticks", "60", "--out"])
        .arg(t.join("rust"))
        .env("SWARMRT_TEST_MISBEHAVE", "3:nan")
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    assert_ok(&wait_with_watchdog(out, LIMIT));
    assert!(
        bytes(&t.join("python"), "trajectory.csv") == bytes(&t.join("rust"), "trajectory.csv"),
        "the other robots moved as beside a Rust robot whose commands are all refused"
    );
}

#[test]
fn a_crashing_python_robot_is_a_death_not_a_hang_or_a_leak() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("run");
    let crash = some_robots("3", &program("misbehave.py", &["crash:20"]));
    let m = run_config(
        "configs/goto_simple.toml",
        &dir,
        &["--ticks", "60", "--set", &crash],
    );
    assert_eq!(m["ticks"], 60, "the run went on: {m}");
    assert_eq!(m["dead"], 1, "{m}");
    assert_eq!(m["unscheduled_deaths"][0]["robot"], 3, "{m}");
    assert_eq!(
        m["unscheduled_deaths"][0]["how"], "exited with code 1",
        "an uncaught Python exception: {m}"
    );
    assert_eq!(m["reproducible"], false, "{m}");
    assert_eq!(state(&dir, 19, 3), "active");
    assert_eq!(state(&dir, 59, 3), "dead");
    let run_id = m["run_id"].as_str().expect("metrics.json has run_id");
    assert!(leftovers(run_id).is_empty(), "{:?}", leftovers(run_id));
}

#[test]
fn a_hung_python_robot_is_given_up_killed_and_cleaned_up() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("run");
    // Robot 3 thinks for a minute on its first tick: a hang.
    let hang = some_robots("3", &program("misbehave.py", &["slow:60000"]));
    // The clock starts after the binaries are built (a `-p` test run rebuilds them).
    swarmrt_tests::bin_dir();
    let started = std::time::Instant::now();
    let m = run_config(
        "configs/goto_simple.toml",
        &dir,
        &[
            "--ticks",
            "40",
            "--set",
            &hang,
            "--set",
            "scenario.deadline_ms=300",
            "--set",
            "scenario.unresponsive_ms=1500",
        ],
    );
    assert!(
        started.elapsed() < std::time::Duration::from_secs(50),
        "no waiting out the hang"
    );
    assert_eq!(m["ticks"], 40, "the run went on: {m}");
    assert_eq!(m["dead"], 1, "{m}");
    assert_eq!(m["unscheduled_deaths"][0]["robot"], 3, "{m}");
    assert_eq!(m["reproducible"], false, "{m}");
    assert_eq!(state(&dir, 39, 3), "dead");
    let procs = processes_of(&m, 3);
    assert!(procs[0].1.contains("signal 9"), "{procs:?}");
    let run_id = m["run_id"].as_str().expect("metrics.json has run_id");
    assert!(leftovers(run_id).is_empty(), "{:?}", leftovers(run_id));
}

#[test]
fn frozen_killed_and_restarted_python_robots_replay_as_rust_ones() {
    let tmp = tempfile::tempdir().unwrap();
    let t = tmp.path();
    let faults = [
        "--ticks",
        "150",
        "--set",
        "faults.freeze=[{robot=3,from=30,to=60}]",
        "--set",
        "faults.kill=[{tick=80,robot=5}]",
        "--set",
        "faults.restart=[{tick=90,robot=6,down_ticks=10}]",
    ];
    run_config("configs/goto_simple.toml", &t.join("rust"), &faults);
    let all = all_robots(&program("goto.py", &[]));
    let mut args = faults.to_vec();
    args.extend_from_slice(&["--set", &all]);
    let m = run_config("configs/goto_simple.toml", &t.join("python"), &args);
    assert_same_records(&t.join("rust"), &t.join("python"), "faulted Python goto");
    assert_eq!(m["reproducible"], true, "{m}");
    assert_eq!(m["unscheduled_deaths"], serde_json::json!([]), "{m}");
    assert_eq!(m["frozen_ticks"], 30, "{m}");
    let dir = t.join("python");
    // The thawed robot skipped the frozen ticks, answered again and saw the shutdown.
    assert_eq!(state(&dir, 29, 3), "active");
    assert_eq!(state(&dir, 30, 3), "frozen");
    assert_eq!(state(&dir, 59, 3), "frozen");
    assert_eq!(state(&dir, 60, 3), "active");
    assert_eq!(
        processes_of(&m, 3),
        vec![(0, "exited with code 0".to_string(), false)]
    );
    assert_eq!(state(&dir, 80, 5), "dead");
    assert_eq!(
        processes_of(&m, 5),
        vec![(0, "killed by signal 9".to_string(), true)]
    );
    // A fresh Python process (incarnation 1) took robot 6 over.
    assert_eq!(
        processes_of(&m, 6),
        vec![
            (0, "killed by signal 9".to_string(), true),
            (1, "exited with code 0".to_string(), false)
        ]
    );
    assert_eq!(state(&dir, 100, 6), "active");
}
