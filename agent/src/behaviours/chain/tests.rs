//! Seed 003's rules against hand-computed geometry: Push, Pull, Resize and Rotate (Fig. 4-5),
//! the connector angle, Table 2 row by row, and a veto from a fixed slave reversing the
//! propagation (Fig. 3), observation in, command and frames out.

use crate::behaviour::{Act, Behaviour};
use crate::behaviours::chain::{
    Chain, ChainNote, ChainParams, Layer, Link, Reaction, Sides, Target, Wheels, adapt,
    clamp_angle, connector_angle, line_blocked, rotate_towards, segment_collision, shake, subsume,
};
use crate::inbox::Heard;
use swarmrt_protocol::{Neighbour, Observation};
use swarmrt_scenario::Config;

const EPS: f64 = 1e-12;

fn close(a: (f64, f64), b: (f64, f64)) -> bool {
    (a.0 - b.0).abs() < 1e-9 && (a.1 - b.1).abs() < 1e-9
}

#[test]
fn pull_beyond_rod_max_push_inside_rod_min_resize_in_between() {
    let m = (0.0, 0.0);
    // Slave 1 m away on the diagonal (0.6, 0.8): pulled along the guiding line to 0.45 m.
    let (r, p) = adapt(m, (0.6, 0.8), 0.3, 0.45, 0.0);
    assert_eq!(r, Reaction::Pull);
    assert!(close(p, (0.27, 0.36)), "{p:?}");
    // Aiming the master's last step (5 cm) short of rod_max.
    let (_, p) = adapt(m, (1.0, 0.0), 0.3, 0.45, 0.05);
    assert!(close(p, (0.40, 0.0)), "{p:?}");
    // Pushed out to rod_min, away from the master.
    let (r, p) = adapt((1.0, 1.0), (1.0, 0.8), 0.3, 0.45, 0.0);
    assert_eq!(r, Reaction::Push);
    assert!(close(p, (1.0, 0.7)), "{p:?}");
    // In between, the rod resizes and the slave stays.
    let (r, p) = adapt(m, (0.0, -0.4), 0.3, 0.45, 0.0);
    assert_eq!(r, Reaction::Resize);
    assert_eq!(p, (0.0, -0.4));
}

#[test]
fn the_connector_angle_is_kept_in_its_limits_by_rotating_the_rod_about_the_master() {
    let (q, m) = ((-1.0, 0.0), (0.0, 0.0));
    assert!((connector_angle(q, m, (1.0, 0.0)) - std::f64::consts::PI).abs() < EPS);
    // A slave folded back to 30 degrees from q's side goes to 90 degrees, same side, same rod.
    let a = 150f64.to_radians();
    let t = (0.4 * a.cos(), 0.4 * a.sin());
    let c = clamp_angle(q, m, t, 90f64.to_radians(), std::f64::consts::PI);
    assert!(close(c, (0.0, 0.4)), "{c:?}");
    // On the other side too.
    let c = clamp_angle(q, m, (t.0, -t.1), 90f64.to_radians(), std::f64::consts::PI);
    assert!(close(c, (0.0, -0.4)), "{c:?}");
    // Within the limits, unchanged.
    assert_eq!(clamp_angle(q, m, (0.3, 0.2), 1.0, 3.2), (0.3, 0.2));
}

/// A wall along x = 0.5 from y = 0 up to y = 0.6, as lidar hits in the robot frame.
fn wall() -> Vec<(f64, f64)> {
    (0..=12).map(|k| (0.5, k as f64 * 0.05)).collect()
}

#[test]
fn rotate_heads_for_the_newest_point_of_the_master_trail_in_clear_sight() {
    let hits = wall();
    // The master at (1, 0.3) is behind the wall: the guiding line is blocked ...
    assert!(line_blocked(&hits, (1.0, 0.3), 0.13, 0.23));
    // ... but the master's body itself is not an obstacle.
    assert!(!line_blocked(&[(0.95, 0.3)], (1.0, 0.3), 0.13, 0.23));
    // The master came over the top of the wall: of its trail, (0.5, 1.0) is the newest point
    // the slave can reach without passing within 13 cm of the wall ((0.8, 0.9) passes 2.5 cm
    // from its end).
    let trail = [(0.2, 1.0), (0.5, 1.0), (0.8, 0.9), (1.0, 0.6)];
    let pose = (0.0, 0.0, 0.0);
    let to = rotate_towards(pose, trail.iter().copied(), &hits, 0.13);
    assert_eq!(to, Some((0.5, 1.0)));
    // Seen from a robot turned by 90 degrees, the same world points give the same answer.
    let turned = (0.0, 0.0, std::f64::consts::FRAC_PI_2);
    let rotated: Vec<(f64, f64)> = hits.iter().map(|h| (h.1, -h.0)).collect();
    assert_eq!(
        rotate_towards(turned, trail.iter().copied(), &rotated, 0.13),
        Some((0.5, 1.0))
    );
    // A trail entirely behind the wall: trapped.
    let hidden = [(0.8, 0.2), (1.0, 0.3)];
    assert_eq!(
        rotate_towards(pose, hidden.iter().copied(), &hits, 0.13),
        None
    );
}

#[test]
fn the_collision_point_nearest_the_master_and_appendix_a_shake() {
    // A wall of hits along x = 0.5, y in [-0.3, 0.3]: the rod from the master at (1, 0) to the
    // slave at the origin crosses it at (0.5, 0) (nearest the master of the hits on it).
    let wall: Vec<(f64, f64)> = (-6..=6).map(|k| (0.5, k as f64 * 0.05)).collect();
    let m = (1.0, 0.0);
    let hit = segment_collision(&wall, m, (0.0, 0.0), 0.05, 0.0).unwrap();
    assert!(close(hit, (0.5, 0.0)), "{hit:?}");
    // The master's own body (hits within `ignore` of it) is no collision.
    assert_eq!(
        segment_collision(&wall, (0.55, 0.0), (0.0, 0.0), 0.05, 0.2),
        None
    );
    assert_eq!(segment_collision(&wall, m, (0.0, 1.0), 0.05, 0.0), None);
    // Shaking: every accepted point has a clear guiding line from the master and a clear
    // straight path from the slave; the draws decide which.
    let mut x: u64 = 7;
    let mut draw = || {
        x ^= x << 13;
        x ^= x >> 7;
        x ^= x << 17;
        (x >> 11) as f64 / (1u64 << 53) as f64
    };
    let mut found = Vec::new();
    for _ in 0..20 {
        if let Some(s) = shake(m, &wall, 0.05, 0.0, 0.45, 64, &mut draw) {
            assert_eq!(segment_collision(&wall, m, s, 0.05, 0.0), None, "{s:?}");
            assert!(!line_blocked(&wall, s, 0.05, 0.0), "{s:?}");
            found.push(s);
        }
    }
    assert!(found.len() >= 10, "{found:?}");
    // Beyond the wall's ends: the shake moved the point off the line through the wall.
    assert!(found.iter().all(|s| s.1.abs() > 0.3), "{found:?}");
    // Same draws, same points: the shake is as deterministic as its stream.
    let replay = |seed: u64| {
        let mut x = seed;
        let mut draw = move || {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            (x >> 11) as f64 / (1u64 << 53) as f64
        };
        shake(m, &wall, 0.05, 0.0, 0.45, 64, &mut draw)
    };
    assert_eq!(replay(99), replay(99));
    // A slave boxed in on every side finds nothing within its tries: trapped.
    let boxed: Vec<(f64, f64)> = (0..72)
        .map(|k| {
            let a = k as f64 * std::f64::consts::TAU / 72.0;
            (0.2 * a.cos(), 0.2 * a.sin())
        })
        .collect();
    assert_eq!(shake(m, &boxed, 0.05, 0.0, 0.45, 64, &mut draw), None);
}

fn params() -> ChainParams {
    ChainParams {
        speed: 0.2,
        wall_min: 0.7,
        wall_max: 0.9,
        target_gain: 1.0,
        ..ChainParams::default()
    }
}

fn row(left: f64, right: f64, target: Option<Target>) -> (Layer, Wheels) {
    subsume(Sides { left, right }, target, &params())
}

#[test]
fn table_2_row_by_row() {
    let s = 0.2;
    let w = |vl: f64, vr: f64| Wheels { vl, vr };
    // 6 KEEP-MOVING: walls inside the band [0.7, 0.9] on both sides.
    assert_eq!(row(0.8, 0.8, None), (Layer::KeepMoving, w(s, s)));
    // 5 TARGET-CHECK: the target 0.5 rad to the left slows the left wheel by half.
    let t = Target {
        bearing: 0.5,
        reached: false,
    };
    assert_eq!(row(0.8, 0.8, Some(t)), (Layer::TargetCheck, w(0.5 * s, s)));
    // 4 FAR-RIGHT: leaving the right wall, turn right.
    assert_eq!(row(0.8, 1.2, None), (Layer::FarRight, w(s, 0.0)));
    // 3 FAR-LEFT: leaving the left wall but not the right one, turn left ...
    assert_eq!(row(1.2, 0.8, None), (Layer::FarLeft, w(0.0, s)));
    // ... and leaving both (or seeing no wall at all), FAR-RIGHT keeps the word: the head
    // looks for a wall to its right.
    assert_eq!(row(1.2, 1.3, None), (Layer::FarRight, w(s, 0.0)));
    assert_eq!(row(2.0, 2.0, None), (Layer::FarRight, w(s, 0.0)));
    // 2 CLOSE-RIGHT: wall close to the right, turn left (overrides FAR-LEFT).
    assert_eq!(row(1.2, 0.5, None), (Layer::CloseRight, w(0.0, s)));
    // 1 CLOSE-LEFT: wall close to the left but not the right, turn right (overrides FAR-RIGHT).
    assert_eq!(row(0.5, 1.2, None), (Layer::CloseLeft, w(s, 0.0)));
    // Both close: away from the nearer one.
    assert_eq!(row(0.5, 0.6, None), (Layer::CloseLeft, w(s, 0.0)));
    assert_eq!(row(0.6, 0.5, None), (Layer::CloseRight, w(0.0, s)));
    // With the target in sight, leaving a wall is fine (no orbiting), closing in is not.
    assert_eq!(row(0.8, 1.2, Some(t)).0, Layer::TargetCheck);
    assert_eq!(row(0.5, 1.2, Some(t)).0, Layer::CloseLeft);
    // At the target with stop_at_target, both wheels stop.
    let at = Target {
        bearing: 0.0,
        reached: true,
    };
    let p = ChainParams {
        stop_at_target: true,
        ..params()
    };
    let (layer, wheels) = subsume(
        Sides {
            left: 0.8,
            right: 0.8,
        },
        Some(at),
        &p,
    );
    assert_eq!((layer, wheels), (Layer::TargetCheck, w(0.0, 0.0)));
}

/// Four robots in a row along +x, 0.45 m apart from x = 3 down to x = 1.65; robot 2 fixed.
fn config() -> Config {
    crate::registry::from_toml_str(
        "chain.toml",
        r#"
[scenario]
name = "chain"
ticks = 100
dt = 0.1
[map]
bounds = [0.0, 0.0, 10.0, 10.0]
goal = { x = 9.0, y = 1.0, radius = 0.5 }
[robots]
count = 4
radius = 0.1
max_speed = 0.3
max_turn_rate = 2.0
start = { spacing = 0.45, path = [[3.0, 1.0], [1.0, 1.0]] }
lidar = { rays = 8, fov_deg = 360.0, range = 2.0 }
[behaviour]
kind = "chain"
stationary = [2]
veto_hold = 3
"#,
        &[],
    )
    .unwrap()
}

fn brain(cfg: &Config, id: u32) -> Chain {
    let p: ChainParams = cfg.behaviour.params.clone().try_into().unwrap();
    Chain::new(cfg, &p, id)
}

/// Robot `id` at `(x, y)` facing +x, seeing the robots `others` (id, x, y).
fn obs(id: u32, tick: u64, (x, y): (f64, f64), others: &[(u32, f64, f64)]) -> Observation {
    let mut o = Observation::empty(id, tick);
    (o.x, o.y, o.theta) = (x, y, 0.0);
    o.lidar_len = 8;
    o.lidar[..8].fill(2.0);
    for (k, &(j, ox, oy)) in others.iter().enumerate() {
        o.neighbours[k] = Neighbour {
            id: j,
            range: (ox - x).hypot(oy - y),
            bearing: (oy - y).atan2(ox - x),
        };
    }
    o.neighbours_len = others.len() as u16;
    o
}

fn link(x: f64, y: f64, veto: u16) -> Link {
    Link {
        x: x as f32,
        y: y as f32,
        master: None,
        veto,
    }
}

fn frames(act: &mut Act<Link, ChainNote>) -> (Vec<(u32, Link)>, Vec<ChainNote>) {
    let (f, _, n) = act.drain();
    (f, n.collect())
}

#[test]
fn a_fixed_slave_vetoes_and_the_veto_reverses_the_master_slave_direction() {
    let cfg = config();
    let mut act = Act::default();
    // Robot 2 is fixed at (2.1, 1); its master 1 was pulled to (2.7, 1), 0.6 m away.
    let mut fixed = brain(&cfg, 2);
    fixed.step(&obs(2, 1, (2.1, 1.0), &[(1, 2.7, 1.0)]), &[], &mut act);
    assert_eq!(
        (act.v, act.omega),
        (0.0, 0.0),
        "a stationary robot never moves"
    );
    let (sent, notes) = frames(&mut act);
    let to_master = sent.iter().find(|(d, _)| *d == 1).unwrap().1;
    assert_eq!(to_master.veto, 1);
    assert!(matches!(
        notes[..],
        [ChainNote::Veto {
            master: 1,
            depth: 1,
            ..
        }]
    ));
    // Robot 1 hears the veto: it adapts to robot 2 (back towards it, -x, to mid-rod 0.375 m)
    // instead of following robot 0 (+x), and passes the veto on, one deeper, because robot 0
    // at (3.2, 1) is out of reach from there.
    act.reset();
    let mut middle = brain(&cfg, 1);
    let heard = [Heard {
        src: 2,
        sent_tick: 1,
        msg: link(2.1, 1.0, 1),
    }];
    middle.step(
        &obs(1, 2, (2.7, 1.0), &[(0, 3.2, 1.0), (2, 2.1, 1.0)]),
        &heard,
        &mut act,
    );
    assert!(act.v < 0.0, "backs towards the fixed slave: {}", act.v);
    let (sent, _) = frames(&mut act);
    assert_eq!(sent.iter().find(|(d, _)| *d == 0).unwrap().1.veto, 2);
    assert_eq!(sent.iter().find(|(d, _)| *d == 2).unwrap().1.veto, 0);
    // Without the veto, the same robot follows its master 0 (forwards, +x).
    act.reset();
    let mut free = brain(&cfg, 1);
    free.step(
        &obs(1, 2, (2.7, 1.0), &[(0, 3.3, 1.0), (2, 2.1, 1.0)]),
        &[],
        &mut act,
    );
    assert!(act.v > 0.0, "pulled by its master: {}", act.v);
    assert_eq!(frames(&mut act).0[0].1.veto, 0);
}

#[test]
fn a_veto_that_reaches_the_head_stops_it_then_it_turns_in_place_and_goes_on() {
    let cfg = config();
    let mut head = brain(&cfg, 0);
    let mut act = Act::default();
    // Unvetoed, in open space with the goal out of sight: FAR-RIGHT, it turns right looking
    // for a wall (vl = s, vr = 0 over the 0.2 m axle: v = s / 2, omega = -s / axle).
    head.step(&obs(0, 1, (3.0, 1.0), &[(1, 2.6, 1.0)]), &[], &mut act);
    assert!(
        (act.v - 0.1).abs() < EPS && (act.omega + 1.0).abs() < EPS,
        "{act:?}"
    );
    // A veto of depth 2 arrives while robot 1 is within its rod (0.4 m): the head stops, and says so.
    act.reset();
    let veto = [Heard {
        src: 1,
        sent_tick: 1,
        msg: link(2.6, 1.0, 2),
    }];
    head.step(&obs(0, 2, (3.0, 1.0), &[(1, 2.6, 1.0)]), &veto, &mut act);
    assert_eq!((act.v, act.omega), (0.0, 0.0));
    let (_, notes) = frames(&mut act);
    assert!(matches!(notes[..], [ChainNote::Replan { depth: 2, .. }]));
    // It holds still while the veto holds (veto_hold = 3 ticks) ...
    for tick in 3..5 {
        act.reset();
        head.step(&obs(0, tick, (3.0, 1.0), &[(1, 2.6, 1.0)]), &[], &mut act);
        assert_eq!((act.v, act.omega), (0.0, 0.0), "tick {tick}");
    }
    // ... then turns in place (left: both sides equally free) before moving on.
    act.reset();
    head.step(&obs(0, 5, (3.0, 1.0), &[(1, 2.6, 1.0)]), &[], &mut act);
    assert!(act.v == 0.0 && act.omega > 0.0, "{act:?}");
}

#[test]
fn a_link_with_a_position_no_robot_can_be_at_is_ignored() {
    let cfg = config();
    let mut act = Act::default();
    let mut slave = brain(&cfg, 1);
    // Its master 0 is out of range-and-bearing sight; the radio says it is at NaN.
    let heard = [Heard {
        src: 0,
        sent_tick: 1,
        msg: link(f64::NAN, 1.0, 0),
    }];
    slave.step(&obs(1, 2, (2.55, 1.0), &[]), &heard, &mut act);
    assert_eq!((act.v, act.omega), (0.0, 0.0), "no master known: it stays");
    // A sane one is followed.
    act.reset();
    let heard = [Heard {
        src: 0,
        sent_tick: 2,
        msg: link(3.2, 1.0, 0),
    }];
    slave.step(&obs(1, 3, (2.55, 1.0), &[]), &heard, &mut act);
    assert!(act.v > 0.0 && act.v.is_finite(), "{act:?}");
}
