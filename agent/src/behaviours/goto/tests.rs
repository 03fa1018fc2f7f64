//! The go-to behaviour and the agent core, observation in, command out.

use crate::Agent;
use crate::RadioMsg;
use crate::behaviours::goto::Beacon;
use swarmrt_protocol::{Frame, MAX_PAYLOAD, Observation, RobotState};
use swarmrt_scenario::Config;

const GOTO: &str = r#"
[scenario]
name = "goto"
ticks = 100
[map]
bounds = [0.0, 0.0, 10.0, 10.0]
goal = { x = 8.0, y = 2.0, radius = 1.0 }
[robots]
count = 1
lidar = { rays = 5, fov_deg = 180.0, range = 3.0 }
[behaviour]
kind = "goto"
beacon_period = 4
"#;

fn config() -> Config {
    Config::from_toml_str("goto.toml", GOTO, &[]).unwrap()
}

fn obs_at(x: f64, y: f64, theta: f64, tick: u64) -> Observation {
    let mut o = Observation::empty(0, tick);
    o.x = x;
    o.y = y;
    o.theta = theta;
    o.lidar_len = 5;
    o.lidar[..5].fill(3.0);
    o
}

#[test]
fn drives_toward_its_slot_and_stops_there() {
    let mut a = Agent::new(&config(), 0);
    let c = a.step(&obs_at(2.0, 2.0, 0.0, 1)).without_storage();
    assert!(c.v > 0.0 && c.omega.abs() < 1e-9, "straight ahead: {c:?}");
    let c = a
        .step(&obs_at(2.0, 2.0, std::f64::consts::PI / 2.0, 2))
        .without_storage();
    assert!(c.omega < 0.0, "goal is to the right: {c:?}");
    let c = a.step(&obs_at(8.0, 2.0, 0.0, 3)).without_storage();
    assert_eq!((c.v, c.omega), (0.0, 0.0), "at the slot");
}

#[test]
fn turns_away_from_an_obstacle_toward_the_open_side() {
    let mut a = Agent::new(&config(), 0);
    let mut o = obs_at(2.0, 2.0, 0.0, 1);
    // Rays at -90, -45, 0, 45, 90 degrees: something close ahead and on the right.
    o.lidar[..5].copy_from_slice(&[0.5, 0.4, 0.4, 3.0, 3.0]);
    let c = a.step(&o).without_storage();
    assert!(c.omega > 0.0, "turns left, the open side: {c:?}");
    assert!(c.v < 0.5, "slows down: {c:?}");
}

#[test]
fn beacons_every_period_and_stays_silent_otherwise() {
    let mut a = Agent::new(&config(), 0);
    let sent: Vec<u64> = (0..12)
        .filter(|&t| {
            a.step(&obs_at(2.0, 2.0, 0.0, t))
                .without_storage()
                .outbox_len
                > 0
        })
        .collect();
    assert_eq!(sent, vec![0, 4, 8]);
}

#[test]
fn a_down_robot_stands_still_and_malformed_frames_are_counted_by_robots_that_listen() {
    let frames = |o: &mut Observation| {
        let mut junk = Frame::EMPTY;
        junk.len = MAX_PAYLOAD as u16;
        junk.payload.fill(0x7f);
        o.inbox[0] = junk;
        let mut good = Frame::EMPTY;
        let bytes = postcard_beacon();
        good.len = bytes.len() as u16;
        good.payload[..bytes.len()].copy_from_slice(&bytes);
        good.src = 7;
        good.sent_tick = 0;
        o.inbox[1] = good;
        // Raw bytes between foreign robots: skipped, neither decoded nor counted.
        o.inbox[2] = Frame::opaque(swarmrt_protocol::BROADCAST, &[0xff, 1, 2]).unwrap();
        o.inbox_len = 3;
    };
    let mut o = obs_at(2.0, 2.0, 0.0, 1);
    o.state = RobotState::Down as u8;
    frames(&mut o);
    // Goto steers by its lidar alone: it never reads its inbox, so nothing is decoded.
    let mut a = Agent::new(&config(), 0);
    let c = a.step(&o).without_storage();
    assert_eq!((c.v, c.omega, c.outbox_len), (0.0, 0.0, 0));
    assert_eq!(a.malformed(), 0, "goto decodes nothing");
    // The same frames to a behaviour that listens (flocking), and to goto with consensus.
    for cfg in [
        listening("[behaviour]\nkind = \"flocking\""),
        with_consensus(),
    ] {
        let mut a = Agent::new(&cfg, 0);
        let c = a.step(&o).without_storage();
        assert_eq!((c.v, c.omega, c.outbox_len), (0.0, 0.0, 0));
        assert_eq!(
            a.malformed(),
            1,
            "the junk frame only: the beacon decodes, the opaque frame is skipped"
        );
    }
}

/// [`config`] with its `[behaviour]` table replaced by `behaviour`.
fn listening(behaviour: &str) -> Config {
    let text = GOTO.replace("[behaviour]\nkind = \"goto\"\nbeacon_period = 4", behaviour);
    assert_ne!(text, GOTO, "the behaviour table was replaced");
    Config::from_toml_str("listening.toml", &text, &[]).unwrap()
}

/// [`config`] with a Raft election, whose messages travel in the same frames.
fn with_consensus() -> Config {
    let text = format!("{GOTO}\n[consensus]\nalgorithm = \"raft\"\n");
    Config::from_toml_str("consensus.toml", &text, &[]).unwrap()
}

fn postcard_beacon() -> Vec<u8> {
    let mut c = swarmrt_protocol::Command::act(0, 0);
    c.push_frame(
        0,
        &RadioMsg::Goto(Beacon {
            x: 1.0,
            y: 2.0,
            theta: 0.0,
        }),
    )
    .unwrap();
    c.outbox[0].bytes().to_vec()
}
