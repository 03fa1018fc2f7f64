//! Criterion benchmarks of the world core: a whole tick (observe + step) and observe alone at
//! N = 9, 100, 1000; each stage of a tick at N = 100, 1000; lidar ray casts against the map;
//! radio routing and delivery.
//!
//! The scenario is `configs/goto_simple.toml` with the start grid (0.7 m spacing) in the
//! middle of a map sized for N, every robot's lidar on, spinning in place (v = 0,
//! omega = 0.5 rad/s: the state stays the same tick after tick, nobody collides) and sending
//! a pose beacon every fifth tick (as the go-to behaviour does). Measured after 10 warm-up
//! ticks, so inboxes are full. Run with `cargo bench -p swarmrt-world`.

use std::hint::black_box;
use std::path::PathBuf;

use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use swarmrt_agent::RadioMsg;
use swarmrt_agent::behaviours::goto::Beacon;
use swarmrt_protocol::{BROADCAST, Command, Frame, Observation, Vocabulary};
use swarmrt_scenario::Config;
use swarmrt_world::map::Map;
use swarmrt_world::radio::RadioMedium;
use swarmrt_world::{Stage, World};

const BEACON_PERIOD: u64 = 5;

fn scenario(n: u32) -> Config {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../configs/goto_simple.toml");
    let r_start = (n as f64 / std::f64::consts::PI).sqrt() * 0.7 + 1.0;
    let side = (2.0 * r_start + 6.0).max(12.0).ceil();
    let c = side / 2.0;
    let set = vec![
        format!("robots.count={n}"),
        "scenario.stop_when_done=false".to_string(),
        "scenario.ticks=100000000".to_string(),
        format!("map.bounds=[0.0, 0.0, {side:.1}, {side:.1}]"),
        format!("robots.start.x={c:.1}"),
        format!("robots.start.y={c:.1}"),
        format!("map.goal.x={:.1}", c + r_start / 2.0),
        format!("map.goal.y={:.1}", c + r_start / 2.0),
    ];
    Config::load(&path, &set).expect("bench scenario")
}

/// Every robot spinning in place, lidar on, a beacon every fifth tick.
fn commands(world: &World, out: &mut Vec<Option<Command>>) {
    out.clear();
    let tick = world.tick();
    for r in world.robots() {
        let mut c = Command::act(r.id, tick);
        c.omega = 0.5;
        c.lidar_on = 1;
        if (tick + r.id as u64).is_multiple_of(BEACON_PERIOD) {
            let beacon = RadioMsg::Goto(Beacon {
                x: r.x,
                y: r.y,
                theta: r.theta,
            });
            c.push_frame(BROADCAST, &beacon).expect("a beacon fits");
        }
        out.push(Some(c));
    }
}

/// A world at N robots after 10 warm-up ticks, with its observation buffer.
fn warm_world(n: u32) -> (World, Vec<Observation>, Vec<Option<Command>>) {
    let mut world = World::new(&scenario(n), Vocabulary::ANY).expect("bench world");
    let mut obs = vec![Observation::empty(0, 0); n as usize];
    let mut cmds = Vec::new();
    for _ in 0..10 {
        world.observe(&mut obs);
        commands(&world, &mut cmds);
        world.step(&cmds);
        world.drain_events();
    }
    (world, obs, cmds)
}

fn world_tick(c: &mut Criterion) {
    let mut g = c.benchmark_group("world");
    for n in [9u32, 100, 1000] {
        g.throughput(Throughput::Elements(n as u64));
        let (mut world, mut obs, mut cmds) = warm_world(n);
        g.bench_with_input(BenchmarkId::new("tick", n), &n, |b, _| {
            b.iter(|| {
                world.observe(&mut obs);
                commands(&world, &mut cmds);
                world.step(&cmds);
                black_box(world.drain_events());
            })
        });
        let (mut world, mut obs, _) = warm_world(n);
        g.bench_with_input(BenchmarkId::new("observe", n), &n, |b, _| {
            b.iter(|| {
                world.observe(&mut obs);
                black_box(&obs);
            })
        });
    }
    g.finish();
}

fn lidar(c: &mut Criterion) {
    let cfg = scenario(9);
    let map = Map::build(&cfg.map).expect("map");
    let lidar = cfg.robots.lidar.clone();
    let rays = lidar.rays as usize;
    let mut g = c.benchmark_group("lidar");
    g.throughput(Throughput::Elements(rays as u64));
    // From inside the obstacle field of goto_simple (walls and four obstacles within reach).
    let start = &cfg.robots.start;
    let origin = (start.x.unwrap_or(0.0) - 1.5, start.y.unwrap_or(0.0) - 1.0);
    g.bench_function("map_cast_16_rays", |b| {
        let mut heading = 0.0f64;
        b.iter(|| {
            heading += 0.1;
            let mut sum = 0.0;
            for k in 0..rays {
                let angle = heading + lidar.ray_angle(k);
                sum += map.cast(origin, angle, lidar.range).unwrap_or(lidar.range);
            }
            black_box(sum)
        })
    });
    g.finish();
}

fn radio(c: &mut Criterion) {
    let mut g = c.benchmark_group("radio");
    for n in [100usize, 1000] {
        let cfg = scenario(n as u32);
        let side = (n as f64).sqrt().ceil() as usize;
        let positions: Vec<(f64, f64)> = (0..n)
            .map(|i| ((i % side) as f64 * 0.7, (i / side) as f64 * 0.7))
            .collect();
        let can_talk = vec![true; n];
        let mut beacon = Frame::EMPTY;
        beacon.dst = BROADCAST;
        beacon.len = 24;
        let one = [beacon];
        let mut medium = RadioMedium::new(cfg.radio, 1, n);
        let mut tick = 0u64;
        let mut copies = 0u64;
        // A fifth of the robots broadcast each tick, as with the go-to beacon period.
        g.throughput(Throughput::Elements(n as u64));
        g.bench_with_input(BenchmarkId::new("send_and_deliver", n), &n, |b, _| {
            b.iter(|| {
                let outboxes: Vec<&[Frame]> = (0..n)
                    .map(|i| {
                        if (tick + i as u64).is_multiple_of(BEACON_PERIOD) {
                            &one[..]
                        } else {
                            &[][..]
                        }
                    })
                    .collect();
                medium.send(tick, &outboxes, &positions, &can_talk, &mut |_, _| false);
                tick += 1;
                medium.deliver_due(tick, &can_talk);
                copies = medium.stats().delivered;
                black_box(medium.inbox(0).len());
            })
        });
        black_box(copies);
    }
    g.finish();
}

/// Each stage of a whole tick on its own: the world's stage timers
/// ([`World::set_stage_timing`]) measure every stage of each tick criterion runs, and
/// `iter_custom` reports one stage's share. `sensing` is `World::observe` plus the goal check;
/// `radio` is routing plus delivery.
fn stages(c: &mut Criterion) {
    let mut g = c.benchmark_group("stage");
    for n in [100u32, 1000] {
        g.throughput(Throughput::Elements(n as u64));
        let (mut world, mut obs, mut cmds) = warm_world(n);
        world.set_stage_timing(true);
        for stage in Stage::ALL {
            g.bench_with_input(BenchmarkId::new(stage.name(), n), &n, |b, _| {
                b.iter_custom(|iters| {
                    world.take_stage_times();
                    for _ in 0..iters {
                        world.observe(&mut obs);
                        commands(&world, &mut cmds);
                        world.step(&cmds);
                        black_box(world.drain_events());
                    }
                    world.take_stage_times().get(stage)
                })
            });
        }
    }
    g.finish();
}

criterion_group!(benches, world_tick, stages, lidar, radio);
criterion_main!(benches);
