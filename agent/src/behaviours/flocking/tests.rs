//! Seed 004 flocking: each equation against hand-computed values, the one-byte message, the
//! behaviour's bookkeeping (own flock only, time_out, odometry) and the metrics of eq. 14-22.

use std::f64::consts::{FRAC_PI_2, PI};

use proptest::prelude::*;
use crate::behaviour::{Act, Behaviour};
use crate::behaviours::flocking::equations::*;
use crate::behaviours::flocking::{
    FlockMsg, Flocking, FlockingParams, decode_byte, encode_byte, flock_ticks,
};
use crate::inbox::Heard;
use crate::registry;
use swarmrt_protocol::records::Records;
use swarmrt_protocol::{Neighbour, Observation};
use swarmrt_scenario::Config;

const EPS: f64 = 1e-9;

fn close(a: f64, b: f64, tol: f64) -> bool {
    (a - b).abs() <= tol
}

fn v_close(a: V2, b: (f64, f64), tol: f64) {
    assert!(
        close(a.x, b.0, tol) && close(a.y, b.1, tol),
        "{a:?} != {b:?}"
    );
}

#[test]
fn eq6_alignment_is_the_mean_of_the_mates_and_the_robots_own_heading() {
    v_close(alignment(&[]), (1.0, 0.0), EPS);
    v_close(alignment(&[FRAC_PI_2]), (0.5, 0.5), EPS);
    v_close(alignment(&[PI, PI]), (-1.0 / 3.0, 0.0), EPS);
}

#[test]
fn eq5_heading_alignment_weighs_the_migration_urge_by_mb() {
    v_close(heading_alignment(1.0, FRAC_PI_2, e1()), (0.0, 1.0), EPS);
    v_close(heading_alignment(0.0, FRAC_PI_2, e1()), (1.0, 0.0), EPS);
    // 0.3 (0, 1) + 0.7 (1, 0) = (0.7, 0.3), normalised.
    let n = (0.49f64 + 0.09).sqrt();
    v_close(
        heading_alignment(0.3, FRAC_PI_2, e1()),
        (0.7 / n, 0.3 / n),
        EPS,
    );
    // Exactly opposite urges cancel: keep going straight.
    v_close(heading_alignment(0.5, PI, e1()), (1.0, 0.0), EPS);
}

#[test]
fn eq7_8_proximal_pushes_away_with_the_square_of_the_level() {
    assert!(close(level(0.037, 0.037, 0.097), 7.0, EPS));
    assert!(close(level(0.097, 0.037, 0.097), 0.0, EPS));
    assert!(close(level(0.067, 0.037, 0.097), 3.5, EPS));
    assert!(close(level(0.5, 0.037, 0.097), 0.0, EPS));
    assert!(close(repulsion(7.0), -1.0, EPS));
    assert!(close(repulsion(3.5), -0.25, EPS));
    // Something dead ahead pushes straight back.
    v_close(proximal(&[7.0, 0.0], &[0.0, FRAC_PI_2]), (-1.0, 0.0), EPS);
    // Level 7 ahead and 3.5 on the left: (-1, 0) + (0, -0.25), normalised.
    let n = (1.0f64 + 0.0625).sqrt();
    v_close(
        proximal(&[7.0, 3.5], &[0.0, FRAC_PI_2]),
        (-1.0 / n, -0.25 / n),
        EPS,
    );
    v_close(proximal(&[0.0, 0.0], &[0.0, FRAC_PI_2]), (0.0, 0.0), EPS);
}

#[test]
fn eq2_proximal_weight_grows_with_the_strongest_reading() {
    assert!(close(strongest(&[3.5, 7.0, 0.0]), 1.0, EPS));
    assert!(close(strongest(&[3.5]), 0.5, EPS));
    assert!(close(proximal_weight(100.0, -0.5, 1.0), 10.0, 1e-12));
    assert!(close(proximal_weight(100.0, -0.5, 0.0), 0.1, 1e-12));
    assert!(close(proximal_weight(2.0, 1.0, 0.5), 2f64.powf(1.5), 1e-12));
}

#[test]
fn eq3_4_9_cohesion_pulls_only_from_beyond_the_desired_distance() {
    let c = cohesion(&[V2::new(0.2, 0.0), V2::new(0.0, 0.2)]);
    v_close(c, (0.1, 0.1), EPS);
    v_close(cohesion(&[]), (0.0, 0.0), EPS);
    assert!(close(
        cohesion_weight(10.0, 0.0, 0.2, 0.1),
        10f64.powf(0.2),
        1e-12
    ));
    assert!(close(
        cohesion_weight(10.0, 0.5, 0.3, 0.1),
        10f64.powf(0.8),
        1e-12
    ));
    assert_eq!(cohesion_weight(10.0, 0.0, 0.05, 0.1), 0.0);
}

#[test]
fn eq1_desired_heading_is_the_normalised_weighted_sum() {
    // alpha h = (1, 0), Gamma p = 10 (-1, 0): the obstacle wins, turn back.
    v_close(
        desired(1.0, e1(), 10.0, V2::new(-1.0, 0.0), 0.0, V2::zeros()),
        (-1.0, 0.0),
        EPS,
    );
    // (1, 0) + 2 (0, 0.5) = (1, 1) normalised.
    let s = 0.5f64.sqrt();
    v_close(
        desired(1.0, e1(), 0.0, V2::zeros(), 2.0, V2::new(0.0, 0.5)),
        (s, s),
        EPS,
    );
    v_close(
        desired(0.0, e1(), 0.0, V2::zeros(), 0.0, V2::zeros()),
        (1.0, 0.0),
        EPS,
    );
}

#[test]
fn eq10_forward_speed_waits_for_the_flock_and_never_reverses() {
    let top = 0.0628;
    assert!(close(forward_speed(top, 0.8, -0.36), top * 0.8 * 0.8, EPS));
    assert!(close(forward_speed(top, 0.8, 0.5), top * 0.8, EPS));
    assert!(
        close(forward_speed(top, 0.8, 0.0), top * 0.8, EPS),
        "inside D"
    );
    assert!(close(forward_speed(top, -0.6, -0.75), top * 0.6 * 0.5, EPS));
    assert_eq!(forward_speed(top, -0.6, 0.2), 0.0);
    assert_eq!(forward_speed(top, -0.6, 0.0), 0.0);
}

#[test]
fn eq11_13_turn_rate_and_wheel_limits() {
    // kappa theta_a 8 W_r / l = 0.5 * (pi / 2) * 8 * 0.0205 / 0.052.
    let w = turn_rate(0.5, FRAC_PI_2, 0.0205, 0.052);
    assert!(close(w, 0.5 * FRAC_PI_2 * 8.0 * 0.0205 / 0.052, EPS));
    // Wheels 0.05 -/+ 0.026: the right one saturates at 0.0628.
    let (v, omega) = unicycle(0.05, 1.0, 0.052, 0.0628);
    assert!(close(v, (0.024 + 0.0628) / 2.0, EPS), "{v}");
    assert!(close(omega, (0.0628 - 0.024) / 0.052, EPS), "{omega}");
    // Within the limits the command passes through.
    let (v, omega) = unicycle(0.02, 0.5, 0.052, 0.0628);
    assert!(close(v, 0.02, EPS) && close(omega, 0.5, EPS));
}

#[test]
fn one_byte_message_known_values() {
    assert_eq!(encode_byte(5, 0.0), 5 << 5);
    assert_eq!(encode_byte(5, PI), (5 << 5) | 16);
    assert_eq!(
        encode_byte(13, -FRAC_PI_2),
        (5 << 5) | 24,
        "id mod 8, angle mod 2 pi"
    );
    assert_eq!(decode_byte((3 << 5) | 8), (3, FRAC_PI_2));
}

proptest! {
    #[test]
    fn one_byte_message_round_trips_id_and_heading_within_half_a_step(
        id in 0u32..8, heading in -10.0f64..10.0,
    ) {
        let (got_id, got) = decode_byte(encode_byte(id, heading));
        prop_assert_eq!(got_id, id);
        let err = (got - heading).rem_euclid(2.0 * PI);
        let err = err.min(2.0 * PI - err);
        prop_assert!(err <= PI / 32.0 + 1e-9, "{} off by {}", heading, err);
    }
}

/// `configs/<name>.toml` with `extra` overrides, resolved by the registry.
fn load(name: &str, extra: &[&str]) -> Result<Config, swarmrt_scenario::ConfigError> {
    let ov: Vec<String> = extra.iter().map(|s| s.to_string()).collect();
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../configs")
        .join(format!("{name}.toml"));
    registry::load(&path, &ov)
}

/// The crossing scenario (two flocks of five), with `extra` overrides.
fn crossing(extra: &[&str]) -> Config {
    load("flocking_crossing", extra).unwrap()
}

/// Environment 1 with `count` robots.
fn obstacles(count: u32) -> Config {
    load("flocking_obstacles", &[&format!("robots.count={count}")]).unwrap()
}

fn params(cfg: &Config) -> FlockingParams {
    toml::Value::Table(cfg.behaviour.params.clone())
        .try_into()
        .unwrap()
}

fn heard(src: u32, msg: FlockMsg) -> Heard<FlockMsg> {
    Heard {
        src,
        sent_tick: 0,
        msg,
    }
}

#[test]
fn only_the_own_flocks_messages_count_and_they_expire_after_time_out() {
    let cfg = crossing(&["behaviour.time_out=0.64"]); // 10 ticks of 64 ms
    let p = params(&cfg);
    let mut robot = Flocking::new(&cfg, &p, 0);
    let mut act = Act::default();
    let mut obs = Observation::empty(0, 0);
    obs.neighbours[0] = Neighbour {
        id: 1,
        range: 0.12,
        bearing: FRAC_PI_2,
    };
    obs.neighbours_len = 1;
    let inbox = [
        heard(
            1,
            FlockMsg::Heading {
                flock: 0,
                heading: 0.3,
            },
        ),
        heard(
            7,
            FlockMsg::Heading {
                flock: 1,
                heading: 3.0,
            },
        ),
    ];
    robot.step(&obs, &inbox, &mut act);
    let mates: Vec<_> = robot.mates().iter().map(|(id, m)| (id, *m)).collect();
    assert_eq!(mates.len(), 1, "robot 7 is in the other flock: {mates:?}");
    assert_eq!(mates[0].0, 1);
    assert!(close(mates[0].1.heading, 0.3, 1e-6));
    let at = mates[0].1.position.expect("range-and-bearing saw it");
    v_close(at, (0.0, 0.12), 1e-12);
    // It broadcasts its own flock and heading.
    let (frames, _, _) = act.drain();
    assert_eq!(frames.len(), 1);
    assert!(matches!(frames[0].1, FlockMsg::Heading { flock: 0, .. }));
    for tick in 1..=10 {
        act.reset();
        robot.step(&Observation::empty(0, tick), &[], &mut act);
        assert_eq!(
            robot.mates().iter().count(),
            1,
            "still within time_out at {tick}"
        );
    }
    robot.step(&Observation::empty(0, 11), &[], &mut act);
    assert_eq!(robot.mates().iter().count(), 0, "forgotten after time_out");
}

#[test]
fn odometry_integrates_the_robots_own_turns_and_ignores_the_heading_sensor() {
    let cfg = crossing(&["behaviour.heading=\"odometry\""]);
    let p = params(&cfg);
    // Robot 9 is in the second flock, which starts facing 180 degrees.
    let mut robot = Flocking::new(&cfg, &p, 9);
    assert!(close(robot.heading(), PI, 1e-12));
    let mut act = Act::default();
    let mut obs = Observation::empty(9, 0);
    obs.theta = 1.0; // a sensor the odometry robot does not have
    robot.step(&obs, &[], &mut act);
    let omega = act.omega;
    obs.tick = 1;
    act.reset();
    robot.step(&obs, &[], &mut act);
    let want = swarmrt_scenario::wrap_angle(PI + omega * cfg.scenario.dt);
    assert!(
        close(robot.heading(), want, 1e-12),
        "{} vs {want}",
        robot.heading()
    );
    // With a compass, the sensor is the heading.
    let cfg = crossing(&[]);
    let mut robot = Flocking::new(&cfg, &params(&cfg), 9);
    robot.step(&obs, &[], &mut act);
    assert_eq!(robot.heading(), 1.0);
}

#[test]
fn bad_flocking_parameters_name_their_key() {
    let err = |set: &[&str]| load("flocking_crossing", set).unwrap_err();
    assert_eq!(err(&["behaviour.mb=1.5"]).key, "behaviour.mb");
    assert_eq!(
        err(&["behaviour.migration_deg=[0.0, 90.0, 180.0]"]).key,
        "behaviour.migration_deg"
    );
    let e = err(&["behaviour.encoding=\"byte\""]);
    assert_eq!(e.key, "behaviour.encoding");
    assert!(
        e.message.contains("8 robots") || e.message.contains("flock"),
        "{e}"
    );
    assert_eq!(err(&["behaviour.heading=\"gps\""]).key, "behaviour.heading");
}

/// Two robots of one flock over two ticks of 64 ms.
fn two_robot_records(theta1: f64) -> Records {
    let traj = format!(
        "tick,id,x,y,theta,v,omega,lidar,state\n\
         0,0,0.0,0.0,0.0,0,0,1,active\n\
         0,1,0.2,0.0,{theta1},0,0,1,active\n\
         1,0,0.0064,0.0,0.0,0,0,1,active\n\
         1,1,0.2064,0.0,{theta1},0,0,1,active\n"
    );
    Records::parse(&traj, "").unwrap()
}

#[test]
fn eq14_22_metrics_on_a_known_run() {
    let cfg = obstacles(2);
    let p = params(&cfg);
    let ticks = flock_ticks(&cfg, &p, &two_robot_records(0.0));
    assert_eq!(ticks.len(), 1);
    assert_eq!(ticks[0].len(), 1, "tick 0 has no velocity");
    let t = ticks[0][0];
    assert!(close(t.order, 1.0, EPS));
    // Both 0.1 m from the centre of mass.
    assert!(close(t.cohesion, 1.0 / 1.1, EPS));
    // 6.4 mm in 64 ms along +x = 0.1 m/s, over v_max = 0.0628.
    assert!(close(t.velocity, 0.1 / 0.0628, 1e-9));
    assert!(close(t.performance, t.order * t.cohesion * t.velocity, EPS));
    assert!(close(t.overall, t.performance, EPS));
    // s' = 1 (nobody closer than D = 0.1 to the centre), f_p = 0.3 + 0.4 c' + 0.3.
    assert!(close(t.fitness_term, 0.6 + 0.4 / 1.1, EPS));

    let t = flock_ticks(&cfg, &p, &two_robot_records(FRAC_PI_2))[0][0];
    assert!(close(t.order, 0.5f64.sqrt(), EPS), "{}", t.order);

    let m = registry::configure(&cfg)
        .unwrap()
        .metrics(&two_robot_records(0.0));
    let f = &m.iter().find(|(k, _)| *k == "flocking").unwrap().1;
    let fitness = 0.9 * (0.6 + 0.4 / 1.1) + 0.1 * 0.0064;
    assert!(close(f["fitness"].as_f64().unwrap(), fitness, 1e-9), "{f}");
    assert!(close(f["distance"].as_f64().unwrap(), 0.0064, 1e-9), "{f}");
    assert_eq!(f["flocks"].as_array().unwrap().len(), 1);
}

#[test]
fn a_robot_knocked_down_stays_in_its_flock_and_slows_it() {
    let cfg = obstacles(2);
    let traj = "tick,id,x,y,theta,v,omega,lidar,state\n\
         0,0,0.0,0.0,0.0,0,0,1,active\n\
         0,1,0.2,0.0,0.0,0,0,1,active\n\
         1,0,0.0064,0.0,0.0,0,0,1,active\n\
         1,1,0.2,0.0,0.0,0,0,1,down\n";
    let rec = Records::parse(traj, "").unwrap();
    let t = flock_ticks(&cfg, &params(&cfg), &rec)[0][0];
    assert_eq!(t.robots, 1, "one still active");
    // The centre of mass moved 3.2 mm, not 6.4: the down robot is still part of the flock.
    assert!(close(t.velocity, 0.05 / 0.0628, 1e-9), "{}", t.velocity);
}
