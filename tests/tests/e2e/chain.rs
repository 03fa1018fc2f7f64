//! Seed 003 end to end: a head and 15 follower processes thread the serpentine corridor with
//! no collision and their rods within limits; a stationary robot's veto travels back to the
//! head robot by robot (Fig. 3); a middle robot initiates and drags both sub-chains; both
//! modes write the same bytes when positions and vetoes go over a lossy, late radio.

use std::path::Path;

use swarmrt_tests::{assert_modes_agree_with_loss, bytes, run_config};

/// Rows of `trajectory.csv` as (tick, id, x, y).
fn rows(dir: &Path) -> Vec<(u64, u32, f64, f64)> {
    let text = String::from_utf8(bytes(dir, "trajectory.csv")).unwrap();
    text.lines()
        .skip(1)
        .map(|l| {
            let f: Vec<&str> = l.split(',').collect();
            (
                f[0].parse().unwrap(),
                f[1].parse().unwrap(),
                f[2].parse().unwrap(),
                f[3].parse().unwrap(),
            )
        })
        .collect()
}

/// The longest rod between consecutive robots over the run, from the trajectory alone.
fn longest_rod(rows: &[(u64, u32, f64, f64)]) -> f64 {
    rows.windows(2)
        .filter(|w| w[0].0 == w[1].0 && w[1].1 == w[0].1 + 1)
        .map(|w| (w[1].2 - w[0].2).hypot(w[1].3 - w[0].3))
        .fold(0.0, f64::max)
}

/// How far robot `id` ever got from where it started.
fn excursion(rows: &[(u64, u32, f64, f64)], id: u32) -> f64 {
    let mine: Vec<_> = rows.iter().filter(|r| r.1 == id).collect();
    mine.iter()
        .map(|r| (r.2 - mine[0].2).hypot(r.3 - mine[0].3))
        .fold(0.0, f64::max)
}

#[test]
fn sixteen_robot_processes_thread_the_curved_corridor_without_a_collision() {
    let tmp = tempfile::tempdir().unwrap();
    let m = run_config("configs/chain_corridor.toml", tmp.path(), &[]);
    assert_eq!(m["mode"], "processes", "{m}");
    assert_eq!(m["collisions"], 0, "{m}");
    let c = &m["chain"];
    assert_eq!(c["collisions"], 0, "{c}");
    assert_eq!(c["reached"], 16, "{c}");
    assert_eq!(c["tail_reached"], true, "{c}");
    // Rods within limits (0.3-0.45 m) beyond the 5 cm tolerance in at most 0.1 % of rod-ticks.
    let (bad, all) = (
        c["rod_violations"].as_u64().unwrap(),
        c["rod_ticks"].as_u64().unwrap(),
    );
    assert!(all > 30_000 && bad * 1000 <= all, "{c}");
    let rows = rows(tmp.path());
    let longest = longest_rod(&rows);
    assert!(longest < 0.45 + 0.1, "a rod stretched to {longest:.3} m");
    // The run stopped because everyone threaded the goal, well before the tick limit.
    assert!(m["ticks"].as_u64().unwrap() < 6000, "{m}");
}

#[test]
fn a_stationary_robot_vetoes_and_the_veto_travels_back_to_the_head() {
    let tmp = tempfile::tempdir().unwrap();
    let m = run_config(
        "configs/chain_stationary.toml",
        tmp.path(),
        &["--ticks", "400"],
    );
    let c = &m["chain"];
    assert_eq!(c["veto_depth"], 6, "{c}");
    assert!(c["replans"].as_u64().unwrap() >= 1, "{c}");
    assert_eq!(c["collisions"], 0, "{c}");
    // The first veto: robot 6 objects, then 5, 4, ... 1 pass it on a tick apart, each one
    // deeper, and the head re-plans the tick after.
    let events = String::from_utf8(bytes(tmp.path(), "events.jsonl")).unwrap();
    let notes: Vec<serde_json::Value> = events
        .lines()
        .map(|l| serde_json::from_str::<serde_json::Value>(l).unwrap())
        .filter(|e| e["event"] == "note")
        .take(7)
        .collect();
    let first = notes[0]["tick"].as_u64().unwrap();
    for (k, n) in notes.iter().enumerate().take(6) {
        let robot = 6 - k as u64;
        assert_eq!(n["robot"], robot, "{n}");
        assert_eq!(n["tick"], first + k as u64, "{n}");
        assert_eq!(n["note"]["veto"]["master"], robot - 1, "{n}");
        assert_eq!(n["note"]["veto"]["depth"], k as u64 + 1, "{n}");
        let why = if k == 0 { "stationary" } else { "passed" };
        assert_eq!(n["note"]["veto"]["why"], why, "{n}");
    }
    assert_eq!(notes[6]["robot"], 0, "{}", notes[6]);
    assert_eq!(notes[6]["note"]["replan"]["depth"], 6, "{}", notes[6]);
    // The stationary robot and everything behind it never moved; the head did.
    let rows = rows(tmp.path());
    for id in 6..12 {
        assert!(excursion(&rows, id) < 1e-9, "robot {id} moved");
    }
    assert!(excursion(&rows, 0) > 0.2);
    // Pinned by robot 6, the head never got farther than six rods from it, plus what it
    // covers while the veto travels back (six ticks at 0.2 m/s, 0.12 m).
    let far = rows
        .iter()
        .filter(|r| r.1 == 0)
        .map(|r| (r.2 - 5.6).hypot(r.3 - 6.0))
        .fold(0.0, f64::max);
    assert!(
        far < 6.0 * 0.45 + 6.0 * 0.02 + 0.05,
        "head {far:.2} m from the stationary robot"
    );
}

#[test]
fn a_middle_robot_initiates_and_drags_both_sub_chains() {
    let tmp = tempfile::tempdir().unwrap();
    let m = run_config("configs/chain_middle.toml", tmp.path(), &["--in-process"]);
    let c = &m["chain"];
    assert_eq!(c["collisions"], 0, "{c}");
    assert!(c["propagation_ticks"].as_u64().is_some(), "{c}");
    let rows = rows(tmp.path());
    let last = rows.iter().map(|r| r.0).max().unwrap();
    let end = |id: u32| *rows.iter().find(|r| r.0 == last && r.1 == id).unwrap();
    // Robot 7 reached the goal at (6, 11); both ends followed it up from y = 3.
    assert!(
        (end(7).2 - 6.0).hypot(end(7).3 - 11.0) < 0.4 + 1e-9,
        "{:?}",
        end(7)
    );
    for id in [0, 14] {
        assert!(end(id).3 > 6.0, "robot {id} ended at {:?}", end(id));
    }
    // The connector angle at robot 7 kept the sub-chains apart: its neighbours did not meet.
    let gap = (end(6).2 - end(8).2).hypot(end(6).3 - end(8).3);
    assert!(gap > 0.4, "robots 6 and 8 {gap:.2} m apart");
}

#[test]
fn both_modes_write_the_same_bytes_with_positions_and_vetoes_over_a_lossy_radio() {
    let tmp = tempfile::tempdir().unwrap();
    let m = assert_modes_agree_with_loss(
        tmp.path(),
        "configs/chain_stationary.toml",
        300,
        &["--set", "behaviour.master_from=\"radio\""],
        &["trajectory.csv", "events.jsonl"],
    );
    assert!(m["chain"]["vetoes"].as_u64().unwrap() >= 1, "{m}");
}

#[test]
fn appendix_a_shake_threads_the_corridor_and_replays_byte_for_byte() {
    let tmp = tempfile::tempdir().unwrap();
    let shake = ["--set", "behaviour.rotate=\"shake\""];
    // The shake draws from the run seed's stream: both modes, the same bytes, with loss.
    let lossy = tmp.path().join("lossy");
    std::fs::create_dir_all(&lossy).unwrap();
    assert_modes_agree_with_loss(
        &lossy,
        "configs/chain_corridor.toml",
        1200,
        &shake,
        &["trajectory.csv", "events.jsonl"],
    );
    // It is not the trail: the same run with `rotate = "trail"` moves otherwise.
    let trail = tmp.path().join("trail");
    let mut args = vec!["--ticks", "1200", "--in-process"];
    args.extend_from_slice(&swarmrt_tests::LOSSY_RADIO);
    run_config("configs/chain_corridor.toml", &trail, &args);
    assert!(
        bytes(&trail, "trajectory.csv") != bytes(&lossy.join("in-process"), "trajectory.csv"),
        "rotate = \"shake\" changed nothing"
    );
    // With a clean radio the whole chain threads the corridor without a collision.
    let clean = tmp.path().join("clean");
    let mut args = vec!["--in-process"];
    args.extend_from_slice(&shake);
    let m = run_config("configs/chain_corridor.toml", &clean, &args);
    let c = &m["chain"];
    assert_eq!(c["collisions"], 0, "{c}");
    assert_eq!(c["reached"], 16, "{c}");
    assert_eq!(c["tail_reached"], true, "{c}");
}

/// Robot -> tick of its first move, from `chain_propagation.csv`.
fn first_moves(dir: &Path) -> Vec<(u32, u64)> {
    let text = String::from_utf8(bytes(dir, "chain_propagation.csv")).unwrap();
    text.lines()
        .skip(1)
        .map(|l| {
            let f: Vec<&str> = l.split(',').collect();
            (f[0].parse().unwrap(), f[1].parse::<f64>().unwrap() as u64)
        })
        .collect()
}

/// Ticks between the head's first move and the tail's (robot 15).
fn head_to_tail_lag(dir: &Path) -> i64 {
    let moves = first_moves(dir);
    let at = |id: u32| moves.iter().find(|m| m.0 == id).map(|m| m.1 as i64);
    at(15).expect("the tail moved") - at(0).expect("the head moved")
}

#[test]
fn in_tick_rounds_move_the_chain_as_one_body_and_replay_byte_for_byte() {
    let tmp = tempfile::tempdir().unwrap();
    let run = |name: &str, extra: &[&str]| {
        let dir = tmp.path().join(name);
        let mut args = vec!["--ticks", "300"];
        args.extend_from_slice(extra);
        (run_config("configs/chain_corridor.toml", &dir, &args), dir)
    };
    // Without rounds a motion travels one robot per tick: the tail moves 15 ticks after the
    // head. With enough rounds the whole chain reacts within the head's first tick.
    let (_, base) = run("base", &["--in-process"]);
    let (m, rounds) = run("rounds", &["--in-process", "--set", "radio.rounds=64"]);
    assert!(head_to_tail_lag(&base) >= 14, "{:?}", first_moves(&base));
    assert!(head_to_tail_lag(&rounds) <= 1, "{:?}", first_moves(&rounds));
    let r = &m["rounds"];
    assert_eq!(r["max_in_a_tick"], 15, "{r}");
    assert_eq!(r["capped_ticks"], 0, "{r}");
    assert_eq!(r["rejected"], 0, "{r}");
    assert!(r["rounds"].as_u64().unwrap() > 1000, "{r}");
    assert_eq!(m["chain"]["collisions"], 0, "{m}");
    assert!(
        m.get("rounds").is_some() && run_metrics_lacks_rounds(&base),
        "{m}"
    );
    // A cap of 4 rounds: the motion gets 5 robots down the chain per tick, the rest is
    // dropped as capped and carried on by the next tick.
    let (m, capped) = run("capped", &["--in-process", "--set", "radio.rounds=4"]);
    assert_eq!(m["rounds"]["max_in_a_tick"], 4, "{m}");
    assert!(m["rounds"]["capped_ticks"].as_u64().unwrap() > 0, "{m}");
    let lag = head_to_tail_lag(&capped);
    assert!(lag > 1 && lag < head_to_tail_lag(&base), "lag {lag}");
    // As robot processes with 30 % loss and a robot killed mid-run: the same bytes as in
    // one process, and no round waits for the dead robot.
    let lossy = [
        "--set",
        "radio.rounds=64",
        "--set",
        "radio.loss=0.3",
        "--set",
        "faults.kill=[{tick=150,robot=8}]",
    ];
    let (a, pa) = run("lossy_processes", &lossy);
    let mut ip = lossy.to_vec();
    ip.push("--in-process");
    let (b, pb) = run("lossy_in_process", &ip);
    assert_eq!(a["mode"], "processes", "{a}");
    for file in ["trajectory.csv", "events.jsonl"] {
        assert!(
            bytes(&pa, file) == bytes(&pb, file),
            "{file} differs between modes"
        );
    }
    assert_eq!(a["rounds"], b["rounds"], "{a} {b}");
    assert!(b["rounds"]["dropped"].as_u64().unwrap() > 0, "{b}");
    assert_eq!(b["dead"], 1, "{b}");
    assert_eq!(b["ticks"], 300, "{b}");
}

fn run_metrics_lacks_rounds(dir: &Path) -> bool {
    swarmrt_tests::metrics(dir).get("rounds").is_none()
}

#[test]
fn rounds_are_refused_where_they_cannot_hold() {
    let tmp = tempfile::tempdir().unwrap();
    let refused = |extra: &[&str], says: &str| {
        let out = tmp.path().join("refused");
        let mut args = vec![
            "run",
            "configs/chain_corridor.toml",
            "--out",
            out.to_str().unwrap(),
        ];
        args.extend_from_slice(extra);
        let o = swarmrt_tests::swarm(&args, std::time::Duration::from_secs(60));
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{err}");
        assert!(err.contains("radio.rounds") && err.contains(says), "{err}");
    };
    refused(
        &["--set", "radio.rounds=8", "--set", "radio.delay_ticks=1"],
        "delay_ticks = 1",
    );
    refused(&["--set", "radio.rounds=8", "--realtime"], "--realtime");
    refused(&["--set", "radio.rounds=10001"], "10000");
}

#[test]
fn with_rounds_the_heads_motion_reaches_the_tail_of_451_robots_within_its_tick() {
    // Only the initiator starts rounds (round k wakes robot k), so a tick of 450 rounds is
    // one in which robot 450 reacted to the head's motion of that very tick.
    let tmp = tempfile::tempdir().unwrap();
    let args = ["--ticks", "30", "--set", "radio.rounds=1024"];
    let (pa, pb) = (tmp.path().join("processes"), tmp.path().join("in-process"));
    let a = run_config("configs/chain_450.toml", &pa, &args);
    let mut ip = args.to_vec();
    ip.push("--in-process");
    let b = run_config("configs/chain_450.toml", &pb, &ip);
    assert_eq!(a["mode"], "processes", "{a}");
    for file in ["trajectory.csv", "events.jsonl"] {
        assert!(
            bytes(&pa, file) == bytes(&pb, file),
            "{file} differs between modes"
        );
    }
    let r = &a["rounds"];
    assert_eq!(r["max_in_a_tick"], 450, "{r}");
    assert_eq!(r["capped_ticks"], 0, "{r}");
    assert_eq!(a["rounds"], b["rounds"], "{a} {b}");
    let c = &a["chain"];
    assert_eq!(c["rod_violations"], 0, "{c}");
    assert_eq!(c["angle_violations"], 0, "{c}");
    assert_eq!(c["collisions"], 0, "{c}");
}
