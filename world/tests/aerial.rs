//! Aerial robots (seed 002): a height, a holonomic world-frame velocity within horizontal and
//! vertical limits, obstacles with a height, 3D contacts, and the height in the records.

use swarmrt_agent::registry::VOCABULARY;
use swarmrt_protocol::{Command, Observation, RobotState};
use swarmrt_scenario::Config;
use swarmrt_world::{Event, World};

/// Two UAVs at (2, 2) and (2, 5), 1 m up, under a 5 m ceiling; a 2 m high block spans
/// x 4..6 and a tall mast stands at (8, 2).
fn config(extra: &[&str]) -> Config {
    let text = r#"
[scenario]
name = "aerial"
ticks = 1000
dt = 0.1
stop_when_done = false
[map]
bounds = [0.0, 0.0, 10.0, 10.0]
height = 5.0
goal = { x = 9.0, y = 9.0, z = 1.0, radius = 0.3 }
rectangles = [{ x_min = 4.0, y_min = 0.5, x_max = 6.0, y_max = 9.5, height = 2.0 }]
circles = [{ x = 8.0, y = 2.0, r = 0.5 }]
[robots]
count = 2
radius = 0.2
max_speed = 1.0
max_turn_rate = 4.0
lidar = { rays = 3, fov_deg = 180.0, range = 5.0 }
aerial = { max_vertical_speed = 0.5, start_z = 1.0 }
[robots.start]
spacing = 1.0
groups = [{ x = 2.0, y = 2.0 }, { x = 2.0, y = 5.0 }]
"#;
    let ov: Vec<String> = extra.iter().map(|s| s.to_string()).collect();
    Config::from_toml_str("aerial.toml", text, &ov).unwrap()
}

/// Flies every robot with the velocity `vel(i)` for `ticks` ticks; returns the last
/// observations.
fn fly(world: &mut World, vel: impl Fn(usize) -> [f64; 3], ticks: usize) -> Vec<Observation> {
    let n = world.robots().len();
    let mut obs = vec![Observation::empty(0, 0); n];
    for _ in 0..ticks {
        world.observe(&mut obs);
        let cmds: Vec<_> = (0..n)
            .map(|i| {
                let mut c = Command::act(i as u32, world.tick());
                [c.vx, c.vy, c.vz] = vel(i);
                Some(c)
            })
            .collect();
        world.step(&cmds);
    }
    world.observe(&mut obs);
    obs
}

#[test]
fn a_uav_flies_its_world_frame_velocity_and_reports_its_height() {
    let mut w = World::new(&config(&[]), VOCABULARY).unwrap();
    let obs = fly(
        &mut w,
        |i| if i == 0 { [0.0, 0.6, 0.4] } else { [0.0; 3] },
        10,
    );
    let r = &w.robots()[0];
    assert!(
        (r.x - 2.0).abs() < 1e-9 && (r.y - 2.6).abs() < 1e-9,
        "{r:?}"
    );
    assert!((r.z - 1.4).abs() < 1e-9, "{r:?}");
    // The heading follows the horizontal velocity: north.
    assert!(
        (r.theta - std::f64::consts::FRAC_PI_2).abs() < 1e-9,
        "{r:?}"
    );
    assert!((obs[0].z - 1.4).abs() < 1e-9);
    assert_eq!(w.robots()[1].z, 1.0);
}

#[test]
fn the_height_stays_between_the_ground_and_the_ceiling() {
    let mut w = World::new(&config(&[]), VOCABULARY).unwrap();
    fly(
        &mut w,
        |i| {
            if i == 0 {
                [0.0, 0.0, 0.5]
            } else {
                [0.0, 0.0, -0.5]
            }
        },
        100,
    );
    assert_eq!(w.robots()[0].z, 5.0);
    assert_eq!(w.robots()[1].z, 0.0);
    assert!(w.robots().iter().all(|r| r.state == RobotState::Active));
}

#[test]
fn commands_beyond_the_horizontal_or_vertical_limit_are_refused() {
    for vel in [[0.8, 0.8, 0.0], [0.0, 0.0, 0.6], [f64::NAN, 0.0, 0.0]] {
        let mut w = World::new(&config(&[]), VOCABULARY).unwrap();
        fly(&mut w, |i| if i == 0 { vel } else { [0.0; 3] }, 3);
        assert_eq!(w.metrics().rejected, 3, "{vel:?}");
        assert_eq!(
            w.robots()[0].x,
            2.0,
            "{vel:?}: a refused command stands still"
        );
    }
}

#[test]
fn a_uav_above_a_low_block_crosses_it_and_one_below_goes_down() {
    // Robot 0 climbs to 3 m first (over the 2 m block), robot 1 stays at 1 m; both fly east.
    let mut w = World::new(&config(&[]), VOCABULARY).unwrap();
    fly(
        &mut w,
        |i| if i == 0 { [0.0, 0.0, 0.5] } else { [0.0; 3] },
        40,
    );
    fly(&mut w, |_| [1.0, 0.0, 0.0], 45);
    let (high, low) = (&w.robots()[0], &w.robots()[1]);
    assert_eq!(high.state, RobotState::Active, "{high:?}");
    assert!(high.x > 6.0, "{high:?}");
    assert_eq!(low.state, RobotState::Down, "{low:?}");
    assert!(low.x < 4.0, "{low:?}: stopped at the block's face");
    // The mast has no height: it is a wall at any altitude.
    fly(
        &mut w,
        |i| if i == 0 { [1.0, 0.0, 0.0] } else { [0.0; 3] },
        30,
    );
    assert_eq!(w.robots()[0].state, RobotState::Down);
    let collisions = w
        .drain_events()
        .iter()
        .filter(|e| matches!(e, Event::Collision { other: None, .. }))
        .count();
    assert_eq!(collisions, 2);
}

#[test]
fn contacts_are_in_3d() {
    // Both at (2, 3.5) in the plane, but 2 m apart in height: no contact.
    let mut w = World::new(&config(&["robots.aerial.start_z=1.0"]), VOCABULARY).unwrap();
    fly(
        &mut w,
        |i| {
            if i == 0 {
                [0.0, 0.5, 0.5]
            } else {
                [0.0, -0.5, -0.5]
            }
        },
        30,
    );
    let (a, b) = (&w.robots()[0], &w.robots()[1]);
    assert!(
        (a.y - b.y).abs() < 1e-9 && (a.z - b.z).abs() > 1.0,
        "{a:?} {b:?}"
    );
    assert!(w.robots().iter().all(|r| r.state == RobotState::Active));
    // Level again: they touch.
    fly(
        &mut w,
        |i| {
            if i == 0 {
                [0.0, 0.0, -0.5]
            } else {
                [0.0, 0.0, 0.5]
            }
        },
        30,
    );
    assert!(w.robots().iter().all(|r| r.state == RobotState::Down));
}

#[test]
fn an_aerial_run_records_the_height_and_a_ground_run_does_not() {
    let tmp = tempfile::tempdir().unwrap();
    let mut rec = swarmrt_world::records::Recorder::create(
        &swarmrt_scenario::safe_fs::OutDir::open(tmp.path()).unwrap(),
        true,
    )
    .unwrap();
    let w = World::new(&config(&[]), VOCABULARY).unwrap();
    rec.record(0, w.robots(), &[]).unwrap();
    let text = std::fs::read_to_string(tmp.path().join("trajectory.csv")).unwrap();
    assert_eq!(
        text,
        "tick,id,x,y,z,theta,v,vz,omega,lidar,state\n\
         0,0,2.00000,2.00000,1.00000,0.00000,0.00000,0.00000,0.00000,1,active\n\
         0,1,2.00000,5.00000,1.00000,0.00000,0.00000,0.00000,0.00000,1,active\n"
    );
    let parsed = swarmrt_protocol::records::Records::parse(&text, "").unwrap();
    assert_eq!(parsed.ticks[0][1].z, 1.0);
    let mut rec = swarmrt_world::records::Recorder::create(
        &swarmrt_scenario::safe_fs::OutDir::open(tmp.path()).unwrap(),
        false,
    )
    .unwrap();
    rec.record(0, w.robots(), &[]).unwrap();
    let text = std::fs::read_to_string(tmp.path().join("trajectory.csv")).unwrap();
    assert!(
        text.starts_with("tick,id,x,y,theta,v,omega,lidar,state\n0,0,2.00000,2.00000,0.00000,")
    );
}

#[test]
fn a_uav_reaches_its_goal_in_3d() {
    let cfg = config(&["map.goal={x=2.0,y=2.0,z=2.0,radius=0.3}"]);
    let mut w = World::new(&cfg, VOCABULARY).unwrap();
    // Right above the goal's (x, y) but 1 m below it: not reached.
    fly(&mut w, |_| [0.0; 3], 2);
    assert_eq!(w.metrics().reached_target, 0);
    fly(
        &mut w,
        |i| if i == 0 { [0.0, 0.0, 0.5] } else { [0.0; 3] },
        20,
    );
    assert_eq!(w.metrics().reached_target, 1);
}
