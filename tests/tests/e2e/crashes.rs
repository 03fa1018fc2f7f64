//! Nothing lost, nothing hung, nothing leaked: real SIGKILLs against a running swarm.

use std::time::Duration;
use swarmrt_tests::*;

const LIMIT: Duration = Duration::from_secs(120);

fn robot_pid(children: &[(i32, String)], id: u32) -> i32 {
    let needle = format!("--robot {id} ");
    children
        .iter()
        .find(|(_, c)| c.contains("swarm-agent") && c.contains(&needle))
        .map(|(p, _)| *p)
        .expect("robot process exists")
}

fn stop_run(child: &std::process::Child) {
    // SIGINT is Ctrl-C: the orchestrator stops the run in order.
    unsafe {
        libc::kill(child.id() as i32, libc::SIGINT);
    }
}

#[test]
fn killing_one_robot_process_mid_run() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("run");
    let child = start_long_run(&dir, &[]);
    let children = children_of(child.id());
    assert_eq!(children.len(), 10, "world + 9 robots: {children:?}");
    let victim = robot_pid(&children, 4);
    unsafe {
        libc::kill(victim, libc::SIGKILL);
    }
    // The run goes on without robot 4.
    let killed_at = last_tick(&dir);
    wait_until("the run to go on after the kill", LIMIT, || {
        last_tick(&dir) > killed_at + 50
    });
    stop_run(&child);
    let out = wait_with_watchdog(child, LIMIT);
    assert_ok(&out);

    let m = metrics(&dir);
    assert_eq!(m["dead"], 1, "{m}");
    assert_eq!(m["unscheduled_deaths"][0]["robot"], 4);
    assert_eq!(
        m["reproducible"], false,
        "an unscheduled death cannot be replayed"
    );
    let events = String::from_utf8(bytes(&dir, "events.jsonl")).unwrap();
    assert!(
        events
            .lines()
            .any(|l| l.contains("\"died\"") && l.contains("\"robot\":4")),
        "{events}"
    );
    let csv = String::from_utf8(bytes(&dir, "trajectory.csv")).unwrap();
    let last_row_4 = csv
        .lines()
        .rev()
        .find(|l| l.split(',').nth(1) == Some("4"))
        .unwrap();
    assert!(last_row_4.ends_with(",dead"), "{last_row_4}");
    // Every other robot is still active and moving on.
    assert_eq!(
        csv.lines()
            .rev()
            .take(9)
            .filter(|l| l.ends_with(",active"))
            .count(),
        8
    );

    assert_nothing_left(&children, m["run_id"].as_str().unwrap());
}

#[test]
fn killing_the_world_fails_the_run_without_hangs_or_leaks() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("run");
    let child = start_long_run(&dir, &[]);
    let children = children_of(child.id());
    let world = children
        .iter()
        .find(|(_, c)| c.contains("swarm-world"))
        .map(|(p, _)| *p)
        .unwrap();
    let run_id = run_id_of(&children);
    unsafe {
        libc::kill(world, libc::SIGKILL);
    }
    let out = wait_with_watchdog(child, LIMIT);
    assert_eq!(
        out.status.code(),
        Some(1),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let m = metrics(&dir);
    assert_eq!(m["failed"], true);
    // Records up to the last tick, never a torn line.
    let csv = String::from_utf8(bytes(&dir, "trajectory.csv")).unwrap();
    assert!(csv.ends_with('\n'));
    assert!(csv.lines().skip(1).all(|l| l.split(',').count() == 9));
    assert_eq!((csv.lines().count() - 1) % 9, 0, "whole ticks only");
    assert_nothing_left(&children, &run_id);
}

#[test]
fn swarm_clean_removes_what_a_killed_orchestrator_left() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("run");
    let mut child = start_long_run(&dir, &[]);
    let children = children_of(child.id());
    let run_id = run_id_of(&children);
    child.kill().unwrap(); // SIGKILL: no cleanup by the orchestrator
    child.wait().unwrap();
    // Its children notice (parent-death signal) and exit by themselves.
    wait_until("the orphaned children to exit", LIMIT, || {
        children.iter().all(|(p, _)| !alive(*p))
    });
    assert!(
        !leftovers(&run_id).is_empty(),
        "a killed orchestrator leaves its run's files"
    );
    let out = swarm(&["clean"], LIMIT);
    assert_ok(&out);
    assert!(String::from_utf8_lossy(&out.stdout).contains(&run_id));
    assert!(leftovers(&run_id).is_empty(), "{:?}", leftovers(&run_id));
}

#[test]
fn ctrl_c_stops_the_run_and_keeps_complete_records() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("run");
    let child = start_long_run(&dir, &[]);
    let children = children_of(child.id());
    stop_run(&child);
    let out = wait_with_watchdog(child, LIMIT);
    assert_ok(&out);
    let m = metrics(&dir);
    assert_eq!(m["interrupted"], true);
    assert_eq!(m["dead"], 0, "robots stopped by Ctrl-C are not deaths");
    let ticks = m["ticks"].as_u64().unwrap();
    assert_eq!(last_tick(&dir), ticks);
    assert_nothing_left(&children, m["run_id"].as_str().unwrap());
}

#[test]
fn ctrl_c_stops_an_in_process_run_too() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("run");
    let child = start_long_run(&dir, &["--in-process"]);
    stop_run(&child);
    let out = wait_with_watchdog(child, LIMIT);
    assert_ok(&out);
    let m = metrics(&dir);
    assert_eq!(m["interrupted"], true);
    assert_eq!(m["reproducible"], false);
    assert_eq!(last_tick(&dir), m["ticks"].as_u64().unwrap());
}

/// Regression: Ctrl-C while robots were still starting left the late ones waiting for a
/// shutdown sample published before they subscribed; the orchestrator then sat out its whole
/// grace period and SIGKILLed them.
#[test]
fn ctrl_c_during_start_up_stops_every_robot_without_sigkill() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("run");
    let child = std::process::Command::new(swarm_bin())
        .current_dir(workspace())
        .args([
            "run",
            "configs/goto_simple.toml",
            "--set",
            "robots.count=60",
            "--out",
            dir.to_str().unwrap(),
        ])
        .stdin(std::process::Stdio::null())
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    wait_until("some robots to start", LIMIT, || {
        children_of(child.id()).len() > 10
    });
    let children = children_of(child.id());
    stop_run(&child);
    let out = wait_with_watchdog(child, LIMIT);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{err}");
    assert!(
        !err.contains("killing them"),
        "robots had to be SIGKILLed:\n{err}"
    );
    let m = metrics(&dir);
    assert_eq!(m["interrupted"], true);
    assert_nothing_left(&children, m["run_id"].as_str().unwrap());
}
