//! The fault schedule: the world applies faults at tick boundaries and the orchestrator sends
//! the real SIGKILL, so a faulted run still replays bit for bit from its seed.

use std::path::{Path, PathBuf};
use std::time::Duration;
use swarmrt_tests::*;

const LIMIT: Duration = Duration::from_secs(120);

const FAULTS: [&str; 6] = [
    "--set",
    "faults.kill=[{tick=60,robot=4},{tick=90,robot=\"leader\"}]",
    "--set",
    "faults.partition=[{from=100,to=160,groups=[[0,1,2,3]]}]",
    "--set",
    "faults.blackout=[{from=200,to=220}]",
];

/// Runs `swarm run <args>` in processes mode and with `--in-process` into `tmp`, asserts the
/// two wrote byte-identical records, and returns both run directories (processes first).
fn run_both_modes(tmp: &Path, args: &[&str]) -> (PathBuf, PathBuf) {
    let run = |name: &str, extra: &[&str]| {
        let dir = tmp.join(name);
        let mut all = vec!["run"];
        all.extend_from_slice(args);
        all.extend_from_slice(&["--out", dir.to_str().unwrap()]);
        all.extend_from_slice(extra);
        assert_ok(&swarm(&all, LIMIT));
        dir
    };
    let p = run("processes", &[]);
    let q = run("in-process", &["--in-process"]);
    for f in ["trajectory.csv", "events.jsonl"] {
        assert!(bytes(&p, f) == bytes(&q, f), "{f} differs between modes");
    }
    (p, q)
}

#[test]
fn a_scheduled_kill_signals_the_real_process_and_the_run_replays() {
    let tmp = tempfile::tempdir().unwrap();
    let mut args = vec!["configs/goto_simple.toml", "--ticks", "300"];
    args.extend_from_slice(&FAULTS);
    let (p, _) = run_both_modes(tmp.path(), &args);
    let m = metrics(&p);
    assert_eq!(m["dead"], 1, "{m}");
    assert_eq!(m["robots_lost"], 1, "{m}");
    // kill + partition + blackout; the "leader" kill found no leader (goto elects none).
    assert_eq!(m["faults_injected"], 3, "{m}");
    assert_eq!(m["unscheduled_deaths"], serde_json::json!([]), "{m}");
    assert_eq!(m["reproducible"], true, "{m}");
    assert!(m["radio"]["dropped_partition"].as_u64().unwrap() > 0, "{m}");

    let csv = String::from_utf8(bytes(&p, "trajectory.csv")).unwrap();
    let state_of_4 = |tick: u64| {
        csv.lines()
            .find(|l| l.starts_with(&format!("{tick},4,")))
            .map(|l| l.rsplit(',').next().unwrap().to_string())
            .unwrap()
    };
    assert_eq!(state_of_4(59), "active");
    assert_eq!(
        state_of_4(60),
        "dead",
        "dead from exactly the scheduled tick"
    );
    let events = String::from_utf8(bytes(&p, "events.jsonl")).unwrap();
    for needle in [
        r#"{"event":"fault","tick":60,"fault":"kill","robot":4}"#,
        r#"{"event":"fault","tick":90,"fault":"kill_skipped"}"#,
        r#"{"event":"fault","tick":100,"fault":"partition_start"}"#,
        r#"{"event":"fault","tick":220,"fault":"blackout_end"}"#,
    ] {
        assert!(events.contains(needle), "missing {needle}");
    }
}

#[test]
fn the_killed_robots_process_is_really_gone_and_nothing_leaks() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("run");
    // Late enough that robot 2 still runs when the test looks for it (20 ticks in).
    let child = start_long_run(&dir, &["--set", "faults.kill=[{tick=2000,robot=2}]"]);
    let children = children_of(child.id());
    let victim = children
        .iter()
        .find(|(_, c)| c.contains("swarm-agent") && c.contains("--robot 2 "))
        .map(|(p, _)| *p)
        .expect("robot 2 runs");
    wait_until("the scheduled kill", LIMIT, || !alive(victim));
    assert!(last_tick(&dir) >= 2000);
    let others = children.iter().filter(|(p, _)| *p != victim);
    assert!(
        others.clone().all(|(p, _)| alive(*p)),
        "only robot 2 was killed"
    );
    unsafe {
        libc::kill(child.id() as i32, libc::SIGINT);
    }
    let out = wait_with_watchdog(child, LIMIT);
    assert_ok(&out);
    let m = metrics(&dir);
    assert_eq!(m["dead"], 1, "{m}");
    assert_eq!(m["unscheduled_deaths"], serde_json::json!([]), "{m}");
    assert_nothing_left(&children, &run_id_of(&children));
}

#[test]
fn bad_fault_targets_are_refused_with_the_key() {
    for (set, key) in [
        ("faults.kill=[{tick=5,robot=99}]", "faults.kill[0].robot"),
        (
            "faults.kill=[{tick=5,robot=\"boss\"}]",
            "faults.kill[0].robot",
        ),
        ("faults.blackout=[{from=9,to=3}]", "faults.blackout[0].to"),
        (
            "faults.freeze=[{robot=1,from=50,to=50}]",
            "faults.freeze[0].to",
        ),
        (
            "faults.freeze=[{robot=9,from=5,to=50}]",
            "faults.freeze[0].robot",
        ),
        (
            "faults.restart=[{tick=5,robot=1,down_ticks=0}]",
            "faults.restart[0].down_ticks",
        ),
        ("faults.kill_rate=1.5", "faults.kill_rate"),
        ("faults.freeze_rate=-0.1", "faults.freeze_rate"),
        ("faults.freeze_ticks=0", "faults.freeze_ticks"),
        ("scenario.unresponsive_ms=10", "scenario.unresponsive_ms"),
    ] {
        let out = swarm(&["check", "configs/goto_simple.toml", "--set", set], LIMIT);
        assert_eq!(out.status.code(), Some(2), "{set}");
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(err.contains(key), "{set}: {err}");
        assert_eq!(err.lines().count(), 1, "{err}");
    }
}

/// Robot 5 restarted at tick 250, the leader of the moment at tick 400.
const RESTARTS: &str =
    "faults.restart=[{tick=250,robot=5,down_ticks=15},{tick=400,robot=\"leader\"}]";

/// raft_election for 500 ticks with [`RESTARTS`] and one more `--set`, in both modes.
fn run_restarts(tmp: &Path, set: &str) -> (PathBuf, PathBuf) {
    let args = [
        "configs/raft_election.toml",
        "--ticks",
        "500",
        "--set",
        set,
        "--set",
        RESTARTS,
    ];
    run_both_modes(tmp, &args)
}

#[test]
fn freezes_and_restarts_replay_bit_for_bit_with_real_processes() {
    let tmp = tempfile::tempdir().unwrap();
    let (p, q) = run_restarts(tmp.path(), "faults.freeze=[{robot=3,from=100,to=150}]");
    let m = metrics(&p);
    assert_eq!(m["reproducible"], true, "{m}");
    assert_eq!(m["unscheduled_deaths"], serde_json::json!([]), "{m}");
    assert_eq!(m["restarts"], 2, "{m}");
    assert_eq!(m["frozen_ticks"], 50, "{m}");
    // The config's own leader kill, the freeze and both restarts.
    assert_eq!(m["faults_injected"], 4, "{m}");
    let c = &m["consensus"];
    assert_eq!(c["safety_violations"], 0, "{c}");
    // Stable storage (on by default): the fresh processes restored term, vote and log.
    assert_eq!(c["amnesia_restarts"], 0, "{c}");
    let stored = std::fs::metadata(p.join("storage/raft-5.state")).expect("robot 5's state file");
    assert!(stored.len() > 8, "robot 5 wrote at least one record");
    assert_eq!(
        metrics(&q)["consensus"],
        *c,
        "same consensus metrics in both modes"
    );

    // Robot 5 had two processes: the first killed by the schedule, the fresh one ran to the
    // end. The frozen robot 3 came back and ran to the end in its one process.
    let ok = "exited with code 0".to_string();
    assert_eq!(
        processes_of(&m, 5),
        vec![
            (0, "killed by signal 9".to_string(), true),
            (1, ok.clone(), false)
        ]
    );
    assert_eq!(processes_of(&m, 3), vec![(0, ok.clone(), false)]);

    let csv = String::from_utf8(bytes(&p, "trajectory.csv")).unwrap();
    let state = |tick: u64, robot: u32| {
        csv.lines()
            .find(|l| l.starts_with(&format!("{tick},{robot},")))
            .map(|l| l.rsplit(',').next().unwrap().to_string())
            .unwrap()
    };
    assert_eq!(state(99, 3), "active");
    assert_eq!(state(100, 3), "frozen");
    assert_eq!(state(149, 3), "frozen");
    assert_eq!(state(150, 3), "active");
    assert_eq!(state(249, 5), "active");
    assert_eq!(state(250, 5), "restarting");
    assert_eq!(state(264, 5), "restarting");
    assert_eq!(state(265, 5), "active");
    // The fresh process announced itself to the consensus with a Boot note when it rejoined.
    let events = String::from_utf8(bytes(&p, "events.jsonl")).unwrap();
    assert!(
        events.lines().any(|l| l
            .starts_with(r#"{"event":"note","tick":265,"robot":5,"note":{"consensus":{"boot""#)),
        "no boot note of the fresh robot 5"
    );
}

#[test]
fn without_stable_storage_a_restarted_robot_forgets_and_the_checker_says_so() {
    let tmp = tempfile::tempdir().unwrap();
    let (p, q) = run_restarts(tmp.path(), "consensus.storage=false");
    let c = &metrics(&p)["consensus"];
    assert!(
        c["amnesia_restarts"].as_u64().unwrap() >= 1,
        "a fresh process without storage has lost its Raft state: {c}"
    );
    assert_eq!(metrics(&q)["consensus"], *c);
    assert!(!p.join("storage/raft-5.state").exists(), "nothing stored");
}

#[test]
fn a_frozen_process_is_really_stopped_and_a_restarted_one_really_new() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("run");
    let child = start_long_run(
        &dir,
        &[
            "--set",
            "faults.freeze=[{robot=3,from=2000,to=1000000}]",
            "--set",
            "faults.restart=[{tick=2000,robot=1}]",
        ],
    );
    // The faults come ~1 s after the run is seen at tick 20 (it steps ~2,700 ticks/s), so
    // the first process list below still holds robot 1's first incarnation even when this
    // thread is slow to get there (at tick 40 a loaded machine lost that race).
    let first = children_of(child.id());
    let pid_of = |children: &[(i32, String)], robot: u32| {
        children
            .iter()
            .filter(|(_, c)| c.contains("swarm-agent") && c.contains(&format!("--robot {robot} ")))
            .map(|(p, c)| (*p, c.clone()))
            .collect::<Vec<_>>()
    };
    let frozen = pid_of(&first, 3)[0].0;
    let old = pid_of(&first, 1)[0].0;
    wait_until("robot 3's process to be stopped", LIMIT, || {
        std::fs::read_to_string(format!("/proc/{frozen}/stat"))
            .is_ok_and(|s| s.rsplit_once(')').unwrap().1.trim_start().starts_with('T'))
    });
    wait_until("robot 1's fresh process", LIMIT, || {
        let now = pid_of(&children_of(child.id()), 1);
        !alive(old) && now.len() == 1 && now[0].1.contains("--incarnation 1 ")
    });
    let fresh = pid_of(&children_of(child.id()), 1)[0].0;
    // The run goes on without robot 3 and with the fresh robot 1.
    let at = last_tick(&dir);
    wait_until("the run to go on", LIMIT, || last_tick(&dir) > at + 50);
    unsafe {
        libc::kill(child.id() as i32, libc::SIGINT);
    }
    let out = wait_with_watchdog(child, LIMIT);
    assert_ok(&out);
    let m = metrics(&dir);
    // Thawed at the end, the stopped robot saw the shutdown and exited by itself.
    assert_eq!(
        processes_of(&m, 3),
        vec![(0, "exited with code 0".to_string(), false)]
    );
    assert_eq!(processes_of(&m, 1).len(), 2, "{m}");
    assert_eq!(m["unscheduled_deaths"], serde_json::json!([]), "{m}");
    let mut all = first.clone();
    all.push((fresh, "fresh robot 1".into()));
    assert_nothing_left(&all, &run_id_of(&first));
}

#[test]
fn a_robot_stopped_from_outside_is_declared_unresponsive_and_killed() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("run");
    let child = start_long_run(
        &dir,
        &[
            "--set",
            "scenario.deadline_ms=200",
            "--set",
            "scenario.unresponsive_ms=1500",
        ],
    );
    let children = children_of(child.id());
    let victim = children
        .iter()
        .find(|(_, c)| c.contains("swarm-agent") && c.contains("--robot 6 "))
        .map(|(p, _)| *p)
        .unwrap();
    unsafe {
        libc::kill(victim, libc::SIGSTOP);
    }
    wait_until("the unresponsive robot to be killed", LIMIT, || {
        !alive(victim)
    });
    let at = last_tick(&dir);
    wait_until("the run to go on without it", LIMIT, || {
        last_tick(&dir) > at + 50
    });
    unsafe {
        libc::kill(child.id() as i32, libc::SIGINT);
    }
    let out = wait_with_watchdog(child, LIMIT);
    assert_ok(&out);
    let m = metrics(&dir);
    assert_eq!(m["dead"], 1, "{m}");
    assert_eq!(m["unscheduled_deaths"][0]["robot"], 6, "{m}");
    assert_eq!(m["reproducible"], false, "{m}");
    assert!(m["shell"]["late"].as_u64().unwrap() >= 1, "{m}");
    let events = String::from_utf8(bytes(&dir, "events.jsonl")).unwrap();
    assert!(
        events.lines().any(|l| l.contains(r#""event":"died""#)
            && l.contains(r#""robot":6"#)
            && l.contains("unresponsive")),
        "{events}"
    );
    assert_nothing_left(&children, &run_id_of(&children));
}

#[test]
fn random_faults_from_the_seed_replay_in_both_modes() {
    let tmp = tempfile::tempdir().unwrap();
    let (p, _) = run_both_modes(
        tmp.path(),
        &[
            "configs/goto_simple.toml",
            "--ticks",
            "400",
            "--set",
            "scenario.stop_when_done=false",
            "--set",
            "faults.kill_rate=0.0005",
            "--set",
            "faults.freeze_rate=0.004",
            "--set",
            "faults.freeze_ticks=15",
        ],
    );
    let m = metrics(&p);
    let events = String::from_utf8(bytes(&p, "events.jsonl")).unwrap();
    let random = |fault: &str| {
        events
            .lines()
            .filter(|l| {
                l.contains(&format!(r#""fault":"{fault}""#)) && l.contains(r#""random":true"#)
            })
            .count() as u64
    };
    assert!(random("freeze") >= 3, "{events}");
    assert_eq!(
        m["faults_injected"].as_u64().unwrap(),
        random("freeze") + random("kill"),
        "{m}"
    );
    assert_eq!(m["dead"].as_u64().unwrap(), random("kill"), "{m}");
    assert_eq!(m["reproducible"], true, "{m}");
    assert_eq!(m["unscheduled_deaths"], serde_json::json!([]), "{m}");
}
