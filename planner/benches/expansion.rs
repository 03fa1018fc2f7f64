//! Planner speed: one route on the paper's 10 × 15 × 5 grid against two fixed routes, and
//! prioritised planning of 100 vehicles on 100 × 100 × 20.

use std::hint::black_box;

use criterion::{Criterion, criterion_group, criterion_main};
use swarmrt_planner::{PlanParams, Planner, Reservations, plan_all, scenes};

fn paper_route(c: &mut Criterion) {
    let grid = scenes::paper_grid();
    let jobs = scenes::paper_jobs();
    let params = PlanParams::default();
    let mut res = Reservations::new(&grid, &params).unwrap();
    let mut planner = Planner::new();
    for job in &jobs[1..] {
        let r = planner.plan(&grid, &res, job, &params).unwrap();
        res.add_route(job.vehicle, &r);
    }
    c.bench_function("paper_route_2_fixed", |b| {
        b.iter(|| {
            planner
                .plan(black_box(&grid), &res, black_box(&jobs[0]), &params)
                .unwrap()
        })
    });
}

fn swarm_100(c: &mut Criterion) {
    let grid = scenes::swarm_grid();
    let jobs = scenes::swarm_jobs();
    // ε = 1: at ε = 0 the potential makes one iteration take about a minute.
    let params = PlanParams {
        epsilon: 1.0,
        ..PlanParams::default()
    };
    let mut g = c.benchmark_group("swarm");
    g.sample_size(10);
    g.bench_function("plan_all_100_on_100x100x20_eps1", |b| {
        b.iter(|| {
            plan_all(
                &grid,
                black_box(&jobs),
                Reservations::new(&grid, &params).unwrap(),
                &params,
            )
        })
    });
    g.finish();
}

criterion_group!(benches, paper_route, swarm_100);
criterion_main!(benches);
