//! `World::observe` splits large swarms over threads: every thread count gives the same
//! observations, tick after tick, with noise on (each robot draws from its own stream).

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

fn run(threads: usize) -> Vec<Vec<Observation>> {
    let cfg = config();
    let mut world = World::new(&cfg, VOCABULARY).unwrap();
    let n = cfg.robots.count as usize;
    let mut obs = vec![Observation::empty(0, 0); n];
    let mut seen = Vec::new();
    for _ in 0..12 {
        world.observe_on(&mut obs, threads);
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
    let one = run(1);
    assert!(
        one.iter()
            .flatten()
            .any(|o| o.inbox_len > 0 && o.lidar_len > 0)
    );
    for threads in [2, 3, 7] {
        let many = run(threads);
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
