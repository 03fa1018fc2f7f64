//! A* against an exhaustive Dijkstra over the same (cell, slot) graph: equal cost at ε = 0,
//! within (1+ε) of it with bounded relaxation, with and without the potential of eq. (2).

mod common;

use proptest::prelude::*;
use swarmrt_planner::{Cell, Grid, Job, PlanError, PlanParams, Reservations, plan};

fn cell_in(grid: &Grid, raw: (u16, u16, u16)) -> Cell {
    let [nx, ny, nz] = grid.dims();
    Cell::new(raw.0 % nx, raw.1 % ny, raw.2 % nz)
}

fn small_params(a: f64, b: f64, epsilon: f64) -> PlanParams {
    PlanParams {
        a,
        b,
        epsilon,
        horizon_slots: 24,
        ..PlanParams::default()
    }
}

proptest! {
    #![proptest_config(common::config(96))]

    #[test]
    fn astar_equals_dijkstra_without_potential(
        dims in (2u16..=6, 2u16..=6, 1u16..=3),
        blocked in proptest::collection::vec(proptest::bool::weighted(0.3), 108),
        start in (0u16..6, 0u16..6, 0u16..3),
        goal in (0u16..6, 0u16..6, 0u16..3),
    ) {
        let grid = common::grid_with([dims.0, dims.1, dims.2], &blocked);
        let params = small_params(0.0, 0.0, 0.0);
        let res = Reservations::new(&grid, &params).unwrap();
        let job = Job { vehicle: 0, start: cell_in(&grid, start), goal: cell_in(&grid, goal), start_slot: 3 };
        let ours = plan(&grid, &res, &job, &params);
        let best = common::dijkstra(&grid, &res, &job, &params);
        match (ours, best) {
            (Ok(route), Some(opt)) => {
                prop_assert!((route.cost - opt).abs() < 1e-9, "A* {} vs Dijkstra {}", route.cost, opt);
                prop_assert_eq!(route.cells[0], job.start);
                prop_assert_eq!(*route.cells.last().unwrap(), job.goal);
            }
            (Err(PlanError::NoRoute { .. }), None) => {}
            (Err(PlanError::GoalBlocked { .. }), None) => prop_assert!(grid.blocked(job.goal)),
            (ours, best) => prop_assert!(false, "disagree: A* {:?}, Dijkstra {:?}", ours, best),
        }
    }

    #[test]
    fn bounded_relaxation_within_one_plus_epsilon(
        dims in (3u16..=6, 3u16..=6, 1u16..=3),
        blocked in proptest::collection::vec(proptest::bool::weighted(0.2), 108),
        ends in proptest::collection::vec((0u16..6, 0u16..6, 0u16..3), 6),
        eps_pick in 0usize..3,
        with_potential in any::<bool>(),
    ) {
        let epsilon = [0.1, 0.5, 1.0][eps_pick];
        let grid = common::grid_with([dims.0, dims.1, dims.2], &blocked);
        let (a, b) = if with_potential { (10.0, 50.0) } else { (0.0, 0.0) };
        let base = small_params(a, b, 0.0);
        // Two other vehicles planned first (their routes give occupancy and potential).
        let mut res = Reservations::new(&grid, &base).unwrap();
        for v in 1..3u32 {
            let job = Job {
                vehicle: v,
                start: cell_in(&grid, ends[2 * v as usize]),
                goal: cell_in(&grid, ends[2 * v as usize + 1]),
                start_slot: 0,
            };
            if let Ok(r) = plan(&grid, &res, &job, &base) {
                res.add_route(v, &r);
            }
        }
        let job = Job { vehicle: 0, start: cell_in(&grid, ends[0]), goal: cell_in(&grid, ends[1]), start_slot: 0 };
        let exact = plan(&grid, &res, &job, &base);
        let relaxed = plan(&grid, &res, &job, &small_params(a, b, epsilon));
        let best = common::dijkstra(&grid, &res, &job, &base);
        match (exact, relaxed, best) {
            (Ok(e), Ok(r), Some(opt)) => {
                prop_assert!((e.cost - opt).abs() < 1e-9, "ε = 0: A* {} vs Dijkstra {}", e.cost, opt);
                prop_assert!(r.cost >= opt - 1e-9);
                prop_assert!(r.cost <= (1.0 + epsilon) * opt + 1e-9, "ε = {}: {} > (1+ε)·{}", epsilon, r.cost, opt);
            }
            (Err(_), Err(_), None) => {}
            (e, r, best) => prop_assert!(false, "disagree: {:?} / {:?} / {:?}", e, r, best),
        }
    }
}
