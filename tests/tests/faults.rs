//! The fault schedule: the world applies faults at tick boundaries and the orchestrator sends
//! the real SIGKILL, so a faulted run still replays bit for bit from its seed.

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

#[test]
fn a_scheduled_kill_signals_the_real_process_and_the_run_replays() {
    let tmp = tempfile::tempdir().unwrap();
    let run = |name: &str, extra: &[&str]| {
        let dir = tmp.path().join(name);
        let mut args = vec!["run", "configs/goto_simple.toml", "--ticks", "300", "--out"];
        args.push(dir.to_str().unwrap());
        args.extend_from_slice(&FAULTS);
        args.extend_from_slice(extra);
        assert_ok(&swarm(&args, LIMIT));
        dir
    };
    let p = run("processes", &[]);
    let q = run("in-process", &["--in-process"]);
    for f in ["trajectory.csv", "events.jsonl"] {
        assert!(bytes(&p, f) == bytes(&q, f), "{f} differs between modes");
    }
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
    let child = start_long_run(&dir, &["--set", "faults.kill=[{tick=80,robot=2}]"]);
    let children = children_of(child.id());
    let victim = children
        .iter()
        .find(|(_, c)| c.contains("swarm-agent") && c.contains("--robot 2 "))
        .map(|(p, _)| *p)
        .expect("robot 2 runs");
    wait_until("the scheduled kill", LIMIT, || !alive(victim));
    assert!(last_tick(&dir) >= 80);
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
    ] {
        let out = swarm(&["check", "configs/goto_simple.toml", "--set", set], LIMIT);
        assert_eq!(out.status.code(), Some(2), "{set}");
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(err.contains(key), "{set}: {err}");
        assert_eq!(err.lines().count(), 1, "{err}");
    }
}
