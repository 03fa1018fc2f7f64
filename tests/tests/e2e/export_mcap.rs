//! `swarm export --mcap`: a real run written as MCAP and read back by the PyPI `mcap` package
//! (`tests/scripts/read_mcap.py`, in the tests' venv): channels and schemas, messages per
//! topic against the run's records, a robot's pose against `trajectory.csv`, a killed robot's
//! state and death; a torn run exported up to its last whole tick; a directory that is not a
//! run refused in one line.

use std::collections::BTreeMap;
use std::path::Path;
use std::process::Command;
use std::time::Duration;

use serde_json::Value;
use swarmrt_tests::{assert_ok, python::python, run_config, swarm, workspace};

const LIMIT: Duration = Duration::from_secs(120);
const CONFIG: &str = "configs/flocking_crossing.toml";
/// The robot and tick whose pose is compared.
const ROBOT: u32 = 3;
const TICK: u64 = 37;
/// The robot killed at tick 20.
const KILLED: u32 = 5;

/// `read_mcap.py <file> <robot> <tick>`'s JSON.
fn read_with_python(file: &Path, robot: u32, tick: u64) -> Value {
    let script = workspace().join("tests/scripts/read_mcap.py");
    let out = Command::new(python())
        .arg(&script)
        .arg(file)
        .arg(robot.to_string())
        .arg(tick.to_string())
        .env("PYTHONDONTWRITEBYTECODE", "1")
        .output()
        .expect("python starts");
    assert!(
        out.status.success(),
        "read_mcap.py failed ({}):\n{}",
        out.status,
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).unwrap_or_else(|e| {
        panic!(
            "read_mcap.py printed no JSON ({e}):\n{}",
            String::from_utf8_lossy(&out.stdout)
        )
    })
}

/// `trajectory.csv` as (tick, id) -> the row's fields by column name.
fn trajectory(dir: &Path) -> BTreeMap<(u64, u32), BTreeMap<String, String>> {
    let text = std::fs::read_to_string(dir.join("trajectory.csv")).unwrap();
    let mut lines = text.lines();
    let header: Vec<String> = lines
        .next()
        .unwrap()
        .split(',')
        .map(str::to_string)
        .collect();
    lines
        .map(|l| {
            let row: BTreeMap<String, String> = header
                .iter()
                .cloned()
                .zip(l.split(',').map(str::to_string))
                .collect();
            (
                (row["tick"].parse().unwrap(), row["id"].parse().unwrap()),
                row,
            )
        })
        .collect()
}

/// The difference of two angles, wrapped to [-pi, pi].
fn angle_diff(a: f64, b: f64) -> f64 {
    let d = (a - b).rem_euclid(std::f64::consts::TAU);
    if d > std::f64::consts::PI {
        d - std::f64::consts::TAU
    } else {
        d
    }
}

fn export(run: &Path, file: &Path) -> std::process::Output {
    swarm(
        &[
            "export",
            run.to_str().unwrap(),
            "--mcap",
            file.to_str().unwrap(),
        ],
        LIMIT,
    )
}

#[test]
fn a_run_exported_as_mcap_reads_back_in_python() {
    let tmp = tempfile::tempdir().unwrap();
    let run = tmp.path().join("run");
    // Robot KILLED is killed at tick 20: its fault and death are events, and it is dead at
    // TICK.
    let kill = format!("faults.kill=[{{tick = 20, robot = {KILLED}}}]");
    run_config(CONFIG, &run, &["--ticks", "60", "--set", &kill]);
    let file = tmp.path().join("run.mcap");
    let out = export(&run, &file);
    assert_ok(&out);
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        stdout.starts_with(&format!("wrote {}", file.display())),
        "{stdout}"
    );
    assert!(
        out.stderr.is_empty(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );

    let rows = trajectory(&run);
    let ticks: std::collections::BTreeSet<u64> = rows.keys().map(|(t, _)| *t).collect();
    let events = std::fs::read_to_string(run.join("events.jsonl")).unwrap();
    let n_events = events.lines().filter(|l| !l.trim().is_empty()).count();
    assert!(ticks.contains(&TICK), "the run has no tick {TICK}");

    let got = read_with_python(&file, ROBOT, TICK);
    println!("read_mcap.py: {got:#}");
    let channels: Vec<(&str, &str, &str, &str)> = got["channels"]
        .as_array()
        .unwrap()
        .iter()
        .map(|c| {
            (
                c["topic"].as_str().unwrap(),
                c["schema"].as_str().unwrap(),
                c["schema_encoding"].as_str().unwrap(),
                c["message_encoding"].as_str().unwrap(),
            )
        })
        .collect();
    assert_eq!(
        channels,
        [
            ("/scene/map", "foxglove.SceneUpdate", "jsonschema", "json"),
            (
                "/scene/robots",
                "foxglove.SceneUpdate",
                "jsonschema",
                "json"
            ),
            ("/tf", "foxglove.FrameTransforms", "jsonschema", "json"),
            ("/events", "foxglove.Log", "jsonschema", "json"),
        ]
    );
    let count = |topic: &str| got["counts"][topic].as_u64().unwrap_or(0) as usize;
    assert_eq!(count("/scene/map"), 1);
    assert_eq!(count("/scene/robots"), ticks.len());
    assert_eq!(count("/tf"), ticks.len());
    assert_eq!(count("/events"), n_events);
    assert_eq!(
        got["statistics_messages"].as_u64().unwrap() as usize,
        1 + 2 * ticks.len() + n_events
    );
    assert_eq!(got["in_time_order"], true);
    assert_eq!(got["attachments"], serde_json::json!(["config.toml"]));
    assert_eq!(got["metadata"]["swarmrt"]["scenario"], "flocking_crossing");

    // Robot ROBOT at tick TICK, as trajectory.csv has it.
    let row = &rows[&(TICK, ROBOT)];
    let f = |k: &str| row[k].parse::<f64>().unwrap();
    let pose = &got["pose"];
    assert_eq!(pose["parent"], "world", "{pose}");
    let p = |k: &str| {
        pose[k]
            .as_f64()
            .unwrap_or_else(|| panic!("no pose {k}: {got}"))
    };
    assert!((p("x") - f("x")).abs() < 1e-5, "x {pose} vs {row:?}");
    assert!((p("y") - f("y")).abs() < 1e-5, "y {pose} vs {row:?}");
    assert!(
        angle_diff(p("yaw"), f("theta")).abs() < 1e-5,
        "heading {pose} vs {row:?}"
    );
    let dt = got["metadata"]["swarmrt"]["dt"]
        .as_str()
        .unwrap()
        .parse::<f64>()
        .unwrap();
    assert_eq!(
        pose["log_time_ns"].as_u64(),
        Some((TICK as f64 * dt * 1e9).round() as u64)
    );
    let entity = &got["robot_entity"];
    assert_eq!(entity["state"], row["state"].as_str(), "{entity}");
    assert!((entity["x"].as_f64().unwrap() - f("x")).abs() < 1e-5);

    // The killed robot: dead, in another colour than the active one, and its death a warning
    // that names it.
    assert_eq!(entity["state"], "active", "{entity}");
    let dead = read_with_python(&file, KILLED, TICK);
    assert_eq!(dead["robot_entity"]["state"], "dead", "{dead}");
    assert_ne!(dead["robot_entity"]["color"], entity["color"]);
    let first = &got["events"]["first_warning"];
    assert_eq!(first["name"], format!("robot_{KILLED}"), "{first}");
    assert!(
        first["message"]
            .as_str()
            .unwrap()
            .contains(&format!("robot {KILLED}")),
        "{first}"
    );
    assert!(n_events >= 2, "{events}");

    // Warnings in the log are collisions, deaths and rejected commands.
    let warnings = events
        .lines()
        .filter(|l| {
            ["collision", "died", "rejected"]
                .iter()
                .any(|k| l.contains(&format!("\"event\":\"{k}\"")))
        })
        .count();
    assert_eq!(
        got["events"]["levels"]["3"].as_u64().unwrap_or(0) as usize,
        warnings,
        "{}",
        got["events"]
    );

    // The same run gives the same bytes.
    let again = tmp.path().join("again.mcap");
    assert_ok(&export(&run, &again));
    assert!(std::fs::read(&file).unwrap() == std::fs::read(&again).unwrap());

    // A crashed run's torn last line: exported up to the last whole tick, said on stderr.
    let torn = tmp.path().join("torn");
    std::fs::create_dir(&torn).unwrap();
    for name in ["config.toml", "events.jsonl", "metrics.json"] {
        std::fs::copy(run.join(name), torn.join(name)).unwrap();
    }
    let text = std::fs::read_to_string(run.join("trajectory.csv")).unwrap();
    std::fs::write(torn.join("trajectory.csv"), &text[..text.len() - 12]).unwrap();
    let out = export(&torn, &tmp.path().join("torn.mcap"));
    assert_ok(&out);
    let err = String::from_utf8_lossy(&out.stderr);
    let last = *ticks.last().unwrap();
    assert!(err.contains(&format!("up to tick {}", last - 1)), "{err}");
    let got = read_with_python(&tmp.path().join("torn.mcap"), ROBOT, TICK);
    assert_eq!(
        got["counts"]["/tf"].as_u64().unwrap() as usize,
        ticks.len() - 1
    );
}

#[test]
fn a_directory_that_is_not_a_run_is_refused_in_one_line() {
    let tmp = tempfile::tempdir().unwrap();
    let file = tmp.path().join("x.mcap");
    for dir in [tmp.path().to_path_buf(), tmp.path().join("missing")] {
        let out = export(&dir, &file);
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{err}");
        assert_eq!(err.trim().lines().count(), 1, "one line: {err}");
        assert!(err.contains(dir.to_str().unwrap()), "{err}");
        assert!(!err.contains("panicked"), "{err}");
    }
    assert!(!file.exists());
}

/// c0b8b90: `--mcap RUN/trajectory.csv` overwrote the run's own record, and a link planted
/// at the `--mcap` name was replaced. Now both are refused in one line and left as they were.
#[test]
fn an_export_onto_the_runs_own_file_or_a_planted_link_is_refused() {
    let tmp = tempfile::tempdir().unwrap();
    let run = tmp.path().join("run");
    run_config(
        "configs/goto_simple.toml",
        &run,
        &["--ticks", "5", "--in-process"],
    );
    for name in [
        "trajectory.csv",
        "events.jsonl",
        "config.toml",
        "metrics.json",
    ] {
        let target = run.join(name);
        let before = std::fs::read(&target).unwrap();
        let out = export(&run, &target);
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{name}: {err}");
        assert!(
            err.contains(&format!("that is the run's own {name}")),
            "{err}"
        );
        assert_eq!(err.trim().lines().count(), 1, "one line: {err}");
        assert_eq!(std::fs::read(&target).unwrap(), before, "{name} changed");
    }
    // A hard link elsewhere to a record is the same file: refused too.
    let alias = tmp.path().join("alias.mcap");
    std::fs::hard_link(run.join("trajectory.csv"), &alias).unwrap();
    assert_eq!(export(&run, &alias).status.code(), Some(2));
    // A symbolic link planted at the export's name: refused, neither it nor its target changed.
    let victim = tmp.path().join("victim");
    std::fs::write(&victim, "keep").unwrap();
    let planted = tmp.path().join("planted.mcap");
    std::os::unix::fs::symlink(&victim, &planted).unwrap();
    let out = export(&run, &planted);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(
        err.contains("is a symbolic link; refusing to follow it"),
        "{err}"
    );
    assert!(std::fs::symlink_metadata(&planted).unwrap().is_symlink());
    assert_eq!(std::fs::read_to_string(&victim).unwrap(), "keep");
    // And an ordinary new file is written.
    assert_ok(&export(&run, &tmp.path().join("ok.mcap")));
}
