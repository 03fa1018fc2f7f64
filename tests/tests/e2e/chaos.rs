//! Nothing lost, nothing hung, nothing leaked, under many random faults: seeded process-mode
//! runs whose schedule draws random kills, freezes and a restart inside the run, while this
//! test sends real signals from outside, to robots and, in separate runs, to the world.
//!
//! Every run must end within a bound, leave no process and no file of its run in /dev/shm or
//! the iceoryx2 root, and leave records that are whole and parse: a killed world yields a run
//! marked failed with the records up to its last tick.

use std::collections::BTreeMap;
use std::path::Path;
use std::time::Duration;
use swarmrt_tests::*;

/// How long an orchestrator may take to end once the test has stopped disturbing it.
const BOUND: Duration = Duration::from_secs(60);
/// Seeded runs with robots disturbed from outside.
const ROBOT_RUNS: u64 = 8;
/// Seeded runs with the world disturbed from outside.
const WORLD_RUNS: u64 = 4;

/// SplitMix64: the test's own seeded choices.
struct Dice(u64);

impl Dice {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }
    fn below(&mut self, n: u64) -> u64 {
        self.next() % n
    }
    fn sleep(&mut self, lo_ms: u64, hi_ms: u64) {
        std::thread::sleep(Duration::from_millis(lo_ms + self.below(hi_ms - lo_ms)));
    }
}

fn signal(pid: i32, sig: i32) {
    unsafe {
        libc::kill(pid, sig);
    }
}

/// Children of the orchestrator seen so far (restarts add processes during the run).
fn look(parent: u32, seen: &mut BTreeMap<i32, String>) {
    for (pid, cmd) in children_of(parent) {
        seen.entry(pid).or_insert(cmd);
    }
}

/// Checks that a finished run's records are whole and parse; returns the last tick.
fn assert_records_whole(dir: &Path, robots: usize) -> u64 {
    let csv = String::from_utf8(bytes(dir, "trajectory.csv")).unwrap();
    assert!(csv.ends_with('\n'), "torn last line");
    let mut lines = csv.lines();
    assert_eq!(lines.next(), Some("tick,id,x,y,theta,v,omega,lidar,state"));
    let mut per_tick: BTreeMap<u64, usize> = BTreeMap::new();
    for l in lines {
        let f: Vec<&str> = l.split(',').collect();
        assert_eq!(f.len(), 9, "bad row {l:?}");
        let tick: u64 = f[0].parse().unwrap();
        for x in &f[2..7] {
            x.parse::<f64>()
                .unwrap_or_else(|_| panic!("bad number in {l:?}"));
        }
        assert!(
            ["active", "down", "dead", "frozen", "restarting"].contains(&f[8]),
            "{l:?}"
        );
        *per_tick.entry(tick).or_default() += 1;
    }
    let last = *per_tick.keys().last().expect("at least tick 0");
    assert_eq!(
        per_tick.len() as u64,
        last + 1,
        "ticks 0..={last} each recorded"
    );
    assert!(per_tick.values().all(|&c| c == robots), "whole ticks only");
    let events = String::from_utf8(bytes(dir, "events.jsonl")).unwrap();
    assert!(events.is_empty() || events.ends_with('\n'));
    for l in events.lines() {
        let v: serde_json::Value = serde_json::from_str(l).unwrap_or_else(|e| panic!("{l:?}: {e}"));
        assert!(
            v["event"].is_string() && v["tick"].as_u64().unwrap() <= last,
            "{l}"
        );
    }
    last
}

/// One seeded run: starts it, disturbs it from outside, ends it, checks what it left.
/// Returns what it did and how many faults the schedule itself injected.
fn chaos_run(seed: u64, disturb_world: bool) -> (String, u64) {
    let mut dice = Dice(seed.wrapping_mul(0x2545_f491_4f6c_dd1d) ^ disturb_world as u64);
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("run");
    let seed_arg = format!("scenario.seed={seed}");
    let restart = format!(
        "faults.restart=[{{tick={},robot={},down_ticks={}}}]",
        30 + dice.below(200),
        dice.below(9),
        1 + dice.below(20)
    );
    let child = start_long_run(
        &dir,
        &[
            "--set",
            &seed_arg,
            "--set",
            "faults.kill_rate=0.0002",
            "--set",
            "faults.freeze_rate=0.001",
            "--set",
            "faults.freeze_ticks=25",
            "--set",
            &restart,
            "--set",
            "scenario.deadline_ms=200",
            "--set",
            "scenario.unresponsive_ms=1500",
        ],
    );
    let orchestrator = child.id();
    let mut seen = BTreeMap::new();
    look(orchestrator, &mut seen);
    let run_id = run_id_of(&seen.clone().into_iter().collect::<Vec<_>>());
    let world = *seen
        .iter()
        .find(|(_, c)| c.contains("swarm-world"))
        .unwrap()
        .0;
    let robot_pids = |seen: &BTreeMap<i32, String>| -> Vec<i32> {
        seen.iter()
            .filter(|(p, c)| c.contains("swarm-agent") && alive(**p))
            .map(|(p, _)| *p)
            .collect()
    };

    let mut log = Vec::new();
    let mut world_killed = false;
    for _ in 0..4 {
        dice.sleep(50, 400);
        look(orchestrator, &mut seen);
        if disturb_world && !world_killed && dice.below(3) == 0 {
            match dice.below(3) {
                0 => {
                    signal(world, libc::SIGKILL);
                    world_killed = true;
                    log.push("kill world".to_string());
                }
                _ => {
                    signal(world, libc::SIGSTOP);
                    dice.sleep(100, 800);
                    signal(world, libc::SIGCONT);
                    log.push("freeze world".to_string());
                }
            }
            continue;
        }
        let robots = robot_pids(&seen);
        let Some(&victim) = robots.get(dice.below(robots.len().max(1) as u64) as usize) else {
            continue;
        };
        match dice.below(3) {
            0 => {
                signal(victim, libc::SIGKILL);
                log.push(format!("kill {victim}"));
            }
            1 => {
                signal(victim, libc::SIGSTOP);
                dice.sleep(50, 600);
                signal(victim, libc::SIGCONT);
                log.push(format!("freeze {victim} briefly"));
            }
            _ => {
                // Left stopped: the world declares it unresponsive and it is killed.
                signal(victim, libc::SIGSTOP);
                log.push(format!("stop {victim} for good"));
            }
        }
    }
    if disturb_world && !world_killed {
        signal(world, libc::SIGKILL);
        world_killed = true;
        log.push("kill world".to_string());
    }
    look(orchestrator, &mut seen);
    if !world_killed {
        // Ctrl-C ends a run that would otherwise go on for 100,000 ticks.
        signal(orchestrator as i32, libc::SIGINT);
    }
    let out = wait_with_watchdog(child, BOUND);
    let what = format!("seed {seed}: {log:?}");
    assert_eq!(
        out.status.code(),
        Some(if world_killed { 1 } else { 0 }),
        "{what}\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let all: Vec<(i32, String)> = seen.into_iter().collect();
    assert_nothing_left(&all, &run_id);

    let m = metrics(&dir);
    assert_eq!(m["failed"], world_killed, "{what}: {m}");
    let last = assert_records_whole(&dir, 9);
    assert_eq!(m["ticks"].as_u64(), Some(last), "{what}: {m}");
    for p in m["processes"].as_array().expect("processes listed") {
        assert_ne!(p["end"], "not reaped", "{what}: {p}");
    }
    if log
        .iter()
        .any(|l| l.starts_with("kill ") && !l.contains("world"))
    {
        // A robot killed from outside is an unscheduled death: the run says it cannot be
        // replayed.
        assert_eq!(m["reproducible"], false, "{what}: {m}");
        assert!(
            !m["unscheduled_deaths"].as_array().unwrap().is_empty(),
            "{what}: {m}"
        );
    }
    (what, m["faults_injected"].as_u64().unwrap_or(0))
}

#[test]
fn random_faults_against_robots_never_hang_lose_or_leak() {
    let start = std::time::Instant::now();
    let mut scheduled = 0;
    for seed in 0..ROBOT_RUNS {
        let (what, faults) = chaos_run(seed, false);
        eprintln!("ok {what}, {faults} scheduled faults");
        scheduled += faults;
    }
    let secs = start.elapsed().as_secs_f64();
    eprintln!("{ROBOT_RUNS} runs in {secs:.1} s");
    assert!(
        scheduled >= ROBOT_RUNS,
        "the schedule's own faults fired too: {scheduled}"
    );
}

#[test]
fn random_faults_against_the_world_never_hang_lose_or_leak() {
    let start = std::time::Instant::now();
    for seed in 100..100 + WORLD_RUNS {
        let (what, _) = chaos_run(seed, true);
        eprintln!("ok {what}");
    }
    let secs = start.elapsed().as_secs_f64();
    eprintln!("{WORLD_RUNS} runs in {secs:.1} s");
}
