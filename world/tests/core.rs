//! The world core against known geometry: kinematics, collisions, lidar, sensors, command
//! validation and determinism.

use std::f64::consts::PI;
use std::time::Duration;
use swarmrt_agent::behaviours::formation::FormationNote;
use swarmrt_agent::behaviours::goto::Beacon;
use swarmrt_agent::registry::VOCABULARY;
use swarmrt_agent::{Note, RadioMsg};
use swarmrt_protocol::{BROADCAST, Command, Frame, MAX_OUTBOX, NoteJson, Observation, RobotState};
use swarmrt_scenario::Config;
use swarmrt_world::world::Stage;
use swarmrt_world::{Event, World};

/// A message to fill outboxes with.
const BEACON: RadioMsg = RadioMsg::Goto(Beacon {
    x: 0.0,
    y: 0.0,
    theta: 0.0,
});

/// One robot at (2, 2) facing +x, a circle at (6, 2), walls at 0 and 10.
fn config(extra: &[&str]) -> Config {
    let text = r#"
[scenario]
name = "core"
ticks = 1000
dt = 0.1
stop_when_done = false
[map]
bounds = [0.0, 0.0, 10.0, 10.0]
goal = { x = 9.0, y = 9.0, radius = 0.5 }
circles = [{ x = 6.0, y = 2.0, r = 1.0 }]
[robots]
count = 1
radius = 0.2
max_speed = 2.0
max_turn_rate = 4.0
start = { x = 2.0, y = 2.0, spacing = 1.0, heading_deg = 0.0 }
lidar = { rays = 3, fov_deg = 180.0, range = 5.0 }
"#;
    let ov: Vec<String> = extra.iter().map(|s| s.to_string()).collect();
    Config::from_toml_str("core.toml", text, &ov).unwrap()
}

fn drive(world: &mut World, v: f64, omega: f64, ticks: usize) {
    let n = world.robots().len();
    let mut obs = vec![Observation::empty(0, 0); n];
    for _ in 0..ticks {
        world.observe(&mut obs);
        let cmds: Vec<_> = (0..n)
            .map(|i| {
                let mut c = Command::act(i as u32, world.tick());
                c.v = v;
                c.omega = omega;
                c.lidar_on = 1;
                Some(c)
            })
            .collect();
        world.step(&cmds);
    }
}

#[test]
fn unicycle_moves_straight_and_turns() {
    let mut w = World::new(&config(&[]), VOCABULARY).unwrap();
    drive(&mut w, 1.0, 0.0, 10);
    let r = &w.robots()[0];
    assert!(
        (r.x - 3.0).abs() < 1e-9 && (r.y - 2.0).abs() < 1e-9,
        "{r:?}"
    );
    // A quarter turn at pi/2 rad/s over 1 s, standing still.
    drive(&mut w, 0.0, PI / 2.0, 10);
    assert!((w.robots()[0].theta - PI / 2.0).abs() < 1e-9);
    drive(&mut w, 1.0, 0.0, 10);
    let r = &w.robots()[0];
    assert!(
        (r.x - 3.0).abs() < 1e-9 && (r.y - 3.0).abs() < 1e-9,
        "{r:?}"
    );
}

#[test]
fn out_of_range_speed_is_rejected_not_clamped() {
    let mut w = World::new(&config(&[]), VOCABULARY).unwrap();
    drive(&mut w, 5.0, 0.0, 3);
    assert_eq!(w.robots()[0].x, 2.0, "a refused command means stop");
    assert_eq!(w.metrics().rejected, 3);
    let events = w.drain_events();
    assert_eq!(
        events.len(),
        1,
        "logged once per robot and reason: {events:?}"
    );
    assert!(matches!(&events[0], Event::Rejected { reason, .. } if reason == "speed out of range"));
}

#[test]
fn nan_wrong_version_wrong_tick_and_bad_frames_are_rejected() {
    let w = World::new(&config(&[]), VOCABULARY).unwrap();
    let good = Command::act(0, 0);
    assert_eq!(w.validate(0, &good), Ok(()));
    let mut c = good;
    c.v = f64::NAN;
    assert!(w.validate(0, &c).is_err());
    let mut c = good;
    c.version = 99;
    assert!(w.validate(0, &c).is_err());
    let mut c = good;
    c.tick = 7;
    assert!(w.validate(0, &c).is_err());
    let mut c = good;
    c.outbox_len = MAX_OUTBOX as u16 + 1;
    assert!(w.validate(0, &c).is_err());
    let mut c = good;
    c.push_frame(BROADCAST, &BEACON).unwrap();
    c.outbox[0].len = 500;
    assert_eq!(w.validate(0, &c), Err("oversized radio frame"));
    let mut c = good;
    c.push_frame(42, &BEACON).unwrap();
    assert_eq!(w.validate(0, &c), Err("radio frame to an unknown robot"));
    let mut c = good;
    c.push_frame(BROADCAST, &BEACON).unwrap();
    // A variant index no robot knows (0xff would be an opaque frame).
    c.outbox[0].payload[0] = 0x7f;
    assert_eq!(w.validate(0, &c), Err("malformed radio frame"));
    assert_eq!(
        w.validate(1, &good),
        Err("robot id does not match its slot")
    );
    let mut c = good;
    c.set_notes(&[Note::Formation(FormationNote::EpsilonFlip)])
        .unwrap();
    c.report[0] = 250;
    assert_eq!(w.validate(0, &c), Err("malformed report"));
    let mut c = good;
    c.report_len = u16::MAX;
    assert_eq!(w.validate(0, &c), Err("report length out of range"));
}

#[test]
fn opaque_frames_pass_the_boundary_and_reach_the_others() {
    let mut w = World::new(&config(&["robots.count=2"]), VOCABULARY).unwrap();
    let mut obs = vec![Observation::empty(0, 0); 2];
    w.observe(&mut obs);
    let mut c = Command::act(0, 0);
    c.outbox[0] = Frame::opaque(BROADCAST, b"foreign").unwrap();
    c.outbox_len = 1;
    assert_eq!(w.validate(0, &c), Ok(()));
    w.step(&[Some(c), Some(Command::act(1, 0))]);
    w.observe(&mut obs);
    let heard: Vec<&[u8]> = obs[1]
        .inbox()
        .iter()
        .filter_map(|f| f.opaque_bytes())
        .collect();
    assert_eq!(heard, [&b"foreign"[..]]);
    assert_eq!(obs[1].inbox()[0].src, 0);
}

#[test]
fn notes_are_recorded_as_events_of_their_tick() {
    let mut w = World::new(&config(&[]), VOCABULARY).unwrap();
    let mut obs = vec![Observation::empty(0, 0); 1];
    w.observe(&mut obs);
    let mut c = Command::act(0, 0);
    c.set_notes(&[
        Note::Formation(FormationNote::Role { role: 2 }),
        Note::Formation(FormationNote::EpsilonFlip),
    ])
    .unwrap();
    w.step(&[Some(c)]);
    let notes: Vec<_> = w
        .drain_events()
        .into_iter()
        .filter(|e| matches!(e, Event::Note { .. }))
        .collect();
    assert_eq!(
        notes,
        vec![
            Event::Note {
                tick: 0,
                robot: 0,
                note: NoteJson::new(r#"{"role":{"role":2}}"#.into()).unwrap()
            },
            Event::Note {
                tick: 0,
                robot: 0,
                note: NoteJson::new(r#""epsilon_flip""#.into()).unwrap()
            },
        ]
    );
}

#[test]
fn hitting_an_obstacle_knocks_the_robot_down_where_it_stands() {
    let mut w = World::new(&config(&[]), VOCABULARY).unwrap();
    // Surface of the circle is at x = 5; the robot's edge touches at x = 4.8.
    drive(&mut w, 2.0, 0.0, 30);
    let r = w.robots()[0].clone();
    assert_eq!(r.state, RobotState::Down);
    assert!(
        r.x < 4.8 + 1e-9 && r.x > 4.5,
        "stopped at the obstacle, not inside: {}",
        r.x
    );
    assert_eq!(w.metrics().collisions, 1);
    assert_eq!(w.metrics().down, 1);
    let x = r.x;
    drive(&mut w, 2.0, 0.0, 5);
    assert_eq!(w.robots()[0].x, x, "a down robot stays where it is");
}

#[test]
fn fast_robot_does_not_tunnel_through_a_thin_wall() {
    let mut cfg = config(&["robots.max_speed=100.0"]);
    cfg.map.circles.clear();
    cfg.map.rectangles.push(swarmrt_scenario::RectObstacle {
        x_min: 4.0,
        y_min: 0.5,
        x_max: 4.05,
        y_max: 3.5,
        height: None,
    });
    let mut w = World::new(&cfg, VOCABULARY).unwrap();
    drive(&mut w, 50.0, 0.0, 1); // 5 m in one tick
    assert_eq!(w.robots()[0].state, RobotState::Down);
    assert!(w.robots()[0].x < 4.0);
}

#[test]
fn robots_colliding_both_go_down() {
    let cfg = config(&[
        "robots.count=2",
        "robots.start={ x = 2.5, y = 6.0, spacing = 1.0, heading_deg = -90.0 }",
    ]);
    let mut w = World::new(&cfg, VOCABULARY).unwrap();
    assert_eq!(
        (w.robots()[1].x, w.robots()[1].y),
        (2.5, 5.0),
        "robot 1 starts 1 m south"
    );
    let mut obs = vec![Observation::empty(0, 0); 2];
    for _ in 0..20 {
        w.observe(&mut obs);
        let t = w.tick();
        let mut a = Command::act(0, t);
        a.v = 1.0; // robot 0 drives into robot 1, which stands still
        w.step(&[Some(a), Some(Command::act(1, t))]);
    }
    let states: Vec<_> = w.robots().iter().map(|r| r.state).collect();
    assert_eq!(states, vec![RobotState::Down, RobotState::Down]);
    let events = w.drain_events();
    assert!(events.iter().any(|e| matches!(
        e,
        Event::Collision {
            robot: 0,
            other: Some(1),
            ..
        }
    )));
}

#[test]
fn lidar_measures_known_distances() {
    let mut w = World::new(&config(&[]), VOCABULARY).unwrap();
    let mut obs = vec![Observation::empty(0, 0)];
    w.observe(&mut obs);
    let l = obs[0].lidar();
    assert_eq!(l.len(), 3);
    // Rays at -90, 0, +90 degrees: wall at y = 0 (2 m), circle surface (3 m), range cap (5 m).
    assert!((l[0] - 2.0).abs() < 1e-9, "{l:?}");
    assert!((l[1] - 3.0).abs() < 1e-9, "{l:?}");
    assert!((l[2] - 5.0).abs() < 1e-9, "{l:?}");
}

#[test]
fn lidar_off_reports_nothing_and_costs_nothing() {
    let mut w = World::new(&config(&[]), VOCABULARY).unwrap();
    let mut obs = vec![Observation::empty(0, 0)];
    w.observe(&mut obs);
    assert_eq!(w.metrics().lidar_on_ticks, 1, "on at start");
    w.step(&[Some(Command::act(0, 0))]); // lidar_on = 0
    w.observe(&mut obs);
    assert_eq!(obs[0].lidar_len, 0);
    assert_eq!(w.metrics().lidar_on_ticks, 1);
}

#[test]
fn lidar_sees_other_robots() {
    let cfg = config(&[
        "robots.count=2",
        "robots.start={ x = 2.5, y = 6.0, spacing = 2.0, heading_deg = -90.0 }",
    ]);
    let mut w = World::new(&cfg, VOCABULARY).unwrap();
    let mut obs = vec![Observation::empty(0, 0); 2];
    w.observe(&mut obs);
    // Robot 1 is 2 m ahead (south) of robot 0; its body starts 0.2 m earlier.
    assert!(
        (obs[0].lidar()[1] - 1.8).abs() < 1e-9,
        "{:?}",
        obs[0].lidar()
    );
}

#[test]
fn range_and_bearing_and_goal_sensor() {
    let cfg = config(&[
        "robots.count=2",
        "robots.start={ x = 2.5, y = 6.0, spacing = 2.0, heading_deg = 0.0 }",
    ]);
    let mut w = World::new(&cfg, VOCABULARY).unwrap();
    let mut obs = vec![Observation::empty(0, 0); 2];
    w.observe(&mut obs);
    let n = obs[0].neighbours();
    assert_eq!(n.len(), 1);
    assert_eq!(n[0].id, 1);
    assert!((n[0].range - 2.0).abs() < 1e-9);
    // Robot 1 is 2 m south; robot 0 faces +x, so it is 90 degrees to the right.
    assert!((n[0].bearing + PI / 2.0).abs() < 1e-9, "{}", n[0].bearing);
    assert_eq!(obs[0].goal_visible, 1);
    let (dx, dy): (f64, f64) = (9.0 - 2.5, 9.0 - 6.0);
    assert!((obs[0].goal_range - (dx * dx + dy * dy).sqrt()).abs() < 1e-9);
    // A narrow forward camera cannot see a goal off to the side.
    let cfg = config(&["robots.goal_sensor={ range = 100.0, fov_deg = 10.0 }"]);
    let mut w = World::new(&cfg, VOCABULARY).unwrap();
    let mut obs = vec![Observation::empty(0, 0)];
    w.observe(&mut obs);
    assert_eq!(obs[0].goal_visible, 0);
}

#[test]
fn radio_frames_arrive_with_the_next_observation() {
    let cfg = config(&[
        "robots.count=2",
        "robots.start={ x = 2.5, y = 6.0, spacing = 2.0 }",
    ]);
    let mut w = World::new(&cfg, VOCABULARY).unwrap();
    let mut obs = vec![Observation::empty(0, 0); 2];
    w.observe(&mut obs);
    let mut a = Command::act(0, 0);
    a.push_frame(
        BROADCAST,
        &RadioMsg::Goto(Beacon {
            x: 1.0,
            y: 2.0,
            theta: 3.0,
        }),
    )
    .unwrap();
    a.outbox[0].src = 99; // the world never trusts the sender's claim
    w.step(&[Some(a), Some(Command::act(1, 0))]);
    w.observe(&mut obs);
    assert_eq!(obs[1].inbox().len(), 1);
    assert_eq!(obs[1].inbox()[0].src, 0);
    assert_eq!(obs[0].inbox().len(), 0, "no echo to the sender");
    assert_eq!(
        RadioMsg::decode(obs[1].inbox()[0].bytes()),
        Some(RadioMsg::Goto(Beacon {
            x: 1.0,
            y: 2.0,
            theta: 3.0
        }))
    );
}

#[test]
fn dead_robot_stays_as_an_obstacle_and_is_not_waited_for() {
    let cfg = config(&[
        "robots.count=2",
        "robots.start={ x = 2.5, y = 6.0, spacing = 2.0, heading_deg = -90.0 }",
    ]);
    let mut w = World::new(&cfg, VOCABULARY).unwrap();
    w.mark_dead(1, "process killed by signal 9");
    w.mark_dead(1, "again");
    assert_eq!(w.metrics().dead, 1, "idempotent");
    assert_eq!(w.robots()[1].state, RobotState::Dead);
    let mut obs = vec![Observation::empty(0, 0); 2];
    w.observe(&mut obs);
    assert!(
        (obs[0].lidar()[1] - 1.8).abs() < 1e-9,
        "dead body still blocks the lidar"
    );
    assert_eq!(obs[0].neighbours_len, 0, "a dead robot's emitter is off");
}

#[test]
fn same_seed_same_run_with_noise_and_loss() {
    let run = |seed: u64| {
        let cfg = config(&[
            "robots.count=4",
            "robots.start={ x = 5.0, y = 7.0, spacing = 1.0 }",
            "robots.noise={ pose = 0.05, heading = 0.02, lidar = 0.05 }",
            "radio.loss=0.3",
            &format!("scenario.seed={seed}"),
        ]);
        let mut w = World::new(&cfg, VOCABULARY).unwrap();
        let mut obs = vec![Observation::empty(0, 0); 4];
        let mut trace = Vec::new();
        for _ in 0..50 {
            w.observe(&mut obs);
            trace.extend(
                obs.iter()
                    .map(|o| (o.x.to_bits(), o.lidar[0].to_bits(), o.inbox_len)),
            );
            w.step(&turning_beacons(4, w.tick()));
        }
        trace
    };
    assert_eq!(run(1), run(1));
    assert_ne!(run(1), run(2));
}

/// Every robot drives a slow left curve with its lidar on and broadcasts a beacon.
fn turning_beacons(robots: u32, tick: u64) -> Vec<Option<Command>> {
    (0..robots)
        .map(|i| {
            let mut c = Command::act(i, tick);
            c.v = 0.3;
            c.omega = 0.5;
            c.lidar_on = 1;
            c.push_frame(BROADCAST, &BEACON).unwrap();
            Some(c)
        })
        .collect()
}

#[test]
fn stage_timing_is_off_by_default_and_changes_nothing() {
    let run = |timing: bool| {
        let cfg = config(&[
            "robots.count=4",
            "robots.start={ x = 5.0, y = 7.0, spacing = 1.0 }",
            "robots.noise={ pose = 0.05, heading = 0.02, lidar = 0.05 }",
            "radio.loss=0.3",
        ]);
        let mut w = World::new(&cfg, VOCABULARY).unwrap();
        assert!(!w.stage_times().enabled());
        w.set_stage_timing(timing);
        let mut events = Vec::new();
        for _ in 0..20 {
            let mut obs = vec![Observation::empty(0, 0); 4];
            w.observe(&mut obs);
            w.step(&turning_beacons(4, w.tick()));
            events.extend(w.drain_events());
        }
        let times = w.take_stage_times();
        assert_eq!(times.enabled(), timing);
        assert_eq!(w.stage_times().total(), Duration::ZERO, "taken");
        (w.robots().to_vec(), events, w.metrics(), times)
    };
    let (robots_off, events_off, metrics_off, off) = run(false);
    let (robots_on, events_on, metrics_on, on) = run(true);
    assert_eq!(robots_off, robots_on);
    assert_eq!(events_off, events_on);
    assert_eq!(metrics_off, metrics_on);
    assert_eq!(off.total(), Duration::ZERO, "no clock read while off");
    // Lower bounds only: twenty observations of four robots with lidar take some time.
    assert!(on.get(Stage::Sensing) > Duration::ZERO);
    assert!(on.total() >= on.get(Stage::Sensing));
}

#[test]
fn start_layout_follows_the_count_and_avoids_obstacles() {
    // Centred on the circle obstacle: robots start around it, never inside, never overlapping.
    let cfg = config(&[
        "robots.count=60",
        "robots.start={ x = 6.0, y = 2.0, spacing = 0.5 }",
    ]);
    let w = World::new(&cfg, VOCABULARY).unwrap();
    let r = w.robots();
    assert_eq!(r.len(), 60);
    for a in r {
        assert!(
            w.map().clearance((a.x, a.y)) >= 0.2,
            "robot {} starts in an obstacle",
            a.id
        );
        for b in r.iter().filter(|b| b.id > a.id) {
            assert!((a.x - b.x).hypot(a.y - b.y) >= 0.5 - 1e-9);
        }
    }
}

#[test]
fn wheel_slip_drifts_the_true_heading_from_the_commanded_one_reproducibly() {
    let run = |extra: &[&str]| {
        let mut w = World::new(&config(extra), VOCABULARY).unwrap();
        drive(&mut w, 0.5, 0.0, 40);
        let r = &w.robots()[0];
        (r.x, r.y, r.theta)
    };
    let exact = run(&[]);
    assert_eq!(exact.2, 0.0, "no slip: straight means straight");
    assert!((exact.0 - 4.0).abs() < 1e-9);
    let a = run(&["robots.noise.wheel_slip=0.1"]);
    assert_eq!(a, run(&["robots.noise.wheel_slip=0.1"]), "seeded");
    assert_ne!(a, run(&["robots.noise.wheel_slip=0.1", "scenario.seed=9"]));
    // Unequal wheels turn a robot told to go straight: its own count of wheel turns (zero
    // heading change) is now wrong by the drift.
    assert!(a.2.abs() > 1e-3, "heading drifted by {}", a.2);
    assert!(
        (a.0 - 4.0).abs() < 0.5,
        "but it still went about 2 m: {a:?}"
    );
}

#[test]
fn explicit_lidar_angles_measure_along_their_rays() {
    // Rays backwards and sideways; the circle at (6, 2) is ahead, the wall at x = 0 behind.
    let cfg = config(&[
        "robots.lidar.rays=2",
        "robots.lidar.angles_deg=[180.0, 0.0]",
    ]);
    let mut w = World::new(&cfg, VOCABULARY).unwrap();
    let mut obs = vec![Observation::empty(0, 0)];
    w.observe(&mut obs);
    let l = obs[0].lidar();
    assert!((l[0] - 2.0).abs() < 1e-6, "wall 2 m behind: {l:?}");
    assert!((l[1] - 3.0).abs() < 1e-6, "circle edge 3 m ahead: {l:?}");
}

#[test]
fn obstacles_hide_the_goal_only_with_occlusion() {
    // The goal sits behind the circle at (6, 2), straight ahead of the robot.
    let see = |extra: &[&str]| {
        let mut sets = vec!["map.goal={ x = 9.0, y = 2.0, radius = 0.5 }"];
        sets.extend_from_slice(extra);
        let mut w = World::new(&config(&sets), VOCABULARY).unwrap();
        let mut obs = vec![Observation::empty(0, 0)];
        w.observe(&mut obs);
        obs[0].goal_visible
    };
    assert_eq!(see(&[]), 1);
    assert_eq!(see(&["robots.goal_sensor.occlusion=true"]), 0);
    // In the clear, occlusion changes nothing.
    assert_eq!(
        see(&[
            "robots.goal_sensor.occlusion=true",
            "map.goal={ x = 2.0, y = 8.0, radius = 0.5 }"
        ]),
        1
    );
}

#[test]
fn a_group_with_its_own_goal_sees_and_reaches_only_that_one() {
    let start = "robots.start={ spacing = 1.0, groups = [{ x = 2.0, y = 2.0, goal = [3.0, 2.0] }, \
                 { x = 2.0, y = 8.0 }] }";
    let mut w = World::new(&config(&["robots.count=2", start]), VOCABULARY).unwrap();
    let mut obs = vec![Observation::empty(0, 0); 2];
    w.observe(&mut obs);
    // Robot 0 sees its own goal 1 m ahead; robot 1 the map's goal at (9, 9).
    assert!(
        (obs[0].goal_range - 1.0).abs() < 1e-9,
        "{}",
        obs[0].goal_range
    );
    assert!((obs[1].goal_range - (49.0f64 + 1.0).sqrt()).abs() < 1e-9);
    drive(&mut w, 1.0, 0.0, 10);
    let reached: Vec<u32> = w
        .drain_events()
        .into_iter()
        .filter_map(|e| match e {
            Event::Reached { robot, .. } => Some(robot),
            _ => None,
        })
        .collect();
    assert_eq!(reached, [0]);
}
