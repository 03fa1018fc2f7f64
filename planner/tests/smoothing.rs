//! The smoothed trajectory never enters a blocked cell (random obstacle maps, dense sampling).

mod common;

use proptest::prelude::*;
use swarmrt_planner::{Cell, Grid, Job, PlanParams, Reservations, Trajectory, plan};

proptest! {
    #![proptest_config(common::config(64))]

    #[test]
    fn smoothed_path_stays_in_free_cells(
        boxes in proptest::collection::vec((0.0f64..8.0, 0.0f64..8.0, 0.0f64..3.0, 0.2f64..2.5, 0.2f64..2.5, 0.5f64..3.0), 0..5),
        cylinders in proptest::collection::vec((0.0f64..8.0, 0.0f64..8.0, 0.1f64..1.2), 0..3),
        inflate in 0.0f64..0.4,
        start in (0u16..8, 0u16..8, 0u16..3),
        goal in (0u16..8, 0u16..8, 0u16..3),
        epsilon in 0.0f64..1.0,
    ) {
        let mut grid = Grid::new([0.0; 3], [8.0, 8.0, 3.0], 1.0).unwrap();
        for (x, y, z, w, l, h) in boxes {
            grid.block_box([x, y, z], [x + w, y + l, z + h], inflate);
        }
        for (x, y, r) in cylinders {
            grid.block_cylinder([x, y], r, 0.0, 2.0, inflate);
        }
        let start = Cell::new(start.0, start.1, start.2);
        let goal = Cell::new(goal.0, goal.1, goal.2);
        prop_assume!(!grid.blocked(start) && !grid.blocked(goal));
        let params = PlanParams { epsilon, horizon_slots: 96, ..PlanParams::default() };
        let res = Reservations::new(&grid, &params).unwrap();
        let job = Job { vehicle: 0, start, goal, start_slot: 2 };
        if let Ok(route) = plan(&grid, &res, &job, &params) {
            let traj = Trajectory::new(&grid, &route, params.slot, None, 5);
            prop_assert_eq!(traj.segments_linear(), 0);
            prop_assert_eq!(traj.check(&grid, 5), None);
            let (t0, t1) = (traj.start_time(), traj.end_time());
            let n = ((t1 - t0) * 400.0).ceil() as usize;
            for q in 0..=n {
                let t = t0 + (t1 - t0) * q as f64 / n.max(1) as f64;
                let p = traj.position(t);
                let c = grid.cell_of(p);
                prop_assert!(c.is_some_and(|c| !grid.blocked(c)), "t = {} at {:?} in {:?}", t, p, c);
            }
            // It follows the timing: at every knot it is at the cell centre.
            for (k, c) in route.cells.iter().enumerate() {
                let p = traj.position((f64::from(route.start_slot) + k as f64) * params.slot);
                let q = grid.centre(*c);
                prop_assert!((0..3).all(|a| (p[a] - q[a]).abs() < 1e-9));
            }
        }
    }
}
