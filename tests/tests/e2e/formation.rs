//! The seed 000 formation end to end: real robot processes on the simple map, the deadlock map
//! with and without epsilon-greedy, the complex map at low speed, and identical records in both
//! modes under a lossy radio.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use swarmrt_tests::{bytes, run_config};

fn run(config: &str, dir: &Path, extra: &[&str]) -> serde_json::Value {
    run_config(config, dir, extra)
}

/// Robots with their lidar on, per tick.
fn lidars_on(dir: &Path) -> BTreeMap<u64, u32> {
    let text = String::from_utf8(bytes(dir, "trajectory.csv")).unwrap();
    let mut on = BTreeMap::new();
    for line in text.lines().skip(1) {
        let f: Vec<&str> = line.split(',').collect();
        *on.entry(f[0].parse::<u64>().unwrap()).or_insert(0) += f[7].parse::<u32>().unwrap();
    }
    on
}

#[test]
fn nine_robot_processes_reach_the_target_at_half_a_metre_per_second_with_three_lidars() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("simple");
    let m = run(
        "configs/formation_simple.toml",
        &dir,
        &["--set", "behaviour.speed=0.5"],
    );
    assert_eq!(m["mode"], "processes");
    assert_eq!(m["reached_target"], 9, "{m}");
    assert_eq!(m["down"], 0, "{m}");
    let end = m["steps_to_target"]
        .as_u64()
        .expect("reached, so a step count");

    // Every lidar starts on, and at tick 0 no robot has heard another yet, so each thinks it
    // is alone and the middle observer; from tick 2 only the observers' lidars are on. Role
    // hand-overs may leave two or four on for a tick.
    let on = lidars_on(&dir);
    let moving: Vec<u32> = (2..end).map(|t| on[&t]).collect();
    let three = moving.iter().filter(|&&n| n == 3).count();
    assert!(
        moving.iter().all(|&n| (2..=4).contains(&n)),
        "lidars on per tick: {moving:?}"
    );
    assert!(
        three as f64 >= 0.95 * moving.len() as f64,
        "exactly three lidars on in only {three} of {} ticks",
        moving.len()
    );
    // Seed 000, Fig. 7: three of nine lidars on saves 1 - 3/9 of the lidar energy.
    let saving = m["energy_saving"].as_f64().unwrap();
    assert!((saving - 2.0 / 3.0).abs() < 0.02, "energy saving {saving}");
    assert!(m["formation_error_rms"].as_f64().unwrap() < 0.2, "{m}");
    assert_eq!(m["loops_detected"], 0, "{m}");
}

#[test]
fn the_deadlock_map_loops_without_epsilon_greedy_and_is_left_with_it() {
    let tmp = tempfile::tempdir().unwrap();
    let off = run(
        "configs/formation_deadlock.toml",
        &tmp.path().join("off"),
        &[
            "--in-process",
            "--ticks",
            "3000",
            "--set",
            "behaviour.epsilon_obstacle=0",
            "--set",
            "behaviour.epsilon_clear=0",
        ],
    );
    assert_eq!(off["reached_target"], 0, "{off}");
    assert_eq!(off["down"], 0, "stuck, not crashed: {off}");
    assert!(off["loops_detected"].as_u64().unwrap() >= 1, "{off}");
    assert!(off["loop_ticks"].as_u64().unwrap() > 1000, "{off}");
    assert_eq!(off["epsilon_flips"], 0, "{off}");

    let on = run(
        "configs/formation_deadlock.toml",
        &tmp.path().join("on"),
        &["--in-process", "--ticks", "3000"],
    );
    assert_eq!(on["reached_target"], 9, "{on}");
    assert!(on["epsilon_flips"].as_u64().unwrap() > 0, "{on}");
}

#[test]
fn the_complex_map_brings_the_swarm_home_at_a_fifth_of_a_metre_per_second() {
    // Seed 000: "for v < 1 m/s all robots reach the target" on the complex map (w = 1 deg).
    // Issue 35 asks for at least 8.5 of 9 on average over 5 seeds at 0.2 m/s; in-process runs
    // give the records of process runs (the lossy-radio test below).
    let tmp = tempfile::tempdir().unwrap();
    let mut reached = Vec::new();
    for seed in 1..=5 {
        let seed = format!("scenario.seed={seed}");
        let m = run(
            "configs/formation_complex.toml",
            &tmp.path().join(&seed),
            &[
                "--in-process",
                "--set",
                "behaviour.speed=0.2",
                "--set",
                "behaviour.turn_deg=1",
                "--set",
                &seed,
            ],
        );
        reached.push(m["reached_target"].as_u64().expect("reached_target"));
    }
    let mean = reached.iter().sum::<u64>() as f64 / reached.len() as f64;
    assert!(mean >= 8.5, "robots home per seed: {reached:?}");
}

#[test]
fn a_lossy_delayed_radio_gives_the_same_records_in_both_modes() {
    let tmp = tempfile::tempdir().unwrap();
    let lossy = [
        "--ticks",
        "300",
        "--set",
        "radio.loss=0.3",
        "--set",
        "radio.delay_ticks=2",
        "--set",
        "radio.jitter_ticks=1",
    ];
    let dirs: Vec<PathBuf> = ["processes", "in-process"]
        .iter()
        .map(|mode| {
            let dir = tmp.path().join(mode);
            let mut extra = lossy.to_vec();
            if *mode == "in-process" {
                extra.push("--in-process");
            }
            run("configs/formation_complex.toml", &dir, &extra);
            dir
        })
        .collect();
    for f in ["trajectory.csv", "events.jsonl"] {
        assert!(bytes(&dirs[0], f) == bytes(&dirs[1], f), "{f} differs");
    }
    let events = String::from_utf8(bytes(&dirs[0], "events.jsonl")).unwrap();
    assert!(events.contains("\"role\""), "role notes are recorded");
}
