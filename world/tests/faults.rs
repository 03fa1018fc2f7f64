//! The fault schedule in the world core: freezes, restarts, kills and random faults take
//! effect at exactly their tick boundary and hand the shell the signals to send.

use swarmrt_agent::registry::VOCABULARY;
use swarmrt_protocol::control::ProcessFault;
use swarmrt_protocol::records::FaultKind;
use swarmrt_protocol::{Command, Observation, RobotState};
use swarmrt_scenario::Config;
use swarmrt_world::{Event, ProcessSignal, World};

/// `count` robots in a row on an empty 20 x 20 map, plus `faults` (TOML text).
fn config(count: u32, faults: &str) -> Config {
    let text = format!(
        r#"
[scenario]
name = "faults"
ticks = 100000
dt = 0.1
stop_when_done = false
[map]
bounds = [0.0, 0.0, 20.0, 20.0]
goal = {{ x = 19.0, y = 19.0, radius = 0.5 }}
[robots]
count = {count}
radius = 0.1
start = {{ x = 5.0, y = 5.0, spacing = 0.5, heading_deg = 0.0 }}
{faults}
"#
    );
    Config::from_toml_str("faults.toml", &text, &[]).unwrap()
}

/// One tick: every robot asks for `v` forward; returns the observations it saw.
fn tick(w: &mut World, v: f64) -> Vec<Observation> {
    let n = w.robots().len();
    let mut obs = vec![Observation::empty(0, 0); n];
    w.observe(&mut obs);
    let cmds: Vec<_> = (0..n)
        .map(|i| {
            let mut c = Command::act(i as u32, w.tick());
            c.v = v;
            Some(c)
        })
        .collect();
    w.step(&cmds);
    obs
}

fn faults(events: &[Event]) -> Vec<(u64, FaultKind, Option<u32>)> {
    events
        .iter()
        .filter_map(|e| match e {
            Event::Fault {
                tick, fault, robot, ..
            } => Some((*tick, *fault, *robot)),
            _ => None,
        })
        .collect()
}

#[test]
fn a_frozen_robot_stands_still_from_its_first_tick_and_resumes_at_the_last() {
    let mut w = World::new(
        &config(2, "[[faults.freeze]]\nrobot = 1\nfrom = 5\nto = 10\n"),
        VOCABULARY,
    )
    .unwrap();
    let mut signals = Vec::new();
    let mut xs = Vec::new();
    for _ in 0..15 {
        signals.extend(w.take_signals().into_iter().map(|s| (w.tick(), s)));
        let obs = tick(&mut w, 1.0);
        xs.push((obs[1].tick, obs[1].state, w.robots()[1].x));
    }
    assert_eq!(
        signals,
        vec![
            (5, ProcessSignal::Fault(ProcessFault::Freeze { robot: 1 })),
            (10, ProcessSignal::Fault(ProcessFault::Thaw { robot: 1 }))
        ]
    );
    for (t, state, _) in &xs {
        let frozen = (5..10).contains(t);
        assert_eq!(
            *state == RobotState::Frozen as u8,
            frozen,
            "tick {t}: state {state}"
        );
    }
    // Its command during the freeze is ignored: it does not move from tick 5 to 10.
    let x_at = |t: u64| xs.iter().find(|x| x.0 == t).unwrap().2;
    assert_eq!(x_at(4), x_at(9));
    assert!(x_at(10) > x_at(9));
    assert_eq!(w.metrics().frozen_ticks, 5);
    assert_eq!(w.metrics().faults_injected, 1);
    assert_eq!(
        faults(&w.drain_events()),
        vec![
            (5, FaultKind::Freeze, Some(1)),
            (10, FaultKind::Thaw, Some(1))
        ]
    );
    // The other robot never stopped.
    assert!(w.robots()[0].x > 5.0 + 1.0);
}

#[test]
fn a_restart_takes_the_robot_offline_and_brings_it_back_fresh() {
    let mut w = World::new(
        &config(
            3,
            "[[faults.restart]]\ntick = 4\nrobot = 2\ndown_ticks = 3\n\
             [[faults.restart]]\ntick = 20\nrobot = 2\n",
        ),
        VOCABULARY,
    )
    .unwrap();
    let mut signals = Vec::new();
    let mut states = Vec::new();
    for _ in 0..40 {
        signals.extend(w.take_signals().into_iter().map(|s| (w.tick(), s)));
        let obs = tick(&mut w, 0.5);
        states.push(RobotState::from_u8(obs[2].state).unwrap());
    }
    assert_eq!(
        signals,
        vec![
            (
                4,
                ProcessSignal::Fault(ProcessFault::Restart {
                    robot: 2,
                    incarnation: 1
                })
            ),
            (7, ProcessSignal::Rejoin(2)),
            (
                20,
                ProcessSignal::Fault(ProcessFault::Restart {
                    robot: 2,
                    incarnation: 2
                })
            ),
            // down_ticks defaults to 10.
            (30, ProcessSignal::Rejoin(2)),
        ]
    );
    for (t, s) in states.iter().enumerate() {
        let offline = (4..7).contains(&t) || (20..30).contains(&t);
        assert_eq!(*s == RobotState::Restarting, offline, "tick {t}: {s:?}");
        assert_ne!(*s, RobotState::Dead);
    }
    let m = w.metrics();
    assert_eq!((m.restarts, m.faults_injected, m.dead), (2, 2, 0));
}

#[test]
fn a_kill_ends_a_freeze_and_a_dead_robot_is_neither_frozen_nor_restarted() {
    let mut w = World::new(
        &config(
            2,
            "[[faults.freeze]]\nrobot = 0\nfrom = 2\nto = 10\n\
             [[faults.kill]]\ntick = 5\nrobot = 0\n\
             [[faults.restart]]\ntick = 6\nrobot = 0\n\
             [[faults.freeze]]\nrobot = 0\nfrom = 7\nto = 8\n\
             [[faults.freeze]]\nrobot = \"leader\"\nfrom = 3\nto = 4\n",
        ),
        VOCABULARY,
    )
    .unwrap();
    let mut signals = Vec::new();
    for _ in 0..12 {
        signals.extend(w.take_signals());
        tick(&mut w, 0.0);
    }
    assert_eq!(
        signals,
        vec![
            ProcessSignal::Fault(ProcessFault::Freeze { robot: 0 }),
            ProcessSignal::Fault(ProcessFault::Kill { robot: 0 })
        ],
        "no thaw for a dead robot, no restart or freeze of one"
    );
    assert_eq!(w.robots()[0].state, RobotState::Dead);
    let f: Vec<FaultKind> = faults(&w.drain_events()).into_iter().map(|f| f.1).collect();
    assert_eq!(
        f,
        [
            FaultKind::Freeze,
            FaultKind::FreezeSkipped,
            FaultKind::Kill,
            FaultKind::RestartSkipped,
            FaultKind::FreezeSkipped
        ]
    );
}

#[test]
fn a_robot_down_before_a_freeze_is_down_after_it() {
    let mut w = World::new(
        &config(1, "[[faults.freeze]]\nrobot = 0\nfrom = 80\nto = 85\n"),
        VOCABULARY,
    )
    .unwrap();
    // Drive into the wall at x = 0.
    let mut obs = vec![Observation::empty(0, 0)];
    while w.robots()[0].state == RobotState::Active {
        w.observe(&mut obs);
        let mut c = Command::act(0, w.tick());
        c.v = -1.0;
        w.step(&[Some(c)]);
    }
    assert!(w.tick() < 80);
    while w.tick() < 82 {
        tick(&mut w, 0.0);
    }
    assert_eq!(w.robots()[0].state, RobotState::Frozen);
    while w.tick() < 86 {
        tick(&mut w, 0.0);
    }
    assert_eq!(w.robots()[0].state, RobotState::Down);
}

#[test]
fn random_faults_follow_the_seed_and_their_rate() {
    let run = |seed: u64| {
        let mut cfg = config(
            20,
            "[faults]\nkill_rate = 0.0005\nfreeze_rate = 0.01\nfreeze_ticks = 7\n",
        );
        cfg.scenario.seed = seed;
        let mut w = World::new(&cfg, VOCABULARY).unwrap();
        let mut signals = Vec::new();
        let mut running = 0u64;
        for _ in 0..2000 {
            signals.extend(w.take_signals().into_iter().map(|s| (w.tick(), s)));
            running += w
                .robots()
                .iter()
                .filter(|r| r.state.expects_command())
                .count() as u64;
            tick(&mut w, 0.0);
        }
        (signals, running, w.metrics())
    };
    let (a, running, m) = run(7);
    assert_eq!(a, run(7).0, "same seed, same faults");
    assert_ne!(a, run(8).0, "another seed, other faults");
    let kills = a
        .iter()
        .filter(|s| matches!(s.1, ProcessSignal::Fault(ProcessFault::Kill { .. })))
        .count() as f64;
    let freezes: Vec<_> = a
        .iter()
        .filter_map(|s| match s.1 {
            ProcessSignal::Fault(ProcessFault::Freeze { robot: r }) => Some((s.0, r)),
            _ => None,
        })
        .collect();
    // Each thaw comes exactly freeze_ticks later.
    for (t, r) in &freezes {
        if t + 7 < 2000
            && !a.iter().any(|s| {
                s.1 == ProcessSignal::Fault(ProcessFault::Kill { robot: *r })
                    && s.0 > *t
                    && s.0 <= t + 7
            })
        {
            assert!(
                a.contains(&(
                    t + 7,
                    ProcessSignal::Fault(ProcessFault::Thaw { robot: *r })
                )),
                "{t} {r}"
            );
        }
    }
    // Counts within 5 standard deviations of a Bernoulli draw per running robot-tick (a
    // robot that draws "kill" is not also frozen).
    let within = |count: f64, p: f64| {
        let mean = running as f64 * p;
        (count - mean).abs() <= 5.0 * (mean * (1.0 - p)).sqrt() + 1.0
    };
    assert!(
        within(kills, 0.0005),
        "{kills} kills in {running} robot-ticks"
    );
    assert!(
        within(freezes.len() as f64, 0.01),
        "{} freezes in {running} robot-ticks",
        freezes.len()
    );
    assert_eq!(m.dead as f64, kills);
    assert_eq!(m.faults_injected as f64, kills + freezes.len() as f64);
}
