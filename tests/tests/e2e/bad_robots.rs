//! A robot process that sends malformed commands over the real IPC path is refused and
//! counted; the world and the other robots go on, and nothing hangs.

use std::process::{Command, Stdio};
use std::time::Duration;
use swarmrt_tests::{bytes, leftovers, metrics, swarm_bin, wait_with_watchdog, workspace};

const LIMIT: Duration = Duration::from_secs(120);

/// Runs goto_simple for 60 ticks with robot 3 misbehaving in `mode`; returns the metrics (with
/// the run's rejected events) and robot 3's distinct positions.
fn run_with(mode: &str) -> (serde_json::Value, usize) {
    let (tmp, m) = run_in_tmp(mode);
    let csv = String::from_utf8(bytes(&tmp.path().join("run"), "trajectory.csv")).unwrap();
    let mut positions: Vec<(String, String)> = csv
        .lines()
        .skip(1)
        .filter(|l| l.split(',').nth(1) == Some("3"))
        .map(|l| {
            let f: Vec<&str> = l.split(',').collect();
            (f[2].to_string(), f[3].to_string())
        })
        .collect();
    positions.dedup();
    // The well-behaved robots still move.
    let moved = csv
        .lines()
        .skip(1)
        .filter(|l| l.starts_with("60,") && !l.contains(",3,"))
        .count();
    assert_eq!(moved, 8);
    (m, positions.len())
}

/// The run of [`run_with`], in the returned directory's `run`, and its metrics with the
/// rejected events.
fn run_in_tmp(mode: &str) -> (tempfile::TempDir, serde_json::Value) {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("run");
    let child = Command::new(swarm_bin())
        .current_dir(workspace())
        .args([
            "run",
            "configs/goto_simple.toml",
            "--ticks",
            "60",
            "--out",
            dir.to_str().unwrap(),
        ])
        .env("SWARMRT_TEST_MISBEHAVE", format!("3:{mode}"))
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let out = wait_with_watchdog(child, LIMIT);
    assert!(
        out.status.success(),
        "{mode}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    let mut m = metrics(&dir);
    assert_eq!(m["ticks"], 60, "{mode}: the run went on");
    let events = String::from_utf8(bytes(&dir, "events.jsonl")).unwrap();
    m["rejected_events"] = events
        .lines()
        .map(|l| serde_json::from_str::<serde_json::Value>(l).unwrap())
        .filter(|e| e["event"] == "rejected")
        .collect();
    (tmp, m)
}

#[test]
fn nan_speed_is_refused_and_the_robot_stands_still() {
    let (m, positions) = run_with("nan");
    assert_eq!(m["rejected"], 60, "{m}");
    assert_eq!(positions, 1, "never moved");
}

#[test]
fn wrong_tick_is_refused_without_hanging_the_world() {
    let (m, positions) = run_with("wrong-tick");
    assert_eq!(m["rejected"], 60, "{m}");
    assert_eq!(positions, 1);
}

#[test]
fn a_robot_cannot_answer_for_another() {
    let (m, positions) = run_with("impersonate");
    assert_eq!(
        m["rejected"], 60,
        "its own slot is refused, robot 4's is untouched: {m}"
    );
    assert_eq!(positions, 1);
}

#[test]
fn an_outbox_length_past_the_maximum_is_refused() {
    let (m, _) = run_with("bad-frame");
    assert_eq!(m["rejected"], 60, "{m}");
}

#[test]
fn a_second_answer_in_one_tick_is_counted_and_ignored() {
    let (double, m) = run_in_tmp("double");
    let (clean, _) = run_in_tmp("none");
    assert_eq!(
        m["rejected"], 0,
        "the copy is never taken for an answer: {m}"
    );
    for file in ["trajectory.csv", "events.jsonl"] {
        assert!(
            bytes(&double.path().join("run"), file) == bytes(&clean.path().join("run"), file),
            "{file}: robot 3 acts on its answers as if it had sent each once"
        );
    }
    // Each copy is counted when the world drains it, in its tick or (come late) in the next
    // one. Not exactly 60: a robot two samples ahead of the world overflows its buffer of
    // two, whose oldest sample iceoryx2 drops without a word.
    let extra = m["shell"]["extra_commands"].as_u64().unwrap();
    assert!((1..=60).contains(&extra), "{m}");
}

#[test]
fn a_copy_of_an_earlier_tick_is_counted_not_taken_for_the_answer() {
    let (stale, m) = run_in_tmp("stale");
    let (clean, _) = run_in_tmp("none");
    assert_eq!(m["rejected"], 0, "{m}");
    assert_eq!(
        m["shell"]["extra_commands"], 59,
        "one copy a tick after tick 0: {m}"
    );
    for file in ["trajectory.csv", "events.jsonl"] {
        assert!(
            bytes(&stale.path().join("run"), file) == bytes(&clean.path().join("run"), file),
            "{file}: the robot's real answers are the ones acted on"
        );
    }
}

#[test]
fn every_kind_of_garbage_is_refused_counted_and_logged_once() {
    for (mode, reason) in [
        ("inf", "non-finite speed"),
        ("fast", "speed out of range"),
        ("wrong-version", "wrong protocol version"),
        ("oversized-frame", "oversized radio frame"),
        ("garbage-frame", "malformed radio frame"),
        ("frame-to-nobody", "radio frame to an unknown robot"),
        ("garbage-notes", "malformed report"),
    ] {
        let (m, positions) = run_with(mode);
        assert_eq!(m["rejected"], 60, "{mode}: {m}");
        assert_eq!(positions, 1, "{mode}: a refused command moves nothing");
        let events = &m["rejected_events"];
        assert_eq!(
            events.as_array().map(Vec::len),
            Some(1),
            "{mode}: logged once, not per tick: {events}"
        );
        assert_eq!(events[0]["reason"], reason, "{mode}");
        assert_eq!(events[0]["robot"], 3, "{mode}");
    }
}

#[test]
fn a_panicking_robot_is_a_death_not_a_hang_or_a_leak() {
    let (m, positions) = run_with("panic");
    assert_eq!(m["dead"], 1, "{m}");
    assert_eq!(m["unscheduled_deaths"][0]["robot"], 3, "{m}");
    assert_eq!(
        m["unscheduled_deaths"][0]["how"], "exited with code 101",
        "Rust's panic exit code: {m}"
    );
    assert_eq!(m["reproducible"], false, "{m}");
    assert!(positions > 1, "it moved until it panicked");
    let run_id = m["run_id"].as_str().unwrap();
    assert!(leftovers(run_id).is_empty(), "{:?}", leftovers(run_id));
}
