//! A bad config is one clear line naming the file and key, exit code 2, never a panic.

use std::time::Duration;
use swarmrt_tests::swarm;

const LIMIT: Duration = Duration::from_secs(60);

fn refused(args: &[&str], must_mention: &[&str]) {
    let out = swarm(args, LIMIT);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{args:?} -> {err}");
    assert!(!err.contains("panicked"), "{err}");
    assert_eq!(err.trim().lines().count(), 1, "one line: {err}");
    for m in must_mention {
        assert!(err.contains(m), "{args:?}: expected {m:?} in {err}");
    }
}

#[test]
fn unknown_key() {
    let tmp = tempfile::tempdir().unwrap();
    let p = tmp.path().join("typo.toml");
    let text = std::fs::read_to_string(swarmrt_tests::workspace().join("configs/goto_simple.toml"))
        .unwrap();
    std::fs::write(&p, text.replace("capacity = 4", "capacty = 4")).unwrap();
    refused(
        &["check", p.to_str().unwrap()],
        &["typo.toml", "radio.capacty", "unknown field"],
    );
}

#[test]
fn wrong_type() {
    refused(
        &[
            "check",
            "configs/goto_simple.toml",
            "--set",
            "robots.count=\"nine\"",
        ],
        &["goto_simple.toml", "robots.count"],
    );
}

#[test]
fn negative_count() {
    refused(
        &[
            "run",
            "configs/goto_simple.toml",
            "--set",
            "robots.count=-3",
        ],
        &["robots.count"],
    );
}

#[test]
fn loss_above_one_names_its_bounds() {
    refused(
        &["run", "configs/goto_simple.toml", "--set", "radio.loss=1.5"],
        &["radio.loss", "[0, 1]"],
    );
}

#[test]
fn missing_file_and_broken_toml() {
    refused(
        &["check", "configs/does_not_exist.toml"],
        &["does_not_exist.toml"],
    );
    let tmp = tempfile::tempdir().unwrap();
    let p = tmp.path().join("broken.toml");
    std::fs::write(&p, "[scenario\nname = 1").unwrap();
    refused(&["check", p.to_str().unwrap()], &["broken.toml", "TOML"]);
}

#[test]
fn more_robots_than_the_map_has_room_for() {
    refused(
        &[
            "run",
            "configs/goto_simple.toml",
            "--set",
            "robots.count=5000",
        ],
        &["robots.start", "5000"],
    );
}

#[test]
fn issue_5_infinitely_wide_rectangle_is_refused_not_a_panic() {
    // Finite corners whose difference overflows: parry's BVH build used to panic (exit 101).
    refused(
        &[
            "check",
            "configs/goto_simple.toml",
            "--set",
            "map.rectangles=[{ x_min = -1e308, y_min = 1.0, x_max = 1e308, y_max = 2.0 }]",
        ],
        &[
            "goto_simple.toml",
            "map.rectangles[0].x_min",
            "[-1000000, 1000000]",
        ],
    );
}

#[test]
fn issue_5_newline_in_a_key_stays_on_one_line() {
    refused(
        &[
            "check",
            "configs/goto_simple.toml",
            "--set",
            "radio.lo\nss=1",
        ],
        &["radio.lo\\nss", "unknown field"],
    );
}

#[test]
fn issue_5_seed_beyond_toml_integers_is_named_not_called_a_string() {
    // `--seed` takes any u64, but TOML (and so the config) holds at most i64::MAX; the error
    // said "invalid type: string".
    refused(
        &[
            "run",
            "configs/goto_simple.toml",
            "--seed",
            "18446744073709551615",
        ],
        &[
            "scenario.seed",
            "9223372036854775807",
            "18446744073709551615",
        ],
    );
}
