//! Seed 001 end to end: S1 with eight robot processes ends on a circle around the goal without
//! a collision; S2's three groups find the goal; both modes write the same bytes with a lossy,
//! late radio.

use std::f64::consts::TAU;
use std::path::Path;
use swarmrt_tests::{assert_modes_agree_with_loss, bytes, run_config};

fn run(config: &str, dir: &Path, extra: &[&str]) -> serde_json::Value {
    run_config(config, dir, extra)
}

/// The last tick's (id, x, y) rows of `trajectory.csv`.
fn last_positions(dir: &Path) -> Vec<(u32, f64, f64)> {
    let text = String::from_utf8(bytes(dir, "trajectory.csv")).unwrap();
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let col = |name: &str| header.iter().position(|h| *h == name).unwrap();
    let (tick, id, x, y) = (col("tick"), col("id"), col("x"), col("y"));
    let rows: Vec<Vec<&str>> = lines.map(|l| l.split(',').collect()).collect();
    let last = rows.last().unwrap()[tick];
    rows.iter()
        .filter(|r| r[tick] == last)
        .map(|r| {
            (
                r[id].parse().unwrap(),
                r[x].parse().unwrap(),
                r[y].parse().unwrap(),
            )
        })
        .collect()
}

/// Within this many metres of its slot's circle, and this many degrees of even spacing.
const RADIUS_TOLERANCE: f64 = 0.25;
const ANGLE_TOLERANCE_DEG: f64 = 15.0;

#[test]
fn s1_eight_robot_processes_end_on_a_circle_at_the_goal_without_a_collision() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("s1");
    let m = run("configs/grouping_s1.toml", &dir, &[]);
    assert_eq!(m["mode"], "processes");
    assert_eq!(m["collisions"], 0, "{m}");
    let g = &m["grouping"];
    assert_eq!(g["groups"], 1, "{g}");
    assert_eq!(g["leaders"], 1, "{g}");
    assert_eq!(g["reached"], 8, "{g}");
    assert!(g["precision"].as_f64().unwrap() > 0.9, "{g}");
    // The run stops once all eight are in the goal; the circle (radius 1 m) is then whole.
    let pos = last_positions(&dir);
    assert_eq!(pos.len(), 8);
    let (cx, cy) = (
        pos.iter().map(|p| p.1).sum::<f64>() / 8.0,
        pos.iter().map(|p| p.2).sum::<f64>() / 8.0,
    );
    let mut angles: Vec<f64> = pos
        .iter()
        .map(|p| {
            let r = ((p.1 - cx).powi(2) + (p.2 - cy).powi(2)).sqrt();
            assert!(
                (r - 1.0).abs() < RADIUS_TOLERANCE,
                "robot {} is {r:.2} m from the COG",
                p.0
            );
            (p.2 - cy).atan2(p.1 - cx)
        })
        .collect();
    angles.sort_by(f64::total_cmp);
    for k in 0..8 {
        let gap = (angles[(k + 1) % 8] - angles[k])
            .rem_euclid(TAU)
            .to_degrees();
        assert!(
            (gap - 45.0).abs() < ANGLE_TOLERANCE_DEG,
            "gap {gap:.1}° in {angles:?}"
        );
    }
}

#[test]
fn s2_records_are_identical_in_both_modes_with_loss_and_delay() {
    let tmp = tempfile::tempdir().unwrap();
    let files = ["trajectory.csv", "events.jsonl"];
    let m = assert_modes_agree_with_loss(tmp.path(), "configs/grouping_s2.toml", 500, &[], &files);
    // By tick 500 the three groups have chosen their leaders and formed.
    assert_eq!(m["grouping"]["groups"], 3, "{}", m["grouping"]);
}

#[test]
fn s2_three_groups_explore_and_every_robot_reaches_the_goal() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("s2");
    let m = run("configs/grouping_s2.toml", &dir, &["--in-process"]);
    assert_eq!(m["collisions"], 0, "{m}");
    let g = &m["grouping"];
    assert_eq!(g["groups"], 3, "{g}");
    assert_eq!(g["reached"], 11, "{g}");
    let groups = g["per_group"].as_array().unwrap();
    // One leader saw the goal; the others were told (section 2.4).
    let found: Vec<&str> = groups
        .iter()
        .map(|p| p["found_goal"].as_str().unwrap())
        .collect();
    assert_eq!(
        found.iter().filter(|f| **f == "seen").count(),
        1,
        "{found:?}"
    );
    assert!(
        groups.iter().all(|p| p["explore_time"].as_f64().is_some()),
        "{g}"
    );
}

/// A robot nobody senses stays alone: it leads a group of one, explores its own sector and,
/// told where the goal is, gets there on its own.
#[test]
fn a_robot_nobody_senses_leads_itself_and_reaches_the_goal_alone() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("loner");
    let m = run(
        "configs/grouping_s2.toml",
        &dir,
        &[
            "--in-process",
            "--set",
            "robots.count=12",
            "--set",
            "robots.start.groups=[{x=3.0,y=3.0},{x=17.0,y=5.0},{x=3.0,y=18.0},{x=17.5,y=17.5}]",
            "--set",
            "robots.start.group_sizes=[4,4,3,1]",
        ],
    );
    let g = &m["grouping"];
    assert_eq!(g["groups"], 4, "{g}");
    let alone = g["per_group"]
        .as_array()
        .unwrap()
        .iter()
        .find(|p| p["leader"] == 11)
        .unwrap_or_else(|| panic!("robot 11 leads its own group: {g}"));
    assert_eq!(alone["robots"], 1, "{alone}");
    assert_eq!(alone["reached"], 1, "{alone}");
    assert_eq!(m["collisions"], 0, "{m}");
}

/// S2's arena is drawn so a leader sees the goal almost at once (Table II: 0.68 s for one
/// group, 13-14 s for the others): every group finds the goal, every robot reaches it, and the
/// first leader to see it explored under 15 s after forming. Seeds 1 and 3 (3 is the slowest
/// finder of the five reproduce.sh runs) keep the debug build's run short.
#[test]
fn s2_every_group_finds_the_goal_and_the_finder_explores_under_15_s() {
    let tmp = tempfile::tempdir().unwrap();
    for seed in ["1", "3"] {
        let dir = tmp.path().join(format!("s2_{seed}"));
        let m = run(
            "configs/grouping_s2.toml",
            &dir,
            &["--in-process", "--seed", seed],
        );
        let g = &m["grouping"];
        assert_eq!(g["reached"], 11, "seed {seed}: {g}");
        let groups = g["per_group"].as_array().unwrap();
        assert_eq!(groups.len(), 3, "seed {seed}: {g}");
        assert!(
            groups.iter().all(|p| p["found_goal"].is_string()),
            "seed {seed}: a group never learnt the goal: {g}"
        );
        let finder = groups
            .iter()
            .filter(|p| p["found_goal"] == "seen")
            .filter_map(|p| p["explore_time"].as_f64())
            .fold(f64::INFINITY, f64::min);
        assert!(
            finder < 15.0,
            "seed {seed}: the first leader to see the goal explored {finder} s: {g}"
        );
    }
}

/// S4 is a maze with dead-end pockets and doors at the far ends of its walls (section 3.2.4):
/// with only their own range finders' maps (`leader_nav = "map"`), all three groups get out to
/// their goals without a collision, and, as in Table IV, groups 2 and 3 travel farther than
/// group 1, group 3 the farthest. Seed 5 is the one of reproduce.sh's five where group 1 goes
/// deepest into a pocket (seed 1, the default, is pinned by records_pinned).
#[test]
fn s4_all_three_groups_leave_the_maze() {
    let tmp = tempfile::tempdir().unwrap();
    let seed = "5";
    let m = run(
        "configs/grouping_s4.toml",
        &tmp.path().join("s4"),
        &["--in-process", "--seed", seed],
    );
    let g = &m["grouping"];
    assert_eq!(g["reached"], 9, "seed {seed}: {g}");
    assert_eq!(g["collisions"], 0, "seed {seed}: {g}");
    let groups = g["per_group"].as_array().unwrap();
    assert_eq!(groups.len(), 3, "seed {seed}: {g}");
    let d: Vec<f64> = groups.iter().map(|p| p["d_m"].as_f64().unwrap()).collect();
    // Start to goal in a straight line: 36, 23 and 24 m. The maze makes every way at least
    // half as long again, groups 2 and 3 walk the whole top lane (38 m) first, and group 3
    // has one door more than group 2.
    assert!(
        d[0] > 54.0 && d[1] > 55.0 && d[2] > d[1],
        "seed {seed}: d_m {d:?}"
    );
}
