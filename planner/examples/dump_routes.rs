//! Prints the routes (cells) the planner returns for the scenes of `compare`, for diffing
//! before/after a change to the search. Run:
//! `cargo run --release -p swarmrt-planner --example dump_routes`.

use swarmrt_planner::{Job, PlanParams, Planner, Reservations, Route, plan_all, scenes};

fn show(tag: &str, r: &Result<Route, swarmrt_planner::PlanError>) {
    match r {
        Ok(r) => {
            let cells: Vec<String> = r
                .cells
                .iter()
                .map(|c| format!("{},{},{}", c.i, c.j, c.k))
                .collect();
            println!("{tag} cost={:.9} {}", r.cost, cells.join(" "));
        }
        Err(e) => println!("{tag} err={e:?}"),
    }
}

fn main() {
    let base = PlanParams::default();
    let jobs = scenes::paper_jobs();
    let mut planner = Planner::new();
    let variants = [
        ("eps0", base.clone()),
        (
            "eps0.1",
            PlanParams {
                epsilon: 0.1,
                ..base.clone()
            },
        ),
        (
            "eps0.5",
            PlanParams {
                epsilon: 0.5,
                ..base.clone()
            },
        ),
        (
            "eps1",
            PlanParams {
                epsilon: 1.0,
                ..base.clone()
            },
        ),
        (
            "nopot",
            PlanParams {
                a: 0.0,
                b: 0.0,
                ..base.clone()
            },
        ),
        (
            "cl1",
            PlanParams {
                clearance: 1.0,
                ..base.clone()
            },
        ),
        (
            "eps1cl1",
            PlanParams {
                epsilon: 1.0,
                clearance: 1.0,
                ..base.clone()
            },
        ),
    ];
    for (gname, grid) in [
        ("paper", scenes::paper_grid()),
        ("hard", scenes::hard_grid()),
    ] {
        for (pname, p) in &variants {
            // As in compare: vehicles 2 and 3 one after the other, then vehicle 1.
            let mut res = Reservations::new(&grid, p).unwrap();
            for job in &jobs[1..] {
                let r = planner.plan(&grid, &res, job, p);
                show(&format!("{gname} {pname} seq v{}", job.vehicle), &r);
                if let Ok(r) = r {
                    res.add_route(job.vehicle, &r);
                }
            }
            show(
                &format!("{gname} {pname} seq v1"),
                &planner.plan(&grid, &res, &jobs[0], p),
            );
            let all = plan_all(&grid, &jobs, Reservations::new(&grid, p).unwrap(), p);
            for (r, j) in all.iter().zip(&jobs) {
                show(&format!("{gname} {pname} plan_all v{}", j.vehicle), r);
            }
        }
    }
    let sg = scenes::swarm_grid();
    let sj: Vec<Job> = scenes::swarm_jobs();
    // The swarm rows of `compare` (a = b = 0; eps = 1; eps = 1 with clearance 1).
    for (pname, p) in [&variants[4], &variants[3], &variants[6]] {
        if std::env::args().any(|a| a == "--quick") {
            break;
        }
        let all = plan_all(&sg, &sj, Reservations::new(&sg, p).unwrap(), p);
        for (r, j) in all.iter().zip(&sj) {
            show(&format!("swarm {pname} plan_all v{}", j.vehicle), r);
        }
    }
}
