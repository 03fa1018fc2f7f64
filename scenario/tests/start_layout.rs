//! Start layouts: groups that start apart, seeded jitter, and the lidar's explicit ray angles.

use swarmrt_scenario::{Config, ConfigError};

const BASE: &str = r#"
[scenario]
name = "t"
seed = 3
ticks = 10
[map]
bounds = [0.0, 0.0, 10.0, 10.0]
goal = { x = 8.0, y = 8.0, radius = 1.0 }
[robots]
count = 5
radius = 0.05
"#;

fn load(extra: &str, ov: &[&str]) -> Result<Config, ConfigError> {
    let ov: Vec<String> = ov.iter().map(|s| s.to_string()).collect();
    Config::from_toml_str("t.toml", &format!("{BASE}{extra}"), &ov)
}

const GROUPS: &str = r#"
[robots.start]
spacing = 0.2
heading_deg = 90.0
groups = [{ x = 2.0, y = 2.0 }, { x = 8.0, y = 8.0, heading_deg = -90.0 }]
"#;

#[test]
fn groups_split_robots_by_id_into_contiguous_blocks_around_their_centres() {
    let c = load(GROUPS, &[]).unwrap();
    let groups: Vec<usize> = (0..5).map(|i| c.start_group(i)).collect();
    assert_eq!(groups, [0, 0, 0, 1, 1]);
    let poses = c.start_poses(|_, _| true).unwrap();
    for (i, p) in poses.iter().enumerate() {
        let (centre, heading) = if i < 3 {
            ((2.0, 2.0), 90f64)
        } else {
            ((8.0, 8.0), -90f64)
        };
        assert!((p.0 - centre.0).abs() <= 0.2 + 1e-9 && (p.1 - centre.1).abs() <= 0.2 + 1e-9);
        assert!((p.2 - heading.to_radians()).abs() < 1e-12, "{p:?}");
        assert!((c.nominal_heading(i as u32) - heading.to_radians()).abs() < 1e-12);
    }
    // Changing the count alone keeps the layout valid.
    let c = load(GROUPS, &["robots.count=40"]).unwrap();
    assert_eq!(c.start_poses(|_, _| true).unwrap().len(), 40);
    assert_eq!(c.start_group(19), 0);
    assert_eq!(c.start_group(20), 1);
}

#[test]
fn groups_that_overlap_never_share_a_start_point() {
    let text = r#"
[robots.start]
spacing = 0.2
groups = [{ x = 5.0, y = 5.0 }, { x = 5.0, y = 5.0 }]
"#;
    let c = load(text, &["robots.count=30"]).unwrap();
    let poses = c.start_poses(|_, _| true).unwrap();
    for (i, a) in poses.iter().enumerate() {
        for b in &poses[..i] {
            let d = ((a.0 - b.0).powi(2) + (a.1 - b.1).powi(2)).sqrt();
            assert!(d >= 0.2 - 1e-9, "{a:?} {b:?}");
        }
    }
}

#[test]
fn jitter_is_seeded_bounded_and_never_overlaps() {
    let text = r#"
[robots.start]
x = 5.0
y = 5.0
spacing = 0.3
jitter = 0.1
heading_jitter_deg = 180.0
"#;
    let grid = load(
        text,
        &[
            "robots.count=25",
            "robots.start.jitter=0",
            "robots.start.heading_jitter_deg=0",
        ],
    )
    .unwrap()
    .start_poses(|_, _| true)
    .unwrap();
    let a = load(text, &["robots.count=25"]).unwrap();
    let pa = a.start_poses(|_, _| true).unwrap();
    assert_eq!(
        pa,
        a.start_poses(|_, _| true).unwrap(),
        "same seed, same layout"
    );
    let pb = load(text, &["robots.count=25", "scenario.seed=4"])
        .unwrap()
        .start_poses(|_, _| true)
        .unwrap();
    assert_ne!(pa, pb, "another seed, another layout");
    for (p, g) in pa.iter().zip(&grid) {
        assert!((p.0 - g.0).abs() <= 0.1 && (p.1 - g.1).abs() <= 0.1);
    }
    let headings: Vec<f64> = pa.iter().map(|p| p.2).collect();
    assert!(headings.iter().any(|h| h.abs() > 1.0), "{headings:?}");
    for (i, p) in pa.iter().enumerate() {
        for q in &pa[..i] {
            assert!(((p.0 - q.0).powi(2) + (p.1 - q.1).powi(2)).sqrt() >= 0.1 - 1e-9);
        }
    }
    // A jittered point that is not clear is redrawn, then the grid point is kept.
    let clear = |x: f64, _y: f64| x <= 5.0 + 1e-9;
    for (p, g) in a.start_poses(clear).unwrap().iter().zip(&grid) {
        assert!(p.0 <= 5.0 + 1e-9 || (p.0 == g.0 && p.1 == g.1), "{p:?}");
    }
}

#[test]
fn bad_layouts_name_the_key_and_bounds() {
    let both = "[robots.start]\nx = 1.0\ny = 1.0\nspacing = 0.2\ngroups = [{ x = 2.0, y = 2.0 }]\n";
    assert_eq!(load(both, &[]).unwrap_err().key, "robots.start.x");
    let neither = "[robots.start]\nspacing = 0.2\n";
    let e = load(neither, &[]).unwrap_err();
    assert_eq!(e.key, "robots.start.x");
    assert!(e.message.contains("robots.start.groups"), "{e}");
    let e = load(GROUPS, &["robots.start.jitter=0.1"]).unwrap_err();
    assert_eq!(e.key, "robots.start.jitter");
    assert!(e.message.contains("[0, 0.05"), "{e}");
    let e = load(GROUPS, &["robots.start.heading_jitter_deg=-1"]).unwrap_err();
    assert_eq!(e.key, "robots.start.heading_jitter_deg");
    let e = load(GROUPS, &["robots.count=1"]).unwrap_err();
    assert_eq!(e.key, "robots.start.groups");
}

#[test]
fn explicit_ray_angles_are_used_and_must_match_the_ray_count() {
    let text = "[robots.lidar]\nrays = 3\nrange = 0.1\nangles_deg = [-17.0, 90.0, 150.0]\n";
    let c = load(text, &[]).unwrap();
    let angles: Vec<f64> = (0..3)
        .map(|k| c.robots.lidar.ray_angle(k).to_degrees())
        .collect();
    for (a, b) in angles.iter().zip([-17.0, 90.0, 150.0]) {
        assert!((a - b).abs() < 1e-9, "{angles:?}");
    }
    assert_eq!(
        Config::from_toml_str("t.toml", &c.to_toml(), &[]).unwrap(),
        c
    );
    let e = load(text, &["robots.lidar.rays=4"]).unwrap_err();
    assert_eq!(e.key, "robots.lidar.rays");
    assert!(e.message.contains("expected 3"), "{e}");
    let e = load(text, &["robots.lidar.angles_deg=[0.0, 1.0, 1e9]"]).unwrap_err();
    assert_eq!(e.key, "robots.lidar.angles_deg[2]");
}

#[test]
fn wheel_slip_is_bounded_and_absent_from_a_config_that_does_not_use_it() {
    let c = load("", &[]).unwrap();
    assert!(!c.to_toml().contains("wheel_slip"));
    assert!(!c.to_toml().contains("\njitter =") && !c.to_toml().contains("heading_jitter"));
    let e = load("", &["robots.noise.wheel_slip=2"]).unwrap_err();
    assert_eq!(e.key, "robots.noise.wheel_slip");
    let c = load("", &["robots.noise.wheel_slip=0.05"]).unwrap();
    assert_eq!(
        Config::from_toml_str("t.toml", &c.to_toml(), &[]).unwrap(),
        c
    );
}

const SCATTER: &str = r#"
[robots.start]
spacing = 0.5
scatter = 2.0
groups = [{ x = 3.0, y = 3.0 }, { x = 7.0, y = 7.0, goal = [1.0, 9.0] }]
group_sizes = [3, 6]
"#;

#[test]
fn scatter_places_each_group_at_random_in_its_disc_apart_and_never_three_on_a_line() {
    let c = load(SCATTER, &["robots.count=9"]).unwrap();
    let groups: Vec<usize> = (0..9).map(|i| c.start_group(i)).collect();
    assert_eq!(groups, [0, 0, 0, 1, 1, 1, 1, 1, 1]);
    let poses = c.start_poses(|_, _| true).unwrap();
    let centres = [(3.0, 3.0), (7.0, 7.0)];
    for (i, p) in poses.iter().enumerate() {
        let (cx, cy) = centres[groups[i]];
        assert!(
            ((p.0 - cx).powi(2) + (p.1 - cy).powi(2)).sqrt() <= 2.0 + 1e-9,
            "{p:?}"
        );
        for q in &poses[..i] {
            assert!(((p.0 - q.0).powi(2) + (p.1 - q.1).powi(2)).sqrt() >= 0.5 - 1e-9);
        }
    }
    for g in 0..2 {
        let pts: Vec<(f64, f64)> = poses
            .iter()
            .zip(&groups)
            .filter(|&(_, &k)| k == g)
            .map(|(p, _)| (p.0, p.1))
            .collect();
        for (i, p) in pts.iter().enumerate() {
            let others: Vec<(f64, f64)> = pts
                .iter()
                .enumerate()
                .filter(|&(j, _)| j != i)
                .map(|(_, &q)| q)
                .collect();
            assert!(!swarmrt_scenario::layout::collinear_with(&others, *p));
        }
    }
    // Seeded: the same seed places the same, another seed elsewhere.
    assert_eq!(poses, c.start_poses(|_, _| true).unwrap());
    let other = load(SCATTER, &["robots.count=9", "scenario.seed=4"]).unwrap();
    assert_ne!(poses, other.start_poses(|_, _| true).unwrap());
    // Each group's goal: its own, or the map's.
    assert_eq!((c.goal_of(0).x, c.goal_of(0).y), (8.0, 8.0));
    assert_eq!((c.goal_of(5).x, c.goal_of(5).y), (1.0, 9.0));
    assert_eq!(c.goals().len(), 2);
}

#[test]
fn collinear_points_are_recognised() {
    use swarmrt_scenario::layout::collinear_with;
    assert!(collinear_with(&[(0.0, 0.0), (1.0, 1.0)], (3.0, 3.01)));
    assert!(!collinear_with(&[(0.0, 0.0), (1.0, 1.0)], (3.0, 2.5)));
    assert!(!collinear_with(&[(0.0, 0.0)], (3.0, 3.0)));
}

#[test]
fn group_sizes_and_scatter_are_checked() {
    let bad = |extra: &str, ov: &[&str], key: &str| {
        let e = load(extra, ov).unwrap_err().to_string();
        assert!(e.contains(key), "{e}");
    };
    bad(SCATTER, &["robots.count=8"], "robots.start.group_sizes");
    bad(
        SCATTER,
        &["robots.count=9", "robots.start.group_sizes=[9]"],
        "robots.start.group_sizes",
    );
    bad(
        SCATTER,
        &["robots.count=9", "robots.start.scatter=-1"],
        "robots.start.scatter",
    );
    bad(
        &SCATTER.replace("goal = [1.0, 9.0]", "goal = [20.0, 1.0]"),
        &["robots.count=9"],
        "robots.start.groups[1].goal",
    );
    // A disc too small for the robots is refused when the layout is built, not hung.
    let c = load(SCATTER, &["robots.count=9", "robots.start.scatter=0.3"]).unwrap();
    assert!(c.start_poses(|_, _| true).is_none());
}

const PATH: &str = r#"
[robots.start]
spacing = 0.5
path = [[1.0, 1.0], [1.0, 2.0], [3.0, 2.0]]
"#;

#[test]
fn a_path_lays_the_chain_along_the_polyline_each_robot_facing_the_one_before() {
    let c = load(PATH, &[]).unwrap();
    let poses = c.start_poses(|_, _| true).unwrap();
    let expected: [(f64, f64, f64); 5] = [
        (1.0, 1.0, -90.0),
        (1.0, 1.5, -90.0),
        (1.0, 2.0, -90.0),
        (1.5, 2.0, 180.0),
        (2.0, 2.0, 180.0),
    ];
    for (p, e) in poses.iter().zip(expected) {
        assert!(
            (p.0 - e.0).abs() < 1e-12 && (p.1 - e.1).abs() < 1e-12,
            "{p:?} {e:?}"
        );
        let dh = swarmrt_scenario::wrap_angle(p.2 - e.2.to_radians());
        assert!(dh.abs() < 1e-12, "{p:?} {e:?}");
    }
    assert!((c.nominal_heading(3) - std::f64::consts::PI).abs() < 1e-12);
    // A start point inside an obstacle is refused, not moved.
    assert!(c.start_poses(|x, _| x < 1.8).is_none());
}

#[test]
fn a_path_too_short_or_mixed_with_a_grid_is_refused_with_its_key() {
    let e = load(PATH, &["robots.count=8"]).unwrap_err().to_string();
    assert!(
        e.contains("robots.start.path") && e.contains("3.5 m"),
        "{e}"
    );
    let e = load(PATH, &["robots.start.x=2.0"]).unwrap_err().to_string();
    assert!(
        e.contains("robots.start.path") && e.contains("not both"),
        "{e}"
    );
    let e = load(PATH, &["robots.start.path=[[1.0, 1.0]]"])
        .unwrap_err()
        .to_string();
    assert!(e.contains("at least two points"), "{e}");
    let e = load(PATH, &["robots.start.path=[[1.0, 1.0], [1.0, 99.0]]"])
        .unwrap_err()
        .to_string();
    assert!(e.contains("robots.start.path[1]"), "{e}");
    // A hairpin tighter than the bodies: robots 0 and 2 would overlap.
    let e = load(
        PATH,
        &["robots.start.path=[[1.0, 1.0], [1.0, 1.5], [1.05, 1.5], [1.05, 0.2], [3.0, 0.2]]"],
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("robots 0 and 2"), "{e}");
}

const UAV_GROUPS: &str = r#"
[robots.aerial]
max_vertical_speed = 0.5
start_z = 0.5
[robots.start]
spacing = 1.0
groups = [
  { x = 2.0, y = 1.0, goal = [8.0, 8.0], goal_z = 1.5 },
  { x = 5.0, y = 1.0, goal = [5.0, 8.0], goal_z = 1.5 },
]
"#;

/// Seed 002 at other sizes: UAVs of one start group get goal slots of their own, two start
/// spacings apart (a hovering UAV's safe zone lies between), clear of obstacles and of the
/// other group's slots; a group of one keeps its goal exactly.
#[test]
fn uavs_of_one_group_get_their_own_goal_slots_and_a_group_of_one_keeps_its_goal() {
    let two = load(UAV_GROUPS, &["robots.count=2", "map.height=4.0"]).unwrap();
    assert_eq!((two.goal_of(0).x, two.goal_of(0).y), (8.0, 8.0));
    assert_eq!((two.goal_of(1).x, two.goal_of(1).y), (5.0, 8.0));

    let mast = "[[map.circles]]\nx = 8.0\ny = 6.0\nr = 0.5\n";
    let c = load(
        &format!("{UAV_GROUPS}{mast}"),
        &["robots.count=8", "map.height=4.0"],
    )
    .unwrap();
    let goals: Vec<(f64, f64)> = (0..8).map(|i| (c.goal_of(i).x, c.goal_of(i).y)).collect();
    // Each group's first member keeps the group's goal.
    assert_eq!(goals[0], (8.0, 8.0));
    assert_eq!(goals[4], (5.0, 8.0));
    for (i, a) in goals.iter().enumerate() {
        assert_eq!(c.goal_of(i as u32).z, Some(1.5));
        // Inside the map, clear of the mast.
        assert!(
            a.0 > 0.05 && a.0 < 9.95 && a.1 > 0.05 && a.1 < 9.95,
            "{a:?}"
        );
        assert!(
            (a.0 - 8.0).hypot(a.1 - 6.0) > 0.55,
            "robot {i} in the mast: {a:?}"
        );
        for (j, b) in goals.iter().enumerate().skip(i + 1) {
            let d = (a.0 - b.0).hypot(a.1 - b.1);
            assert!(d >= 1.999, "robots {i} and {j}: {a:?} {b:?} {d} m apart");
        }
    }
}
