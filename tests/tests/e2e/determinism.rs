//! Same config + seed => byte-identical `trajectory.csv` and `events.jsonl`, run after run and
//! between process mode and `--in-process` (DESIGN section 3).

use std::path::{Path, PathBuf};
use std::time::Duration;
use swarmrt_tests::{LOSSY_RADIO, assert_ok, bytes, metrics, swarm};

const LIMIT: Duration = Duration::from_secs(180);

fn run(tmp: &std::path::Path, name: &str, extra: &[&str]) -> PathBuf {
    let dir = tmp.join(name);
    let mut args = vec![
        "run",
        "configs/goto_simple.toml",
        "--ticks",
        "300",
        "--out",
        dir.to_str().unwrap(),
    ];
    args.extend_from_slice(extra);
    assert_ok(&swarm(&args, LIMIT));
    dir
}

fn assert_same(a: &Path, b: &Path) {
    for f in ["trajectory.csv", "events.jsonl"] {
        assert!(
            bytes(a, f) == bytes(b, f),
            "{f} differs between {} and {}",
            a.display(),
            b.display()
        );
    }
}

#[test]
fn processes_twice_and_in_process_give_identical_bytes() {
    let tmp = tempfile::tempdir().unwrap();
    let p1 = run(tmp.path(), "p1", &["--seed", "3"]);
    let p2 = run(tmp.path(), "p2", &["--seed", "3"]);
    let ip = run(tmp.path(), "ip", &["--seed", "3", "--in-process"]);
    assert_same(&p1, &p2);
    assert_same(&p1, &ip);
    assert_eq!(metrics(&p1)["reproducible"], true);
}

#[test]
fn lossy_delayed_radio_is_just_as_reproducible() {
    let tmp = tempfile::tempdir().unwrap();
    let mut lossy = vec!["--seed", "4"];
    lossy.extend_from_slice(&LOSSY_RADIO);
    let p1 = run(tmp.path(), "p1", &lossy);
    let p2 = run(tmp.path(), "p2", &lossy);
    let mut ip_args = lossy.to_vec();
    ip_args.push("--in-process");
    let ip = run(tmp.path(), "ip", &ip_args);
    assert_same(&p1, &p2);
    assert_same(&p1, &ip);
    let r = &metrics(&p1)["radio"];
    assert!(
        r["dropped_loss"].as_u64().unwrap() > 0,
        "loss happened: {r}"
    );
    assert_eq!(metrics(&p1)["radio"], metrics(&ip)["radio"]);
}

#[test]
fn a_different_seed_gives_a_different_trajectory() {
    let tmp = tempfile::tempdir().unwrap();
    // Noise makes the seed matter even where the behaviour itself draws nothing.
    let a = run(
        tmp.path(),
        "a",
        &[
            "--seed",
            "1",
            "--in-process",
            "--set",
            "robots.noise.pose=0.02",
        ],
    );
    let b = run(
        tmp.path(),
        "b",
        &[
            "--seed",
            "2",
            "--in-process",
            "--set",
            "robots.noise.pose=0.02",
        ],
    );
    assert_ne!(bytes(&a, "trajectory.csv"), bytes(&b, "trajectory.csv"));
}
