//! Seed 002 end to end: three UAV processes fly the routes the Raft leader planned and
//! committed, to their goals without a conflict or a collision, over a clean and a lossy,
//! late radio; killing the leader mid-flight still brings the others home; both modes write
//! the same bytes; `swarm plan` prints the routes.

use std::path::Path;
use std::time::Duration;

use swarmrt_tests::{assert_modes_agree_with_loss, assert_ok, bytes, run_config, swarm};

const CONFIG: &str = "configs/planner_uav3.toml";
const LEADER_DIES: &str = "configs/planner_uav3_leader_dies.toml";

/// Rows of `trajectory.csv` as (tick, id, [x, y, z], state).
fn rows(dir: &Path) -> Vec<(u64, u32, [f64; 3], String)> {
    let text = String::from_utf8(bytes(dir, "trajectory.csv")).unwrap();
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let col = |name: &str| {
        header
            .iter()
            .position(|h| *h == name)
            .unwrap_or_else(|| panic!("no `{name}` column in {header:?}"))
    };
    let (t, id, x, y, z, st) = (
        col("tick"),
        col("id"),
        col("x"),
        col("y"),
        col("z"),
        col("state"),
    );
    lines
        .map(|l| {
            let f: Vec<&str> = l.split(',').collect();
            (
                f[t].parse().unwrap(),
                f[id].parse().unwrap(),
                [
                    f[x].parse().unwrap(),
                    f[y].parse().unwrap(),
                    f[z].parse().unwrap(),
                ],
                f[st].to_string(),
            )
        })
        .collect()
}

/// The goals of planner_uav3, by robot id.
const GOALS: [[f64; 3]; 3] = [[8.5, 13.5, 1.5], [5.5, 13.5, 3.5], [2.5, 13.5, 1.5]];

/// Checks from the trajectory alone (independently of the metrics): at every tick every two
/// UAVs are more than two radii plus a margin apart, no UAV ever shares a grid cell (d = 1 m)
/// with another within delta = 1 s (10 ticks), and each UAV in `home` ends within its goal
/// radius (0.3 m).
fn assert_safe_and_home(dir: &Path, home: &[u32]) {
    let rows = rows(dir);
    let last = rows.iter().map(|r| r.0).max().unwrap();
    let cell = |p: [f64; 3]| {
        (
            p[0].floor() as i64,
            p[1].floor() as i64,
            p[2].floor() as i64,
        )
    };
    let mut held: Vec<((i64, i64, i64), u64, u32)> = Vec::new();
    for tick in 0..=last {
        let now: Vec<&(u64, u32, [f64; 3], String)> = rows.iter().filter(|r| r.0 == tick).collect();
        for (a, ra) in now.iter().enumerate() {
            for rb in &now[a + 1..] {
                let d = (0..3)
                    .map(|k| (ra.2[k] - rb.2[k]).powi(2))
                    .sum::<f64>()
                    .sqrt();
                assert!(
                    d > 0.6,
                    "{}: UAVs {} and {} {d:.3} m apart at tick {tick}",
                    dir.display(),
                    ra.1,
                    rb.1
                );
            }
            let c = cell(ra.2);
            for &(c2, t2, v2) in &held {
                assert!(
                    !(c2 == c && v2 != ra.1 && tick <= t2 + 10),
                    "{}: UAV {} entered cell {c:?} at tick {tick}, {} ticks after UAV {v2} held it",
                    dir.display(),
                    ra.1,
                    tick - t2
                );
            }
        }
        for r in &now {
            if r.3 == "active" || r.3 == "dead" {
                held.push((cell(r.2), tick, r.1));
            }
        }
        held.retain(|&(_, t, _)| tick <= t + 10);
    }
    for &id in home {
        let end = rows.iter().rfind(|r| r.1 == id).unwrap();
        let g = GOALS[id as usize];
        let off = (0..3)
            .map(|k| (end.2[k] - g[k]).powi(2))
            .sum::<f64>()
            .sqrt();
        assert!(
            off < 0.3,
            "{}: UAV {id} ended {off:.3} m from its goal",
            dir.display()
        );
        assert_eq!(end.3, "active", "UAV {id}");
    }
}

#[test]
fn three_uav_processes_reach_their_goals_with_no_conflict_and_no_collision() {
    let tmp = tempfile::tempdir().unwrap();
    for (name, extra) in [
        ("clean", &[][..]),
        (
            "lossy",
            &["--set", "radio.loss=0.2", "--set", "radio.delay_ticks=2"][..],
        ),
    ] {
        let dir = tmp.path().join(name);
        let m = run_config(CONFIG, &dir, extra);
        assert_eq!(m["mode"], "processes");
        let p = &m["planner"];
        assert_eq!(p["reached"], 3, "{name}: {p}");
        assert_eq!(p["conflicts"], 0, "{name}: {p}");
        assert_eq!(p["collisions"], 0, "{name}: {p}");
        assert_eq!(m["collisions"], 0, "{name}: {m}");
        assert!(p["plans"].as_u64().unwrap() >= 1, "{name}: {p}");
        // Every route the leader planned has a cost and expansions of its own.
        let routes = p["routes"].as_array().unwrap();
        assert!(routes.len() >= 3, "{name}: {p}");
        assert!(
            routes.iter().all(|r| r["cost"].as_f64().unwrap() > 0.0),
            "{p}"
        );
        assert!(p["min_separation"].as_f64().unwrap() > 0.6, "{name}: {p}");
        assert_safe_and_home(&dir, &[0, 1, 2]);
        // Aerial records carry the height, and the figures a side view.
        let header = String::from_utf8(bytes(&dir, "trajectory.csv")).unwrap();
        assert!(header.starts_with("tick,id,x,y,z,theta,v,vz,omega,lidar,state\n"));
        assert!(dir.join("trajectory_side.png").exists());
    }
}

#[test]
fn killing_the_leader_mid_flight_still_brings_the_others_home_without_a_collision() {
    let tmp = tempfile::tempdir().unwrap();
    for policy in ["continue", "hover"] {
        let dir = tmp.path().join(policy);
        let set = format!("behaviour.on_leader_loss=\"{policy}\"");
        let m = run_config(LEADER_DIES, &dir, &["--set", &set]);
        leader_killed_mid_flight(&dir, &m, policy);
    }
}

/// What a leader killed at tick 120 leaves: the two others home, safe, and in `continue`
/// (the paper's autonomy) on the routes the dead leader planned, without a new plan.
fn leader_killed_mid_flight(dir: &Path, m: &serde_json::Value, policy: &str) {
    let p = &m["planner"];
    // Exactly one robot died: the leader at tick 120, while all three were flying.
    let events = String::from_utf8(bytes(dir, "events.jsonl")).unwrap();
    let died: Vec<&str> = events
        .lines()
        .filter(|l| l.contains("\"event\":\"died\""))
        .collect();
    assert_eq!(died.len(), 1, "{died:?}");
    assert!(died[0].contains("\"tick\":120"), "{}", died[0]);
    let dead: u32 = serde_json::from_str::<serde_json::Value>(died[0]).unwrap()["robot"]
        .as_u64()
        .unwrap() as u32;
    let flying_before = events
        .lines()
        .filter(|l| l.contains("\"flying\""))
        .filter(|l| {
            serde_json::from_str::<serde_json::Value>(l).unwrap()["tick"]
                .as_u64()
                .unwrap()
                < 120
        })
        .count();
    assert_eq!(
        flying_before, 3,
        "all three flew a committed route before the kill"
    );
    if policy == "hover" {
        // Everyone hovered and the new leader re-planned the two remaining routes.
        assert!(p["replans"].as_u64().unwrap() >= 1, "{p}");
    } else {
        // The survivors flew the committed routes on: no new plan, no stop, no detour.
        assert_eq!(p["replans"], 0, "{p}");
        assert_eq!(p["hovers"], 0, "{p}");
        assert_eq!(p["detours"], 0, "{p}");
    }
    assert_eq!(p["reached"], 2, "{policy}: {p}");
    assert_eq!(p["collisions"], 0, "{policy}: {p}");
    assert_eq!(p["conflicts"], 0, "{policy}: {p}");
    let home: Vec<u32> = (0..3).filter(|&v| v != dead).collect();
    assert_safe_and_home(dir, &home);
}

#[test]
fn with_the_leader_cut_off_in_a_minority_the_majority_flies_on() {
    // Seed 1's leader is robot 2 (asserted below); from tick 120 it hears no one.
    let tmp = tempfile::tempdir().unwrap();
    for policy in ["continue", "hover"] {
        let dir = tmp.path().join(policy);
        let set = format!("behaviour.on_leader_loss=\"{policy}\"");
        let m = run_config(
            CONFIG,
            &dir,
            &[
                "--set",
                &set,
                "--set",
                "faults.partition=[{from=120,to=900,groups=[[2]]}]",
            ],
        );
        let events = String::from_utf8(bytes(&dir, "events.jsonl")).unwrap();
        let first_leader = events
            .lines()
            .find(|l| l.contains("\"role\":\"leader\""))
            .unwrap();
        assert!(first_leader.contains("\"robot\":2"), "{first_leader}");
        let p = &m["planner"];
        assert_eq!(p["conflicts"], 0, "{policy}: {p}");
        assert_eq!(p["collisions"], 0, "{policy}: {p}");
        if policy == "continue" {
            // All three fly on: the majority without its leader, the leader alone.
            assert_eq!(p["reached"], 3, "{p}");
            assert_eq!(p["plans"], 1, "{p}");
            assert_safe_and_home(&dir, &[0, 1, 2]);
        } else {
            // The majority elects a leader who re-plans it; the old one hovers for good,
            // and the run ends when it stalls.
            assert_eq!(p["reached"], 2, "{p}");
            assert!(m["stalled"]["robots"] == serde_json::json!([2]), "{m}");
        }
    }
}

#[test]
fn a_uav_whose_route_a_dead_uav_blocks_plans_a_detour_on_board_and_arrives() {
    // Robot 0 dies at tick 200 where robot 1's route passes later (within the safe zone).
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("blocked");
    let m = run_config(CONFIG, &dir, &["--set", "faults.kill=[{tick=200,robot=0}]"]);
    let p = &m["planner"];
    let events = String::from_utf8(bytes(&dir, "events.jsonl")).unwrap();
    let detours: Vec<serde_json::Value> = events
        .lines()
        .map(|l| serde_json::from_str::<serde_json::Value>(l).unwrap())
        .filter(|e| e["note"]["detour"].is_object())
        .collect();
    assert_eq!(detours.len(), 1, "{detours:?}");
    assert_eq!(detours[0]["robot"], 1, "{detours:?}");
    assert!(detours[0]["tick"].as_u64().unwrap() > 200, "{detours:?}");
    assert_eq!(p["detours"], 1, "{p}");
    assert_eq!(p["plans"], 1, "no leader re-planned: {p}");
    assert_eq!(p["reached"], 2, "{p}");
    assert_eq!(p["conflicts"], 0, "{p}");
    assert_eq!(p["collisions"], 0, "{p}");
    assert_safe_and_home(&dir, &[1, 2]);
}

#[test]
fn both_modes_write_the_same_records_with_a_lossy_late_radio() {
    let tmp = tempfile::tempdir().unwrap();
    for (name, extra) in [
        (
            "hover",
            &["--set", "behaviour.on_leader_loss=\"hover\""][..],
        ),
        ("continue", &[][..]),
        // A dead UAV on robot 1's route: a detour planned on board and announced.
        ("detour", &["--set", "faults.kill=[{tick=200,robot=0}]"][..]),
    ] {
        let dir = tmp.path().join(name);
        std::fs::create_dir_all(&dir).unwrap();
        let m = assert_modes_agree_with_loss(
            &dir,
            LEADER_DIES,
            600,
            extra,
            &["trajectory.csv", "events.jsonl"],
        );
        assert_eq!(m["planner"]["collisions"], 0, "{name}: {m}");
        if name == "detour" {
            assert!(m["planner"]["detours"].as_u64().unwrap() >= 1, "{m}");
        }
    }
}

#[test]
fn swarm_plan_prints_each_route_from_start_to_goal_without_conflicts() {
    let out = swarm(&["plan", CONFIG, "--json"], Duration::from_secs(60));
    assert_ok(&out);
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(v["conflicts"], 0, "{v}");
    assert_eq!(v["slot_s"], 2.0);
    let routes = v["routes"].as_array().unwrap();
    assert_eq!(routes.len(), 3);
    for r in routes {
        let cells = r["cells"].as_array().unwrap();
        assert_eq!(cells[0]["cell"], r["start"], "{r}");
        assert_eq!(cells.last().unwrap()["cell"], r["goal"], "{r}");
        assert!(r["expansions"].as_u64().unwrap() > 0);
        for w in cells.windows(2) {
            // One slot per step, each step to a 26-neighbour or a wait.
            let dt = w[1]["t"].as_f64().unwrap() - w[0]["t"].as_f64().unwrap();
            assert_eq!(dt, 2.0, "{r}");
            let (a, b) = (
                w[0]["cell"].as_array().unwrap(),
                w[1]["cell"].as_array().unwrap(),
            );
            for (a, b) in a.iter().zip(b) {
                assert!(
                    (a.as_i64().unwrap() - b.as_i64().unwrap()).abs() <= 1,
                    "{r}"
                );
            }
        }
    }
    // The table form names every vehicle and the planning time.
    let out = swarm(&["plan", CONFIG], Duration::from_secs(60));
    assert_ok(&out);
    let text = String::from_utf8_lossy(&out.stdout);
    for v in 0..3 {
        assert!(text.contains(&format!("vehicle {v}: ")), "{text}");
    }
    assert!(text.contains("conflicts: 0; planning time:"), "{text}");
    assert!(
        v["plan_ms"]["per_route"].as_array().unwrap().len() == 3,
        "{v}"
    );
}

#[test]
fn planner_configs_that_cannot_fly_are_refused_with_the_key() {
    for (args, key) in [
        (vec!["plan", "configs/goto_simple.toml"], "behaviour.kind"),
        (
            vec!["check", CONFIG, "--set", "behaviour.cruise_speed=0.9"],
            "behaviour.cruise_speed",
        ),
        (vec!["check", CONFIG, "--set", "map.height=0"], "map.height"),
        (
            vec!["check", CONFIG, "--set", "robots.aerial.start_z=7.5"],
            "robots.aerial.start_z",
        ),
        (
            vec![
                "check",
                CONFIG,
                "--set",
                "map.circles=[{x=2.5,y=9.5,r=0.8,height=-1}]",
            ],
            "map.circles[0].height",
        ),
    ] {
        let out = swarm(&args, Duration::from_secs(60));
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{args:?}: {err}");
        assert!(err.contains(&format!("`{key}`")), "{args:?}: {err}");
        assert_eq!(err.lines().count(), 1, "{args:?}: {err}");
    }
}

#[test]
fn a_restarted_leader_process_rejoins_mid_air_and_every_uav_arrives() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("restart");
    let m = run_config(
        CONFIG,
        &dir,
        &[
            "--set",
            "faults.restart=[{tick=120,robot=\"leader\",down_ticks=20}]",
            "--set",
            "radio.loss=0.2",
            "--set",
            "radio.delay_ticks=2",
        ],
    );
    assert_eq!(m["restarts"], 1, "{m}");
    let p = &m["planner"];
    assert_eq!(p["reached"], 3, "{p}");
    assert_eq!(p["collisions"], 0, "{p}");
    // The fresh process finds its route's time passed: it detours on board (the paper's
    // autonomy) instead of waiting for everyone to hover and a new plan.
    assert!(p["detours"].as_u64().unwrap() >= 1, "{p}");
    assert_safe_and_home(&dir, &[0, 1, 2]);
}

#[test]
fn routes_longer_than_one_frame_commit_in_parts_and_are_flown_whole() {
    // 0.3 m cells: 45-56 moves a route, two log entries each.
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("parts");
    let m = run_config(
        CONFIG,
        &dir,
        &[
            "--in-process",
            "--set",
            "behaviour.cell=0.3",
            "--set",
            "radio.loss=0.2",
            "--set",
            "radio.delay_ticks=2",
        ],
    );
    let p = &m["planner"];
    let moves: Vec<u64> = p["routes"]
        .as_array()
        .unwrap()
        .iter()
        .map(|r| r["moves"].as_u64().unwrap())
        .collect();
    assert!(moves.iter().all(|&n| n > 32), "{moves:?}");
    let events = String::from_utf8(bytes(&dir, "events.jsonl")).unwrap();
    let parts = events.lines().filter(|l| l.contains("\"route\":{")).count();
    assert!(parts >= 2 * 3, "{parts} proposals of route parts");
    assert_eq!(p["reached"], 3, "{p}");
    assert_eq!(p["collisions"], 0, "{p}");
    assert_eq!(p["conflicts"], 0, "{p}");
}

#[test]
fn a_run_whose_uavs_all_stall_ends_early_with_the_reason_in_both_modes() {
    // Two of three UAVs die before any plan: the survivor has no majority, no leader plans,
    // and it hovers at its start for good.
    let tmp = tempfile::tempdir().unwrap();
    let mut dirs = Vec::new();
    for mode in ["processes", "in-process"] {
        let dir = tmp.path().join(mode);
        let mut args = vec![
            "run",
            CONFIG,
            "--out",
            dir.to_str().unwrap(),
            "--set",
            "faults.kill=[{tick=5,robot=1},{tick=5,robot=2}]",
            "--set",
            "scenario.stall_ticks=100",
            "--set",
            "behaviour.on_leader_loss=\"hover\"",
        ];
        if mode == "in-process" {
            args.push("--in-process");
        }
        let out = swarm(&args, Duration::from_secs(120));
        assert_ok(&out);
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(
            err.contains("run stalled at tick 101: robot 0 short of the goal")
                && err.contains("scenario.stall_ticks"),
            "{mode}: {err}"
        );
        let m = swarmrt_tests::metrics(&dir);
        assert_eq!(m["ticks"], 101, "{mode}: {m}");
        assert_eq!(
            m["stalled"]["robots"],
            serde_json::json!([0]),
            "{mode}: {m}"
        );
        assert_eq!(m["stalled"]["ticks"], 100, "{mode}: {m}");
        dirs.push(dir);
    }
    swarmrt_tests::assert_same_records(&dirs[0], &dirs[1], "a stalled run");
}
