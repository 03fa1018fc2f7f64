//! Eq. (1) keeps prioritised routes apart in time: checked directly from the routes' cells
//! and slots, independently of `conflicts()`; and the paper's three-UAV scene.

mod common;

use proptest::prelude::*;
use swarmrt_planner::{
    Cell, Grid, Job, PlanParams, Reservations, Route, Trajectory, conflicts, min_separation,
    plan_all, scenes,
};

/// Pairs of routes with one vehicle in a cell within `pad` slots of the other being there,
/// slot by slot (a route's last cell is held for ever after its end).
fn shared_cells(routes: &[(u32, Route)], pad: i64) -> Vec<(u32, u32, i64)> {
    let last = routes
        .iter()
        .map(|(_, r)| i64::from(r.end_slot()))
        .max()
        .unwrap_or(0)
        + pad
        + 2;
    let first = routes
        .iter()
        .map(|(_, r)| i64::from(r.start_slot))
        .min()
        .unwrap_or(0);
    let held = |r: &Route, s: i64| (s >= i64::from(r.start_slot)).then(|| r.cell_at(s));
    let mut out = Vec::new();
    for (x, (va, ra)) in routes.iter().enumerate() {
        for (vb, rb) in &routes[x + 1..] {
            for s in first..=last {
                for s2 in s - pad..=s + pad {
                    if let (Some(a), Some(b)) = (held(ra, s), held(rb, s2))
                        && a == b
                    {
                        out.push((*va, *vb, s));
                    }
                }
            }
        }
    }
    out
}

proptest! {
    #![proptest_config(common::config(48))]

    #[test]
    fn crossing_routes_never_share_a_cell_within_delta(
        n in 2usize..=4,
        rows in proptest::collection::vec((0u16..6, 0u16..6), 4),
        levels in proptest::collection::vec(0u16..2, 8),
        potential in any::<bool>(),
        delta in 0usize..3,
    ) {
        let grid = Grid::new([0.0; 3], [6.0, 6.0, 2.0], 1.0).unwrap();
        let params = PlanParams {
            a: if potential { 10.0 } else { 0.0 },
            b: if potential { 50.0 } else { 0.0 },
            delta: [0.0, 1.0, 2.0][delta],
            horizon_slots: 64,
            ..PlanParams::default()
        };
        // Starts on the west side, goals on the east side, in crossing rows; distinct cells.
        let mut jobs: Vec<Job> = Vec::new();
        for v in 0..n {
            let start = Cell::new(0, rows[v].0, levels[2 * v]);
            let goal = Cell::new(5, rows[v].1, levels[2 * v + 1]);
            if jobs.iter().any(|j| j.start == start || j.goal == goal) {
                continue;
            }
            jobs.push(Job { vehicle: v as u32 + 10, start, goal, start_slot: 0 });
        }
        let fixed = Reservations::new(&grid, &params).unwrap();
        let results = plan_all(&grid, &jobs, fixed, &params);
        let routes: Vec<(u32, Route)> = results
            .into_iter()
            .zip(&jobs)
            .filter_map(|(r, j)| r.ok().map(|r| (j.vehicle, r)))
            .collect();
        // Open space with distinct starts and goals: everyone gets through.
        prop_assert_eq!(routes.len(), jobs.len());
        let pad = i64::from(params.pad_slots());
        prop_assert_eq!(pad, [0, 1, 2][delta]);
        let shared = shared_cells(&routes, pad);
        prop_assert!(shared.is_empty(), "shared cells within δ: {:?}", shared);
        prop_assert_eq!(conflicts(&grid, &routes, &params), 0);
        // Distinct cells at every slot instant: at least d apart at slot times.
        prop_assert!(min_separation(&grid, &routes, &params, 1, false) >= 1.0 - 1e-9);
    }
}

/// `conflicts()` does see a clash when one is there (two routes through the same cell).
#[test]
fn conflicts_counts_a_forced_clash() {
    let grid = Grid::new([0.0; 3], [5.0, 5.0, 1.0], 1.0).unwrap();
    let params = PlanParams::default();
    let a = Route::from_moves(Cell::new(0, 2, 0), 0, &[22, 22, 22, 22]).unwrap();
    let b = Route::from_moves(Cell::new(2, 0, 0), 0, &[16, 16, 16, 16]).unwrap();
    assert_eq!(a.cells[2], b.cells[2]);
    assert_eq!(conflicts(&grid, &[(1, a.clone()), (2, b)], &params), 1);
    // Same cell three slots apart: a conflict with δ = 3 s, none with δ = 1 s.
    let c = Route::from_moves(Cell::new(2, 0, 0), 0, &[13, 13, 13, 16, 16, 16, 16]).unwrap();
    assert_eq!(
        conflicts(&grid, &[(1, a.clone()), (2, c.clone())], &params),
        0
    );
    assert_eq!(
        conflicts(
            &grid,
            &[(1, a), (2, c)],
            &PlanParams {
                delta: 3.0,
                ..params
            }
        ),
        1
    );
}

/// The paper's experiment (section 2.2): 3 UAVs in 10 × 15 × 5 m, d = 1 m, a = 10, b = 50,
/// δ = 1 s, obstacles in between, starts on the south side and goals on the north side with
/// crossing paths. All three plan, no conflicts, smoothed paths stay in free cells.
#[test]
fn paper_scene_three_uavs_cross_without_conflict() {
    let grid = scenes::paper_grid();
    let params = PlanParams::default();
    let jobs = scenes::paper_jobs();
    assert!(grid.blocked_count() > 0);
    let fixed = Reservations::new(&grid, &params).unwrap();
    let routes: Vec<(u32, Route)> = plan_all(&grid, &jobs, fixed, &params)
        .into_iter()
        .zip(&jobs)
        .map(|(r, j)| (j.vehicle, r.expect("paper scene route")))
        .collect();
    assert_eq!(conflicts(&grid, &routes, &params), 0);
    assert!(shared_cells(&routes, i64::from(params.pad_slots())).is_empty());
    for ((_, route), job) in routes.iter().zip(&jobs) {
        assert_eq!(route.cells[0], job.start);
        assert_eq!(*route.cells.last().unwrap(), job.goal);
        assert!(route.cells.iter().all(|c| !grid.blocked(*c)));
        let traj = Trajectory::new(&grid, route, params.slot, None, 5);
        assert_eq!(traj.check(&grid, 5), None);
        assert_eq!(traj.segments_linear(), 0);
    }
    assert!(min_separation(&grid, &routes, &params, 20, false) > 0.9);
    assert!(min_separation(&grid, &routes, &params, 20, true) > 0.9);
}
