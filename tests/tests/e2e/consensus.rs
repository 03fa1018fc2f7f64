//! Consensus end to end: the Raft scenario in robot processes and in-process (identical
//! records, a leader, the scheduled decision committed and applied by every robot, the
//! checker clean), a real SIGKILL of the leader's process, the quadrant scenario, and the
//! seeded fuzzer over a few hundred seeds.

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::Duration;

use serde_json::Value;
use swarmrt_tests::*;

const LIMIT: Duration = Duration::from_secs(240);

fn run(tmp: &Path, name: &str, config: &str, extra: &[&str]) -> PathBuf {
    let dir = tmp.join(name);
    let mut args = vec!["run", config, "--out", dir.to_str().unwrap()];
    args.extend_from_slice(extra);
    assert_ok(&swarm(&args, LIMIT));
    dir
}

/// The consensus notes of a run: (tick, robot, note) from `events.jsonl`.
fn notes(dir: &Path) -> Vec<(u64, u64, Value)> {
    String::from_utf8(bytes(dir, "events.jsonl"))
        .unwrap()
        .lines()
        .map(|l| serde_json::from_str::<Value>(l).unwrap())
        .filter(|v| v["event"] == "note" && v["note"]["consensus"].is_object())
        .map(|v| {
            (
                v["tick"].as_u64().unwrap(),
                v["robot"].as_u64().unwrap(),
                v["note"]["consensus"].clone(),
            )
        })
        .collect()
}

#[test]
fn raft_election_in_processes_and_in_process_gives_the_same_safe_record() {
    let tmp = tempfile::tempdir().unwrap();
    let ticks = ["--ticks", "420"];
    let p = run(tmp.path(), "p", "configs/raft_election.toml", &ticks);
    let mut ip_args = ticks.to_vec();
    ip_args.push("--in-process");
    let ip = run(tmp.path(), "ip", "configs/raft_election.toml", &ip_args);
    for f in ["events.jsonl", "trajectory.csv"] {
        assert!(bytes(&p, f) == bytes(&ip, f), "{f} differs between modes");
    }

    let notes = notes(&p);
    let leaders: Vec<&(u64, u64, Value)> = notes
        .iter()
        .filter(|(_, _, n)| n["state"]["role"] == "leader")
        .collect();
    assert!(!leaders.is_empty(), "a leader was elected");
    // The scheduled SetGoal (tick 300) was proposed by a leader and every robot applied
    // that very entry (index, term and digest), in log order.
    let (_, proposer, prop) = notes
        .iter()
        .find(|(t, _, n)| n["propose"].is_object() && *t >= 300)
        .expect("the scheduled decision was proposed");
    assert_eq!(prop["propose"]["decision"]["set_goal"]["y"], 3.0);
    assert!(leaders.iter().any(|(_, r, _)| r == proposer));
    let index = &prop["propose"]["index"];
    let appended = notes
        .iter()
        .find(|(_, r, n)| r == proposer && n["append"]["index"] == *index)
        .unwrap();
    // The config kills the leader of tick 200; every robot still alive applies the entry.
    let events = String::from_utf8(bytes(&p, "events.jsonl")).unwrap();
    let killed: Vec<u64> = events
        .lines()
        .filter_map(|l| serde_json::from_str::<Value>(l).ok())
        .filter(|e| e["event"] == "fault" && e["fault"] == "kill")
        .map(|e| e["robot"].as_u64().unwrap())
        .collect();
    assert_eq!(killed.len(), 1, "the scheduled leader kill happened");
    assert!(
        leaders.iter().any(|(t, r, _)| *r == killed[0] && *t < 200),
        "the killed robot was the leader"
    );
    for robot in (0..9u64).filter(|r| !killed.contains(r)) {
        let applied = notes
            .iter()
            .find(|(_, r, n)| *r == robot && n["apply"]["index"] == *index)
            .unwrap_or_else(|| panic!("robot {robot} applied the decision"));
        assert_eq!(applied.2["apply"]["digest"], appended.2["append"]["digest"]);
        assert_eq!(applied.2["apply"]["term"], appended.2["append"]["term"]);
    }

    let m = metrics(&p);
    let c = &m["consensus"];
    assert_eq!(c["safety_violations"], 0, "{c}");
    assert_eq!(c["decisions"][0]["applied_by"], 8, "{c}");
    assert!(
        c["leader_changes"].as_u64().unwrap() >= 1,
        "re-elected: {c}"
    );
    assert_eq!(c["reelection_ticks"].as_array().unwrap().len(), 1, "{c}");
    assert!(c["first_leader_tick"].as_u64().unwrap() < 300, "{c}");
    assert!(c["sent"]["append"].as_u64().unwrap() > 0, "{c}");
    assert_eq!(metrics(&ip)["consensus"], *c, "same metrics in both modes");
}

#[test]
fn killing_the_leaders_process_gets_a_new_leader_and_the_checker_stays_clean() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("run");
    let child = Command::new(swarm_bin())
        .current_dir(workspace())
        .args([
            "run",
            "configs/raft_election.toml",
            "--ticks",
            "100000",
            "--out",
            dir.to_str().unwrap(),
        ])
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("swarm starts");
    let leader_of = |dir: &Path| -> Option<(u64, u64)> {
        let text = std::fs::read_to_string(dir.join("events.jsonl")).ok()?;
        text.lines()
            .filter_map(|l| serde_json::from_str::<Value>(l).ok())
            .filter(|v| v["note"]["consensus"]["state"]["role"] == "leader")
            .map(|v| {
                (
                    v["robot"].as_u64().unwrap(),
                    v["note"]["consensus"]["state"]["term"].as_u64().unwrap(),
                )
            })
            .next_back()
    };
    wait_until("a leader", LIMIT, || leader_of(&dir).is_some());
    // Let the leader settle in, then SIGKILL its process.
    let t0 = last_tick(&dir);
    wait_until("40 more ticks", LIMIT, || last_tick(&dir) > t0 + 40);
    let (leader, term) = leader_of(&dir).unwrap();
    let children = children_of(child.id());
    let needle = format!("--robot {leader} ");
    let (pid, _) = children
        .iter()
        .find(|(_, c)| c.contains("swarm-agent") && c.contains(&needle))
        .expect("the leader's process");
    unsafe {
        libc::kill(*pid, libc::SIGKILL);
    }
    wait_until("a new leader", LIMIT, || {
        leader_of(&dir).is_some_and(|(r, t)| r != leader && t > term)
    });
    unsafe {
        libc::kill(child.id() as i32, libc::SIGINT);
    }
    assert_ok(&wait_with_watchdog(child, LIMIT));
    let c = &metrics(&dir)["consensus"];
    assert_eq!(c["safety_violations"], 0, "{c}");
    let re = c["reelection_ticks"].as_array().unwrap();
    assert!(!re.is_empty(), "re-election measured from the death: {c}");
    assert!(c["leader_changes"].as_u64().unwrap() >= 1, "{c}");
    assert_ne!(c["leader"]["robot"], leader, "{c}");
}

#[test]
fn a_scheduled_kill_of_the_leader_replays_and_the_swarm_still_switches_goal() {
    // The world's "leader" kill target is the robot that last claimed leadership in a note.
    let tmp = tempfile::tempdir().unwrap();
    let args = [
        "--ticks",
        "500",
        "--set",
        "faults.kill=[{tick=200,robot=\"leader\"}]",
    ];
    let p = run(tmp.path(), "p", "configs/raft_election.toml", &args);
    let mut ip_args = args.to_vec();
    ip_args.push("--in-process");
    let ip = run(tmp.path(), "ip", "configs/raft_election.toml", &ip_args);
    assert!(bytes(&p, "events.jsonl") == bytes(&ip, "events.jsonl"));
    let m = metrics(&p);
    assert_eq!(m["reproducible"], true, "a scheduled kill replays");
    let c = &m["consensus"];
    assert_eq!(c["safety_violations"], 0, "{c}");
    // The victim was the leader of that moment; a new one took over.
    let leader_before = notes(&p)
        .iter()
        .filter(|(t, _, n)| *t < 200 && n["state"]["role"] == "leader")
        .map(|(_, r, _)| *r)
        .next_back()
        .expect("a leader before the kill");
    let died: Vec<Value> = String::from_utf8(bytes(&p, "events.jsonl"))
        .unwrap()
        .lines()
        .map(|l| serde_json::from_str::<Value>(l).unwrap())
        .filter(|v| v["event"] == "died")
        .collect();
    assert_eq!(died.len(), 1);
    assert_eq!(died[0]["robot"], leader_before);
    assert_eq!(c["reelection_ticks"].as_array().unwrap().len(), 1, "{c}");
    assert_ne!(c["leader"]["robot"], leader_before, "{c}");
    // The decision scheduled after the kill is applied by every live robot.
    assert_eq!(c["decisions"][0]["applied_by"], 8, "{c}");
}

#[test]
fn quadrant_leader_scenario_ends_with_one_agreed_leader() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = run(
        tmp.path(),
        "q",
        "configs/quadrant_leader.toml",
        &["--in-process"],
    );
    let q = &metrics(&dir)["consensus"]["quadrant"];
    assert_eq!(
        q["self_declared_leaders"].as_array().unwrap().len(),
        1,
        "{q}"
    );
    assert_eq!(q["all_agree"], true, "{q}");
    // The leader holds the best score (the paper's rule); ties went to the seeded draw.
    let beliefs = q["beliefs"].as_array().unwrap();
    let leader = &q["self_declared_leaders"][0];
    let best = beliefs.iter().map(|b| b["score"].as_u64().unwrap()).max();
    let leader_score = beliefs
        .iter()
        .find(|b| b["robot"] == *leader)
        .map(|b| b["score"].as_u64().unwrap());
    assert_eq!(leader_score, best, "{q}");
}

#[test]
fn the_fuzzer_holds_for_three_hundred_seeds() {
    let out = swarm(&["fuzz", "consensus", "--seeds", "300"], LIMIT);
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert_ok(&out);
    assert!(stdout.contains("300 seeds (0..299), 0 failed"), "{stdout}");
}

#[test]
fn fuzzer_arguments_are_checked() {
    for args in [
        &["fuzz", "consensus", "--seeds", "0"][..],
        &[
            "fuzz",
            "consensus",
            "--seeds",
            "2",
            "--start-seed",
            "18446744073709551615",
        ],
        &["fuzz", "election", "--loss", "1.5"],
        &["fuzz", "quadrant", "--area-per-robot", "0"],
    ] {
        let out = swarm(args, LIMIT);
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{args:?}: {err}");
        assert_eq!(err.trim().lines().count(), 1, "{args:?}: {err}");
        assert!(!err.contains("panicked"), "{err}");
    }
}

#[test]
fn a_long_fuzz_run_stops_on_sigterm_between_seeds_and_reports_what_ran() {
    let child = Command::new(swarm_bin())
        .args(["fuzz", "consensus", "--seeds", "10000000"])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    std::thread::sleep(Duration::from_secs(2));
    // SAFETY: plain kill(2) of our own child.
    unsafe { libc::kill(child.id() as i32, libc::SIGTERM) };
    let out = wait_with_watchdog(child, Duration::from_secs(20));
    assert_eq!(out.status.code(), Some(130), "{out:?}");
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(text.contains("0 failed"), "{text}");
    assert!(
        String::from_utf8_lossy(&out.stderr).contains("interrupted"),
        "{out:?}"
    );
}
