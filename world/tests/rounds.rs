//! In-tick propagation rounds (`radio.rounds`): frames marked `in_tick` wake only their
//! receivers before the world steps, a reaction's motion replaces the tick's decision and its
//! frames go on in the next round; the cap, the medium's range and loss apply, and without
//! rounds nothing of this happens.

use swarmrt_protocol::{Command, CommandKind, Observation, Vocabulary};
use swarmrt_scenario::Config;
use swarmrt_world::World;

/// Four robots 1 m apart in a row along x, radio range 1.5 m; `radio` is extra `[radio]`.
fn world(radio: &str) -> World {
    let text = format!(
        r#"
[scenario]
name = "rounds"
ticks = 100
dt = 0.1
[map]
bounds = [0.0, 0.0, 20.0, 20.0]
goal = {{ x = 19.0, y = 19.0, radius = 0.5 }}
[robots]
count = 4
radius = 0.1
start = {{ spacing = 1.0, path = [[5.0, 5.0], [9.0, 5.0]] }}
[radio]
range = 1.5
{radio}
"#
    );
    let cfg = Config::from_toml_str("rounds.toml", &text, &[]).unwrap();
    World::new(&cfg, Vocabulary::ANY).unwrap()
}

/// Every robot stands still; robot `from` sends one frame to each of `to`, the first
/// `in_tick` of them within the tick.
fn commands(w: &World, from: u32, to: &[u32], in_tick: u16) -> Vec<Option<Command>> {
    (0..4)
        .map(|i| {
            let mut c = Command::act(i, w.tick());
            if i == from {
                for &dst in to {
                    c.push_frame(dst, &(1u8,)).unwrap();
                }
                c.in_tick = in_tick;
            }
            Some(c)
        })
        .collect()
}

/// Robot `robot`'s reaction: forward speed `v`, and a frame to each of `to`.
fn reaction(w: &World, robot: u32, v: f64, to: &[u32]) -> Command {
    let mut c = Command::act(robot, w.tick());
    c.kind = CommandKind::React as u32;
    c.v = v;
    for &dst in to {
        c.push_frame(dst, &(8u8, dst)).unwrap();
    }
    c
}

/// Robot ids sorted by x (the row's order along the start line may not be by id).
fn row_order(w: &World) -> Vec<u32> {
    let mut ids: Vec<u32> = (0..4).collect();
    ids.sort_by(|a, b| {
        w.robots()[*a as usize]
            .x
            .total_cmp(&w.robots()[*b as usize].x)
    });
    ids
}

#[test]
fn a_motion_passes_down_the_row_within_one_tick_and_only_receivers_wake() {
    let mut w = world("rounds = 8");
    let order = row_order(&w);
    let mut obs = vec![Observation::empty(0, 0); 4];
    w.observe(&mut obs);
    // The first robot of the row sends within the tick to its neighbour, and a normal frame.
    let (first, second, third) = (order[0], order[1], order[2]);
    let mut cmds: Vec<Option<Command>> = (0..4)
        .map(|i| {
            let mut c = Command::act(i, 0);
            if i == first {
                c.push_frame(second, &(1u8,)).unwrap();
                c.push_frame(second, &(2u8,)).unwrap();
                c.in_tick = 1;
            }
            Some(c)
        })
        .collect();
    w.start_rounds(&cmds);
    let r1 = w.next_round();
    assert_eq!(w.round(), 1);
    assert_eq!(r1.len(), 1, "only the receiver wakes");
    assert_eq!(r1[0].robot, second);
    assert_eq!(r1[0].inbox().len(), 1);
    assert_eq!(r1[0].inbox()[0].src, first);
    assert_eq!(r1[0].inbox()[0].bytes(), &[1u8][..]);
    // It reacts: moves, and passes on to the next robot of the row.
    let react = reaction(&w, second, 0.5, &[third]);
    w.react(second, Some(&react), &mut cmds);
    assert_eq!(cmds[second as usize].unwrap().v, 0.5);
    let r2 = w.next_round();
    assert_eq!(r2.len(), 1);
    assert_eq!(r2[0].robot, third);
    assert_eq!(r2[0].inbox()[0].src, second);
    // The third reacts without passing on: the rounds end, the tick's round is 0 again.
    w.react(third, Some(&reaction(&w, third, 0.25, &[])), &mut cmds);
    assert!(w.next_round().is_empty());
    assert_eq!(w.round(), 0);
    let at = |w: &World| (w.robots()[second as usize].x, w.robots()[second as usize].y);
    let p0 = at(&w);
    w.step(&cmds);
    // The reaction's motion was applied; the frame sent within the tick is not delivered
    // again with the next observation, the ordinary one is.
    let p1 = at(&w);
    assert!((p1.0 - p0.0).hypot(p1.1 - p0.1) > 0.04, "{p0:?} -> {p1:?}");
    w.observe(&mut obs);
    let inbox = obs[second as usize].inbox();
    assert_eq!(inbox.len(), 1);
    assert_eq!(inbox[0].bytes(), &[2u8][..]);
    let m = w.metrics().rounds.expect("rounds are on");
    assert_eq!((m.rounds, m.max_in_a_tick, m.wakeups), (2, 2, 2));
    assert_eq!((m.sent, m.delivered, m.dropped, m.capped), (2, 2, 0, 0));
    assert_eq!(
        w.metrics().radio.sent,
        1,
        "the tick's radio counts only the ordinary frame"
    );
}

#[test]
fn the_cap_ends_the_rounds_and_counts_what_was_still_in_flight() {
    let mut w = world("rounds = 1");
    let order = row_order(&w);
    let mut cmds = commands(&w, order[0], &[order[1]], 1);
    w.start_rounds(&cmds);
    assert_eq!(w.next_round().len(), 1);
    let react = reaction(&w, order[1], 0.0, &[order[2]]);
    w.react(order[1], Some(&react), &mut cmds);
    assert!(w.next_round().is_empty(), "the cap of 1 round is reached");
    let m = w.metrics().rounds.unwrap();
    assert_eq!((m.capped_ticks, m.capped, m.delivered), (1, 1, 1));
}

#[test]
fn range_loss_and_a_refused_reaction_are_counted_not_delivered() {
    // Robot 0 broadcasts within the tick: only the neighbours within 1.5 m hear it.
    let mut w = world("rounds = 4");
    let order = row_order(&w);
    let mut cmds = commands(&w, order[0], &[swarmrt_protocol::BROADCAST], 1);
    w.start_rounds(&cmds);
    let r = w.next_round();
    assert_eq!(
        r.iter().map(|b| b.robot).collect::<Vec<_>>(),
        vec![order[1]]
    );
    // An Act where a React is due is refused: the motion stays, nothing goes on.
    let mut wrong = reaction(&w, order[1], 0.5, &[order[2]]);
    wrong.kind = CommandKind::Act as u32;
    w.react(order[1], Some(&wrong), &mut cmds);
    assert_eq!(cmds[order[1] as usize].unwrap().v, 0.0);
    assert!(w.next_round().is_empty());
    let m = w.metrics();
    assert_eq!(m.rounds.unwrap().rejected, 1);
    assert_eq!(m.rejected, 1);
    // Total loss: a frame within the tick never arrives, and no robot wakes.
    let mut w = world("rounds = 4\nloss = 1.0");
    let order = row_order(&w);
    let cmds = commands(&w, order[0], &[order[1]], 1);
    w.start_rounds(&cmds);
    assert!(w.next_round().is_empty());
    let m = w.metrics().rounds.unwrap();
    assert_eq!((m.sent, m.dropped, m.rounds), (1, 1, 0));
}

#[test]
fn without_rounds_in_tick_frames_are_ordinary_and_no_round_runs() {
    let mut w = world("");
    let order = row_order(&w);
    let cmds = commands(&w, order[0], &[order[1]], 1);
    assert!(!w.has_rounds());
    w.start_rounds(&cmds);
    assert!(w.next_round().is_empty());
    w.step(&cmds);
    let mut obs = vec![Observation::empty(0, 0); 4];
    w.observe(&mut obs);
    assert_eq!(
        obs[order[1] as usize].inbox().len(),
        1,
        "delivered with the next tick"
    );
    assert!(w.metrics().rounds.is_none());
}

#[test]
fn rounds_with_delay_are_refused_naming_the_key() {
    let text = r#"
[scenario]
name = "x"
ticks = 10
[map]
bounds = [0.0, 0.0, 20.0, 20.0]
goal = { x = 19.0, y = 19.0, radius = 0.5 }
[robots]
count = 2
start = { x = 5.0, y = 5.0, spacing = 1.0 }
[radio]
rounds = 4
jitter_ticks = 2
"#;
    let e = Config::from_toml_str("x.toml", text, &[])
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("radio.rounds") && e.contains("jitter_ticks = 2"),
        "{e}"
    );
}
