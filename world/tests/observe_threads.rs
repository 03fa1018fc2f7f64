//! `World::observe` splits large swarms over threads: every thread count gives the same
//! observations, tick after tick, with noise on (each robot draws from its own stream), into
//! slots that held anything before, and `World::observe_each` hands over the same.

use swarmrt_agent::RadioMsg;
use swarmrt_agent::behaviours::goto::Beacon;
use swarmrt_agent::registry::VOCABULARY;
use swarmrt_protocol::{BROADCAST, Command, Observation};
use swarmrt_scenario::Config;
use swarmrt_world::World;

fn config() -> Config {
    let text = r#"
[scenario]
name = "threads"
ticks = 1000
stop_when_done = false
[map]
bounds = [0.0, 0.0, 20.0, 20.0]
goal = { x = 15.0, y = 15.0, radius = 1.0 }
circles = [{ x = 4.0, y = 4.0, r = 1.0 }]
[robots]
count = 300
start = { x = 10.0, y = 10.0, spacing = 0.7, heading_deg = 30.0 }
noise = { pose = 0.01, heading = 0.01, lidar = 0.02 }
[radio]
range = 4.0
loss = 0.1
"#;
    Config::from_toml_str("threads.toml", text, &[]).unwrap()
}

/// How the observations are asked for.
#[derive(Clone, Copy)]
enum Mode {
    /// `observe_on` into slots that start empty.
    Slots,
    /// `observe_on` into slots that start full of another observation's bytes.
    Dirty,
    /// `observe_each`, copying what it hands over.
    Each,
}

fn run(threads: usize, mode: Mode) -> Vec<Vec<Observation>> {
    let cfg = config();
    let mut world = World::new(&cfg, VOCABULARY).unwrap();
    let n = cfg.robots.count as usize;
    let mut obs = vec![Observation::empty(0, 0); n];
    if let Mode::Dirty = mode {
        let mut dirt = Observation::empty(7, 99);
        dirt.lidar = [1.5; swarmrt_protocol::MAX_LIDAR_RAYS];
        dirt.neighbours[..].iter_mut().for_each(|nb| nb.range = 2.5);
        dirt.inbox[..].iter_mut().for_each(|f| f.len = 3);
        dirt.goal_visible = 1;
        dirt.z = 4.0;
        obs.fill(dirt);
    }
    let mut seen = Vec::new();
    for _ in 0..12 {
        match mode {
            Mode::Slots | Mode::Dirty => world.observe_on(&mut obs, threads),
            Mode::Each => world.observe_each(&mut obs, threads, |i, o, slot| {
                assert_eq!(o.robot as usize, i);
                *slot = *o;
            }),
        }
        seen.push(obs.clone());
        let cmds: Vec<Option<Command>> = obs
            .iter()
            .map(|o| {
                let mut c = Command::act(o.robot, o.tick);
                c.v = 0.2;
                c.omega = 0.3;
                c.lidar_on = (o.robot % 3 != 0) as u8;
                if o.tick % 2 == 0 {
                    let beacon = RadioMsg::Goto(Beacon {
                        x: o.x,
                        y: o.y,
                        theta: o.theta,
                    });
                    c.push_frame(BROADCAST, &beacon).unwrap();
                }
                Some(c)
            })
            .collect();
        world.step(&cmds);
    }
    seen
}

#[test]
fn observe_gives_the_same_observations_on_any_number_of_threads() {
    let one = run(1, Mode::Slots);
    assert!(
        one.iter()
            .flatten()
            .any(|o| o.inbox_len > 0 && o.lidar_len > 0)
    );
    for (threads, mode) in [
        (2, Mode::Slots),
        (3, Mode::Slots),
        (7, Mode::Slots),
        (1, Mode::Dirty),
        (2, Mode::Dirty),
        (1, Mode::Each),
        (2, Mode::Each),
        (3, Mode::Each),
    ] {
        let many = run(threads, mode);
        for (tick, (a, b)) in one.iter().zip(&many).enumerate() {
            for (x, y) in a.iter().zip(b) {
                assert_eq!(
                    format!("{x:?}"),
                    format!("{y:?}"),
                    "tick {tick}, robot {}, {threads} threads",
                    x.robot
                );
            }
        }
    }
}
