//! Seed 004 flocking end to end: environment 1 as five robot processes, the crossing flocks,
//! identical records in both modes with a lossy, late radio, and the NR-PSO of Fig. 9.

use std::path::Path;
use std::time::Duration;
use swarmrt_tests::{assert_modes_agree_with_loss, assert_ok, bytes, run_config, swarm, workspace};

fn run(config: &str, dir: &Path, extra: &[&str]) -> serde_json::Value {
    run_config(config, dir, extra)
}

/// `flocking.csv` as (flock, cohesion) per row.
fn cohesion_rows(dir: &Path) -> Vec<(u32, f64)> {
    let text = String::from_utf8(bytes(dir, "flocking.csv")).unwrap();
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let col = |name: &str| header.iter().position(|h| *h == name).unwrap();
    let (flock, cohesion) = (col("flock"), col("cohesion"));
    lines
        .map(|l| {
            let f: Vec<&str> = l.split(',').collect();
            (f[flock].parse().unwrap(), f[cohesion].parse().unwrap())
        })
        .collect()
}

/// Environment 1 with our hand-crafted weights: measured p̄ = 0.59 over 1150 ticks (seed 1);
/// the bar leaves room for changes that do not break the flock.
#[test]
fn five_robot_processes_flock_through_the_obstacles_without_a_collision() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("env1");
    let m = run("configs/flocking_obstacles.toml", &dir, &[]);
    assert_eq!(m["mode"], "processes");
    assert_eq!(m["collisions"], 0, "{m}");
    assert_eq!(m["down"], 0, "{m}");
    let f = &m["flocking"];
    let p = f["performance"].as_f64().unwrap();
    assert!(p > 0.45, "overall performance {p}: {f}");
    assert!(
        f["distance"].as_f64().unwrap() > 2.5,
        "crossed the field: {f}"
    );
    assert!(dir.join("flocking.csv").exists() && dir.join("flocking.png").exists());
}

/// Two flocks head-on: each stays together (c' never below 0.85, i.e. its robots never average
/// more than 18 cm from their centre of mass) and each gets across.
#[test]
fn crossing_flocks_each_keep_their_cohesion_and_get_across() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("env2");
    let m = run("configs/flocking_crossing.toml", &dir, &["--in-process"]);
    assert_eq!(m["collisions"], 0, "{m}");
    let flocks = m["flocking"]["flocks"].as_array().unwrap();
    assert_eq!(flocks.len(), 2);
    for f in flocks {
        assert!(f["distance"].as_f64().unwrap() > 2.5, "{f}");
    }
    let rows = cohesion_rows(&dir);
    for flock in 0..2 {
        let c: Vec<f64> = rows.iter().filter(|r| r.0 == flock).map(|r| r.1).collect();
        assert!(c.len() > 800, "flock {flock} has {} ticks", c.len());
        let worst = c.iter().cloned().fold(f64::INFINITY, f64::min);
        assert!(worst > 0.85, "flock {flock} spread out: c' fell to {worst}");
    }
}

/// One-byte messages, odometry with wheel slip, radio loss, delay and jitter: both modes write
/// the same bytes.
#[test]
fn calibrated_world_records_are_identical_in_both_modes_with_loss_and_delay() {
    let tmp = tempfile::tempdir().unwrap();
    let files = ["trajectory.csv", "events.jsonl", "flocking.csv"];
    assert_modes_agree_with_loss(
        tmp.path(),
        "configs/flocking_calibrated.toml",
        300,
        &[],
        &files,
    );
}

/// Fig. 9: the first 4 of 25 iterations of one of the five NR-PSO tunes of
/// `docs/results/seed004/tune.sh` (environment 4, 7 particles, 14 evaluations per iteration),
/// run again; 4 keep it about 7 s in a debug build. Every evaluation must be the one the doc's
/// figures were drawn from (the tune is deterministic, so the rest of the committed tune, best
/// 0.972, follows), and the best must already lie within the spread the five tunes report in
/// `tunes.md` (0.956-0.995).
#[test]
fn an_nr_pso_tune_of_environment_4_lands_within_the_spread_of_the_five() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("tune");
    let args = [
        "tune",
        "configs/flocking_pso.toml",
        "--param",
        "behaviour.alpha=0:2",
        "--param",
        "behaviour.beta=1:200",
        "--param",
        "behaviour.delta=1:30",
        "--param",
        "behaviour.iota=-1:1",
        "--param",
        "behaviour.zeta=-1:1",
        "--param",
        "behaviour.kappa=0:1",
        "--param",
        "behaviour.mb=0:1",
        "--fitness",
        "flocking.fitness",
        "--maximize",
        "--particles",
        "7",
        "--iterations",
        "4",
        "--evaluations",
        "14",
        "--jobs",
        "1",
        "--seed",
        "3",
        "--in-process",
        "--out",
        out.to_str().unwrap(),
    ];
    assert_ok(&swarm(&args, Duration::from_secs(300)));
    let tune: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("tune.json")).unwrap()).unwrap();
    assert_eq!(tune["evaluations_done"], 56, "{tune}");
    let best = tune["best"]["fitness"].as_f64().unwrap();
    assert!((0.956..=0.995).contains(&best), "best F_p {best}");
    let csv = bytes(&out, "tune.csv");
    let committed = std::fs::read(workspace().join("docs/results/seed004/tunes/normal_s3.csv"))
        .expect("the committed tune");
    assert_eq!(
        csv.iter().filter(|&&b| b == b'\n').count(),
        57,
        "a header and 56 evaluations"
    );
    assert!(
        committed.starts_with(&csv),
        "tune.csv is not the start of tunes/normal_s3.csv: rerun docs/results/seed004/tune.sh \
         if the change is meant"
    );
}
