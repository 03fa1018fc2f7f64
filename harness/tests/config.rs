//! `load_run_config`, the one path from a scenario file and `--set` to a config a run starts
//! from: each of its checks fails as a `ConfigError` naming the file and the key.

use std::path::{Path, PathBuf};

use swarmrt_harness::config::load_run_config;
use swarmrt_scenario::ConfigError;

const BASE: &str = r#"
[scenario]
name = "one-path"
ticks = 20
[map]
bounds = [0.0, 0.0, 10.0, 10.0]
goal = { x = 8.0, y = 2.0, radius = 1.0 }
[robots]
count = 2
"#;

/// `text` written as `name` in a directory of its own.
fn scenario(name: &str, text: &str) -> (PathBuf, PathBuf) {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!("load_run_config-{name}"));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join(format!("{name}.toml"));
    std::fs::write(&path, text).unwrap();
    (dir, path)
}

fn set(overrides: &[&str]) -> Vec<String> {
    overrides.iter().map(|s| s.to_string()).collect()
}

fn refused(name: &str, text: &str, overrides: &[&str]) -> (PathBuf, ConfigError) {
    let (dir, path) = scenario(name, text);
    let e = load_run_config(&path, &set(overrides), &dir).unwrap_err();
    (path, e)
}

#[test]
fn a_good_scenario_comes_back_resolved() {
    let (dir, path) = scenario("good", BASE);
    let cfg = load_run_config(&path, &set(&["robots.count=3"]), &dir).unwrap();
    assert_eq!(cfg.robots.count, 3);
    assert!(
        !cfg.behaviour.params.is_empty(),
        "every [behaviour] key is written: {:?}",
        cfg.behaviour
    );
}

#[test]
fn a_bad_set_names_the_override_and_its_key() {
    // Out of bounds: the file the value ends up in.
    let (path, e) = refused("bad-set", BASE, &["radio.loss=2"]);
    assert_eq!(e.file, path.display().to_string(), "{e}");
    assert_eq!(e.key, "radio.loss", "{e}");
    // Not an override at all: the override itself.
    let (_, e) = refused("no-equals", BASE, &["robots.count"]);
    assert_eq!(e.file, "--set", "{e}");
}

#[test]
fn a_bad_behaviour_parameter_names_file_and_key() {
    let (path, e) = refused("bad-behaviour", BASE, &["behaviour.nonsense=1"]);
    assert_eq!(e.file, path.display().to_string(), "{e}");
    assert!(e.key.starts_with("behaviour"), "{e}");
}

#[test]
fn a_bad_obstacle_names_file_and_key() {
    let (path, e) = refused(
        "bad-obstacle",
        BASE,
        &["map.polygons=[{points=[[1.0,1.0],[2.0,2.0],[3.0,3.0]]}]"],
    );
    assert_eq!(e.file, path.display().to_string(), "{e}");
    assert_eq!(e.key, "map.polygons[0].points", "{e}");
    assert_eq!(
        e.message,
        "expected a polygon of at least 3 distinct points, not all on one line, whose convex \
         hull has an area of at least 1e-6 m², got its 3 distinct points on one line",
        "{e}"
    );
}

#[test]
fn a_robot_program_that_does_not_exist_names_file_and_key() {
    let text = format!("{BASE}program = [\"./no-such-robot.py\"]\n");
    let (path, e) = refused("missing-program", &text, &[]);
    assert_eq!(e.file, path.display().to_string(), "{e}");
    assert_eq!(e.key, "robots.program[0]", "{e}");
    assert!(e.message.starts_with("cannot run "), "{e}");
}

#[test]
fn a_robot_program_becomes_an_absolute_path_from_cwd() {
    use std::os::unix::fs::PermissionsExt;
    let text = format!("{BASE}program = [\"./robot.sh\"]\n");
    let (dir, path) = scenario("program", &text);
    let robot = dir.join("robot.sh");
    std::fs::write(&robot, "#!/bin/sh\n").unwrap();
    std::fs::set_permissions(&robot, std::fs::Permissions::from_mode(0o755)).unwrap();
    let cfg = load_run_config(&path, &[], &dir).unwrap();
    let program = Path::new(&cfg.robots.program[0]);
    assert!(program.is_absolute(), "{program:?}");
    assert_eq!(
        program.canonicalize().unwrap(),
        robot.canonicalize().unwrap()
    );
}
