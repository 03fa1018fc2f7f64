//! Planner speed and quality in one table: against the paper's 30 ms (Python, Cortex-A72),
//! against the `pathfinding` crate's A* on a static grid, across ε, and at swarm scale.
//!
//! Run: `cargo run --release -p swarmrt-planner --example compare`.

use std::hint::black_box;
use std::time::Instant;

use pathfinding::prelude::astar;
use swarmrt_planner::{
    Cell, Grid, Job, PlanParams, Planner, Reservations, Route, conflicts, min_separation, plan_all,
    scenes,
};

/// Median of `reps` timings of `f`, microseconds.
fn median_us(reps: usize, mut f: impl FnMut()) -> f64 {
    let mut t: Vec<f64> = (0..reps)
        .map(|_| {
            let s = Instant::now();
            f();
            s.elapsed().as_secs_f64() * 1e6
        })
        .collect();
    t.sort_by(f64::total_cmp);
    t[reps / 2]
}

/// 26-connected static search with `pathfinding`: integer costs in mm (1000, 1414, 1732) and
/// the exact free-space (octile) distance as heuristic; same no-corner-cutting rule as ours.
fn pf_astar(grid: &Grid, start: Cell, goal: Cell) -> Option<(Vec<Cell>, u32)> {
    let [nx, ny, nz] = grid.dims().map(i32::from);
    let succ = |c: &Cell| {
        let c = *c;
        let mut out = Vec::with_capacity(26);
        for di in -1..=1 {
            for dj in -1..=1 {
                for dk in -1..=1i32 {
                    if (di, dj, dk) == (0, 0, 0) {
                        continue;
                    }
                    let (i, j, k) = (
                        i32::from(c.i) + di,
                        i32::from(c.j) + dj,
                        i32::from(c.k) + dk,
                    );
                    if i < 0 || j < 0 || k < 0 || i >= nx || j >= ny || k >= nz {
                        continue;
                    }
                    let n = Cell::new(i as u16, j as u16, k as u16);
                    let swept_free = [c.i, n.i].iter().all(|&bi| {
                        [c.j, n.j].iter().all(|&bj| {
                            [c.k, n.k].iter().all(|&bk| {
                                Cell::new(bi, bj, bk) == c || !grid.blocked(Cell::new(bi, bj, bk))
                            })
                        })
                    });
                    if swept_free {
                        out.push((
                            n,
                            [0, 1000, 1414, 1732][(di * di + dj * dj + dk * dk) as usize],
                        ));
                    }
                }
            }
        }
        out
    };
    let h = |c: &Cell| {
        let mut g = [
            c.i.abs_diff(goal.i),
            c.j.abs_diff(goal.j),
            c.k.abs_diff(goal.k),
        ]
        .map(u32::from);
        g.sort_unstable();
        1732 * g[0] + 1414 * (g[1] - g[0]) + 1000 * (g[2] - g[1])
    };
    astar(&start, succ, h, |c| *c == goal)
}

fn main() {
    let params = PlanParams::default();
    let grid = scenes::paper_grid();
    let jobs = scenes::paper_jobs();
    let mut planner = Planner::new();

    println!("swarmrt-planner compare (release; medians of repeated runs)");
    println!();

    // 1. The paper's scene: vehicle 1 planned against vehicles 2 and 3's routes.
    let mut res = Reservations::new(&grid, &params).unwrap();
    for job in &jobs[1..] {
        let r = planner.plan(&grid, &res, job, &params).unwrap();
        res.add_route(job.vehicle, &r);
    }
    let route = planner.plan(&grid, &res, &jobs[0], &params).unwrap();
    let us = median_us(2001, || {
        black_box(
            planner
                .plan(&grid, &res, black_box(&jobs[0]), &params)
                .unwrap(),
        );
    });
    println!("1. paper scene 10x15x5, d=1, a=10 b=50 delta=1 s, 2 other routes fixed");
    println!(
        "   {:<40} {:>10} {:>10} {:>8} {:>8}",
        "", "time us", "x faster", "cost", "expand"
    );
    println!(
        "   {:<40} {:>10.0} {:>10} {:>8} {:>8}",
        "paper (Python, Cortex-A72, whole plan)", 30000.0, "1", "-", "-"
    );
    println!(
        "   {:<40} {:>10.1} {:>10.0} {:>8.2} {:>8}",
        "ours, one route",
        us,
        30000.0 / us,
        route.cost,
        route.expansions
    );
    for (name, p) in [
        (
            "ours, one route, eps = 1",
            PlanParams {
                epsilon: 1.0,
                ..params.clone()
            },
        ),
        (
            "ours, one route, a = b = 0 (no potential)",
            PlanParams {
                a: 0.0,
                b: 0.0,
                ..params.clone()
            },
        ),
    ] {
        let mut res = Reservations::new(&grid, &p).unwrap();
        for job in &jobs[1..] {
            let r = planner.plan(&grid, &res, job, &p).unwrap();
            res.add_route(job.vehicle, &r);
        }
        let r = planner.plan(&grid, &res, &jobs[0], &p).unwrap();
        let us = median_us(2001, || {
            black_box(planner.plan(&grid, &res, black_box(&jobs[0]), &p).unwrap());
        });
        println!(
            "   {:<40} {:>10.1} {:>10.0} {:>8.2} {:>8}",
            name,
            us,
            30000.0 / us,
            r.cost,
            r.expansions
        );
    }
    let all_us = median_us(501, || {
        black_box(plan_all(
            &grid,
            &jobs,
            Reservations::new(&grid, &params).unwrap(),
            &params,
        ));
    });
    println!(
        "   {:<40} {:>10.1} {:>10.0} {:>8} {:>8}",
        "ours, plan_all of the 3 UAVs",
        all_us,
        30000.0 / all_us,
        "-",
        "-"
    );
    println!();

    // 2. Static search vs the pathfinding crate (no time, no potential, no other vehicles).
    let stat = PlanParams {
        a: 0.0,
        b: 0.0,
        ..params.clone()
    };
    let empty = Reservations::new(&grid, &stat).unwrap();
    println!("2. static 26-connected search on the paper grid vs pathfinding::astar");
    println!(
        "   {:<12} {:>12} {:>10} {:>12} {:>10} {:>8}",
        "start->goal", "pf time us", "pf cost", "ours us", "ours cost", "ratio"
    );
    let mut ratios = Vec::new();
    for job in &jobs {
        let pf = pf_astar(&grid, job.start, job.goal).expect("pathfinding finds a route");
        let pf_us = median_us(2001, || {
            black_box(pf_astar(&grid, job.start, job.goal));
        });
        let ours = planner.plan(&grid, &empty, job, &stat).unwrap();
        let our_us = median_us(2001, || {
            black_box(planner.plan(&grid, &empty, job, &stat).unwrap());
        });
        ratios.push(pf_us / our_us);
        println!(
            "   vehicle {:<4} {:>12.1} {:>10.3} {:>12.1} {:>10.3} {:>7.2}x",
            job.vehicle,
            pf_us,
            f64::from(pf.1) / 1000.0,
            our_us,
            ours.cost,
            pf_us / our_us
        );
    }
    println!(
        "   (ratio = pathfinding time / ours; costs in m, pathfinding's rounded down to mm per move)"
    );
    println!();

    // 3. Bounded relaxation on a harder map (three walls; all three vehicles, one after another).
    let hard = scenes::hard_grid();
    println!("3. epsilon sweep on the harder map (3 walls), vehicle 1 against the other two");
    println!(
        "   {:<8} {:>10} {:>10} {:>10} {:>12} {:>12}",
        "epsilon", "time us", "cost", "expand", "cost/opt", "time/opt"
    );
    let mut base: Option<(f64, f64)> = None;
    // The other two routes are planned once at ε = 0, so every row faces the same traffic.
    let mut res = Reservations::new(&hard, &params).unwrap();
    for job in &jobs[1..] {
        if let Ok(r) = planner.plan(&hard, &res, job, &params) {
            res.add_route(job.vehicle, &r);
        }
    }
    for eps in [0.0, 0.1, 0.5, 1.0] {
        let p = PlanParams {
            epsilon: eps,
            ..params.clone()
        };
        let r = planner.plan(&hard, &res, &jobs[0], &p).unwrap();
        let us = median_us(101, || {
            black_box(planner.plan(&hard, &res, &jobs[0], &p).unwrap());
        });
        let (c0, t0) = *base.get_or_insert((r.cost, us));
        println!(
            "   {:<8} {:>10.1} {:>10.3} {:>10} {:>12.3} {:>12.3}",
            eps,
            us,
            r.cost,
            r.expansions,
            r.cost / c0,
            us / t0
        );
    }
    println!();

    // 4. Swarm scale.
    let sg = scenes::swarm_grid();
    let sj: Vec<Job> = scenes::swarm_jobs();
    println!(
        "4. 100 vehicles on 100x100x20 (d=1, {} blocked cells), prioritised, every path crossing",
        sg.blocked_count()
    );
    println!(
        "   {:<22} {:>10} {:>10} {:>8} {:>10} {:>11} {:>9} {:>10}",
        "params", "total ms", "ms/veh", "found", "conflicts", "expansions", "min sep", "30ms/veh"
    );
    for (name, p) in [
        (
            "a=b=0, eps=0",
            PlanParams {
                a: 0.0,
                b: 0.0,
                ..params.clone()
            },
        ),
        (
            "a=10 b=50, eps=1",
            PlanParams {
                epsilon: 1.0,
                ..params.clone()
            },
        ),
        (
            "a=10 b=50, eps=1, cl=1",
            PlanParams {
                epsilon: 1.0,
                clearance: 1.0,
                ..params.clone()
            },
        ),
    ] {
        let s = Instant::now();
        let results = plan_all(&sg, &sj, Reservations::new(&sg, &p).unwrap(), &p);
        let total = s.elapsed().as_secs_f64() * 1e3;
        let routes: Vec<(u32, Route)> = results
            .iter()
            .zip(&sj)
            .filter_map(|(r, j)| r.as_ref().ok().map(|r| (j.vehicle, r.clone())))
            .collect();
        let expansions: u64 = routes.iter().map(|(_, r)| r.expansions).sum();
        let per = total / sj.len() as f64;
        println!(
            "   {:<22} {:>10.1} {:>10.2} {:>8} {:>10} {:>11} {:>8.2}m {:>9.1}x",
            name,
            total,
            per,
            format!("{}/{}", routes.len(), sj.len()),
            conflicts(&sg, &routes, &p),
            expansions,
            min_separation(&sg, &routes, &p, 4, false),
            30.0 / per
        );
    }
    println!(
        "   (a=10 b=50 at eps=0 takes ~0.5 s per vehicle here: see the report; 30ms/veh = paper's budget / ours)"
    );
}
