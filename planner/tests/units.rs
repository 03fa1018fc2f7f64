//! Unit-level checks: radio move codes, grid blocking, eq. (2)'s minimum, params validation,
//! goal handling.

use swarmrt_planner::route::{WAIT, code_of, offset};
use swarmrt_planner::{
    Cell, Grid, Job, PlanError, PlanParams, Potential, Reservations, Route, plan,
};

#[test]
fn moves_round_trip() {
    let grid = Grid::new([0.0; 3], [10.0, 15.0, 5.0], 1.0).unwrap();
    let params = PlanParams::default();
    let res = Reservations::new(&grid, &params).unwrap();
    let job = Job {
        vehicle: 0,
        start: Cell::new(0, 0, 0),
        goal: Cell::new(9, 14, 4),
        start_slot: 7,
    };
    let route = plan(&grid, &res, &job, &params).unwrap();
    let bytes = route.moves();
    assert_eq!(bytes.len(), route.cells.len() - 1);
    assert!(bytes.iter().all(|b| *b <= 26));
    let back = Route::from_moves(job.start, 7, &bytes).unwrap();
    assert_eq!(back.cells, route.cells);
    assert_eq!(back.start_slot, 7);
    for code in 0..27u8 {
        let [di, dj, dk] = offset(code);
        assert_eq!(code_of(di, dj, dk), code);
    }
    assert_eq!(offset(WAIT), [0, 0, 0]);
    assert_eq!(
        Route::from_moves(job.start, 0, &[27]),
        Err(PlanError::BadMove { index: 0, code: 27 })
    );
    // Stepping below index 0.
    assert_eq!(
        Route::from_moves(job.start, 0, &[13, 0]),
        Err(PlanError::BadMove { index: 1, code: 0 })
    );
}

#[test]
fn box_blocks_cells_within_inflate_only() {
    // Cell (0,0,0) spans x in [0,1]; a box starting at x = 1.1 is 0.1 m away, one at 1.3 is 0.3.
    let mut g = Grid::new([0.0; 3], [5.0, 1.0, 1.0], 1.0).unwrap();
    g.block_box([1.1, 0.0, 0.0], [1.2, 1.0, 1.0], 0.2);
    assert!(g.blocked(Cell::new(0, 0, 0)));
    let mut g = Grid::new([0.0; 3], [5.0, 1.0, 1.0], 1.0).unwrap();
    g.block_box([1.3, 0.0, 0.0], [1.4, 1.0, 1.0], 0.2);
    assert!(!g.blocked(Cell::new(0, 0, 0)));
    assert!(g.blocked(Cell::new(1, 0, 0)));
    assert!(!g.blocked(Cell::new(2, 0, 0)), "1.4 to 2.0 is 0.6 m");
    // A box exactly on cell faces with no inflation blocks only the cells it fills.
    let mut g = Grid::new([0.0; 3], [5.0, 1.0, 1.0], 1.0).unwrap();
    g.block_box([2.0, 0.0, 0.0], [3.0, 1.0, 1.0], 0.0);
    assert_eq!(g.blocked_count(), 1);
}

#[test]
fn cylinder_and_prism_block_by_distance() {
    let mut g = Grid::new([0.0; 3], [6.0, 6.0, 2.0], 1.0).unwrap();
    // Radius 0.5 about (3, 3): the four cells around the corner (3,3) are inside.
    g.block_cylinder([3.0, 3.0], 0.5, 0.0, 1.0, 0.0);
    for (i, j) in [(2, 2), (2, 3), (3, 2), (3, 3)] {
        assert!(g.blocked(Cell::new(i, j, 0)));
        assert!(
            !g.blocked(Cell::new(i, j, 1)),
            "z from 1 to 2 only touches the top face"
        );
    }
    assert!(!g.blocked(Cell::new(1, 3, 0)), "0.5 m from the rim");
    g.block_cylinder([3.0, 3.0], 0.5, 0.0, 1.0, 0.6);
    assert!(g.blocked(Cell::new(1, 3, 0)));
    assert!(!g.blocked(Cell::new(0, 3, 0)));
    // An L-shaped (non-convex) prism: its notch stays free.
    let mut g = Grid::new([0.0; 3], [6.0, 6.0, 1.0], 1.0).unwrap();
    g.block_prism(
        &[
            [0.0, 0.0],
            [4.0, 0.0],
            [4.0, 1.0],
            [1.0, 1.0],
            [1.0, 4.0],
            [0.0, 4.0],
        ],
        0.0,
        1.0,
        0.0,
    );
    assert!(
        g.blocked(Cell::new(0, 0, 0))
            && g.blocked(Cell::new(3, 0, 0))
            && g.blocked(Cell::new(0, 3, 0))
    );
    assert!(!g.blocked(Cell::new(2, 2, 0)));
    assert!(!g.blocked(Cell::new(5, 5, 0)));
}

#[test]
fn grid_lookups() {
    let g = Grid::new([-5.0, 0.0, 0.0], [5.0, 15.0, 5.0], 1.0).unwrap();
    assert_eq!(g.dims(), [10, 15, 5]);
    assert_eq!(g.cell_of([-5.0, 0.0, 0.0]), Some(Cell::new(0, 0, 0)));
    assert_eq!(g.cell_of([5.0, 15.0, 5.0]), Some(Cell::new(9, 14, 4)));
    assert_eq!(g.cell_of([5.1, 1.0, 1.0]), None);
    assert_eq!(g.nearest_cell([100.0, -3.0, 2.5]), Cell::new(9, 0, 2));
    assert_eq!(g.centre(Cell::new(0, 0, 0)), [-4.5, 0.5, 0.5]);
    assert_eq!(g.neighbours26(Cell::new(0, 0, 0)).count(), 7);
    assert_eq!(g.neighbours26(Cell::new(4, 4, 2)).count(), 26);
    for idx in [0, 17, 749] {
        assert_eq!(g.index(g.cell_at(idx)), idx);
    }
    assert!(matches!(
        Grid::new([0.0; 3], [1.0; 3], 0.0),
        Err(PlanError::InvalidGrid { .. })
    ));
    assert!(matches!(
        Grid::new([0.0; 3], [0.0, 1.0, 1.0], 1.0),
        Err(PlanError::InvalidGrid { .. })
    ));
    assert!(matches!(
        Grid::new([0.0; 3], [1000.0; 3], 0.1),
        Err(PlanError::TooManyCells { .. })
    ));
}

#[test]
fn potential_minimum_at_sqrt_3b_over_a() {
    let p = Potential::new(10.0, 50.0, None);
    let r_star = (3.0f64 * 50.0 / 10.0).sqrt();
    assert!((p.r_star() - r_star).abs() < 1e-12);
    assert!(p.value(r_star).abs() < 1e-12);
    for q in 1..2000 {
        let r = q as f64 * 0.01;
        assert!(p.value(r) >= 0.0);
        assert!(p.value(r) >= p.value(r_star));
    }
    assert!(p.value(r_star * 0.99) > 0.0 && p.value(r_star * 1.01) > 0.0);
    assert!(p.value(0.0).is_finite());
    assert!((p.range() - 2.0 * r_star).abs() < 1e-12);
    // Sum with the cut-off: a vehicle beyond the range adds nothing.
    assert_eq!(p.sum([0.0; 3], &[[100.0, 0.0, 0.0]]), 0.0);
    assert!(p.sum([0.0; 3], &[[1.0, 0.0, 0.0], [1.0, 0.0, 0.0]]) == 2.0 * p.value(1.0));
    let off = Potential::new(0.0, 0.0, None);
    assert_eq!(off.value(0.5), 0.0);
    assert_eq!(off.sum([0.0; 3], &[[0.5, 0.0, 0.0]]), 0.0);
}

#[test]
fn params_validation_names_the_field() {
    assert_eq!(PlanParams::default().validate(), Ok(()));
    let cases: Vec<(PlanParams, &str)> = vec![
        (
            PlanParams {
                slot: 0.0,
                ..PlanParams::default()
            },
            "slot",
        ),
        (
            PlanParams {
                delta: -1.0,
                ..PlanParams::default()
            },
            "delta",
        ),
        (
            PlanParams {
                epsilon: f64::NAN,
                ..PlanParams::default()
            },
            "epsilon",
        ),
        (
            PlanParams {
                wait_cost: 0.0,
                ..PlanParams::default()
            },
            "wait_cost",
        ),
        (
            PlanParams {
                clearance: -0.1,
                ..PlanParams::default()
            },
            "clearance",
        ),
        (
            PlanParams {
                b: 0.0,
                ..PlanParams::default()
            },
            "b",
        ),
        (
            PlanParams {
                a: -1.0,
                ..PlanParams::default()
            },
            "a",
        ),
        (
            PlanParams {
                potential_range: Some(0.0),
                ..PlanParams::default()
            },
            "potential_range",
        ),
        (
            PlanParams {
                max_expansions: 0,
                ..PlanParams::default()
            },
            "max_expansions",
        ),
        (
            PlanParams {
                horizon_slots: 0,
                ..PlanParams::default()
            },
            "horizon_slots",
        ),
    ];
    for (p, name) in cases {
        match p.validate() {
            Err(e @ PlanError::InvalidParam { field, .. }) => {
                assert_eq!(field, name);
                assert!(e.to_string().contains(name));
            }
            other => panic!("{name}: {other:?}"),
        }
    }
}

#[test]
fn goal_blocked_taken_and_budget() {
    let mut grid = Grid::new([0.0; 3], [5.0, 5.0, 1.0], 1.0).unwrap();
    grid.set_blocked(Cell::new(4, 4, 0), true);
    let params = PlanParams::default();
    let mut res = Reservations::new(&grid, &params).unwrap();
    let job = Job {
        vehicle: 0,
        start: Cell::new(0, 0, 0),
        goal: Cell::new(4, 4, 0),
        start_slot: 0,
    };
    assert_eq!(
        plan(&grid, &res, &job, &params),
        Err(PlanError::GoalBlocked {
            goal: Cell::new(4, 4, 0)
        })
    );
    res.add_dead(9, Cell::new(3, 3, 0));
    let job = Job {
        goal: Cell::new(3, 3, 0),
        ..job
    };
    assert_eq!(
        plan(&grid, &res, &job, &params),
        Err(PlanError::GoalTaken {
            goal: Cell::new(3, 3, 0),
            vehicle: 9
        })
    );
    let job = Job {
        goal: Cell::new(4, 0, 0),
        ..job
    };
    let tight = PlanParams {
        max_expansions: 2,
        ..params.clone()
    };
    assert!(matches!(
        plan(&grid, &res, &job, &tight),
        Err(PlanError::NoRoute { expansions: 2 })
    ));
    // Start == goal: a one-cell route of cost 0.
    let job = Job {
        goal: job.start,
        ..job
    };
    let r = plan(&grid, &res, &job, &params).unwrap();
    assert_eq!((r.cells.len(), r.cost), (1, 0.0));
}

#[test]
fn waits_behind_a_vehicle_and_parks_after_it() {
    // A corridor one cell wide. Vehicle 1 flies (4,0) -> (1,0) over slots 0..=3 and parks.
    let grid = Grid::new([0.0; 3], [5.0, 1.0, 1.0], 1.0).unwrap();
    let params = PlanParams {
        a: 0.0,
        b: 0.0,
        ..PlanParams::default()
    };
    let mut res = Reservations::new(&grid, &params).unwrap();
    let other = Route::from_moves(Cell::new(4, 0, 0), 0, &[4, 4, 4]).unwrap();
    assert_eq!(other.cells[3], Cell::new(1, 0, 0));
    res.add_route(1, &other);
    // Vehicle 1 parks at (1,0) for ever: from (0,0) vehicle 0 cannot pass it.
    let job = Job {
        vehicle: 0,
        start: Cell::new(0, 0, 0),
        goal: Cell::new(2, 0, 0),
        start_slot: 0,
    };
    assert!(matches!(
        plan(&grid, &res, &job, &params),
        Err(PlanError::NoRoute { .. })
    ));
    // Following it from (4,0) at slot 2: (3,0) is held at slot 1, so with δ = 1 slot it is
    // occupied until slot 2 (the departure slot): vehicle 0 must wait once, then go.
    let job = Job {
        vehicle: 0,
        start: Cell::new(4, 0, 0),
        goal: Cell::new(2, 0, 0),
        start_slot: 2,
    };
    let r = plan(&grid, &res, &job, &params).unwrap();
    assert_eq!(
        r.cells,
        vec![
            Cell::new(4, 0, 0),
            Cell::new(4, 0, 0),
            Cell::new(3, 0, 0),
            Cell::new(2, 0, 0)
        ]
    );
    assert_eq!(r.moves()[0], WAIT);
    assert!((r.cost - 3.0).abs() < 1e-12);
    // With δ = 0 no wait is needed.
    let p0 = PlanParams {
        delta: 0.0,
        ..params
    };
    let mut res0 = Reservations::new(&grid, &p0).unwrap();
    res0.add_route(1, &other);
    let r0 = plan(&grid, &res0, &job, &p0).unwrap();
    assert_eq!(r0.cells.len(), 3);
}
