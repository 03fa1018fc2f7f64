//! The stall watch (`scenario.stall_ticks`): a run whose live robots all stopped short of the
//! goal ends with the reason; a robot still moving, one frozen (it may come back), or the
//! watch switched off keeps the run going.

use swarmrt_agent::registry::VOCABULARY;
use swarmrt_protocol::{Command, Observation};
use swarmrt_scenario::Config;
use swarmrt_world::World;

/// Two robots in a row on an empty 20 x 20 map, the goal far away; `extra` is TOML text.
fn config(scenario: &str, extra: &str) -> Config {
    let text = format!(
        r#"
[scenario]
name = "stall"
ticks = 1000
dt = 0.1
{scenario}
[map]
bounds = [0.0, 0.0, 20.0, 20.0]
goal = {{ x = 19.0, y = 19.0, radius = 0.5 }}
[robots]
count = 2
radius = 0.1
max_turn_rate = 10.0
start = {{ x = 5.0, y = 5.0, spacing = 2.0, heading_deg = 0.0 }}
{extra}
"#
    );
    Config::from_toml_str("stall.toml", &text, &[]).unwrap()
}

/// Runs until the world is finished (or 1000 ticks); robot i gets forward speed `v(i, tick)`
/// and turns on the spot, so a robot with speed stays in motion.
fn run(w: &mut World, v: impl Fn(u32, u64) -> f64) {
    let n = w.robots().len();
    let mut obs = vec![Observation::empty(0, 0); n];
    while !w.finished() {
        w.observe(&mut obs);
        let cmds: Vec<_> = (0..n as u32)
            .map(|i| {
                let mut c = Command::act(i, w.tick());
                c.v = v(i, w.tick());
                c.omega = 1.0;
                Some(c)
            })
            .collect();
        w.step(&cmds);
    }
}

#[test]
fn robots_that_stop_short_of_the_goal_end_the_run_with_the_reason() {
    let cfg = config("stall_ticks = 50", "");
    let mut w = World::new(&cfg, VOCABULARY).unwrap();
    // Both drive for 100 ticks, then stop for good.
    run(&mut w, |_, t| if t < 100 { 0.5 } else { 0.0 });
    let m = w.metrics();
    let stalled = m.stalled.clone().expect("the run stalled");
    assert_eq!(stalled.robots, vec![0, 1]);
    assert_eq!(stalled.ticks, 50);
    // The last move left the footprint before tick 100; 50 still ticks later it ends.
    assert!(
        (140..=151).contains(&stalled.tick),
        "stalled at {}",
        stalled.tick
    );
    assert_eq!(w.tick(), stalled.tick);
    assert!(stalled.line().contains("robots 0, 1"), "{}", stalled.line());
    assert!(stalled.line().contains("scenario.stall_ticks"));
    let json = serde_json::to_value(&m).unwrap();
    assert_eq!(json["stalled"]["tick"], stalled.tick);
}

#[test]
fn one_robot_still_moving_keeps_the_run_going() {
    let cfg = config("stall_ticks = 50", "");
    let mut w = World::new(&cfg, VOCABULARY).unwrap();
    // Robot 1 circles (0.3 m/s at 1 rad/s: a 0.6 m circle) the whole run; robot 0 stands.
    run(&mut w, |i, _| if i == 1 { 0.3 } else { 0.0 });
    assert_eq!(w.metrics().stalled, None);
    assert_eq!(w.tick(), 1000);
}

#[test]
fn a_frozen_robot_may_come_back_so_the_run_waits_for_it() {
    let cfg = config(
        "stall_ticks = 50",
        "[[faults.freeze]]\nrobot = 1\nfrom = 10\nto = 300\n",
    );
    let mut w = World::new(&cfg, VOCABULARY).unwrap();
    run(&mut w, |_, _| 0.0);
    let stalled = w.metrics().stalled.expect("stalled after the thaw");
    // Not while robot 1 was frozen: only once it stood still 50 ticks after its thaw too.
    assert!(stalled.tick >= 300, "stalled at {}", stalled.tick);
    assert_eq!(stalled.robots, vec![0, 1]);
}

#[test]
fn the_watch_is_off_at_zero_and_without_stop_when_done() {
    for scenario in [
        "stall_ticks = 0",
        "stall_ticks = 50\nstop_when_done = false",
    ] {
        let mut w = World::new(&config(scenario, ""), VOCABULARY).unwrap();
        run(&mut w, |_, _| 0.0);
        assert_eq!(w.metrics().stalled, None, "{scenario}");
        assert_eq!(w.tick(), 1000, "{scenario}");
    }
}

#[test]
fn the_default_is_600_ticks_and_out_of_range_is_refused() {
    let cfg = config("", "");
    assert_eq!(cfg.scenario.stall_ticks, 600);
    let text = "[scenario]\nname = \"s\"\nticks = 10\nstall_ticks = -1\n[map]\nbounds = [0.0, 0.0, 1.0, 1.0]\ngoal = { x = 0.5, y = 0.5, radius = 0.1 }\n[robots]\ncount = 1\n";
    let err = Config::from_toml_str("s.toml", text, &[])
        .unwrap_err()
        .to_string();
    assert!(err.contains("stall_ticks"), "{err}");
}
