//! Ready-made scenes for examples, benchmarks and demos; deterministic, no randomness.
//!
//! [`paper_grid`] is the experiment of Marchenko & Ponomarenko 2024, 2.2: a 10 × 15 × 5 m
//! space, d = 1 m, with a few obstacles (the paper does not give their layout; these are
//! ours), three UAVs crossing from the south side to the north side ([`paper_jobs`]).
//! [`swarm_grid`] / [`swarm_jobs`] scale it to 100 vehicles on 100 × 100 × 20 cells.

use crate::astar::Job;
use crate::grid::{Cell, Grid};

/// Vehicle radius used to inflate the scenes' obstacles, metres.
pub const VEHICLE_RADIUS: f64 = 0.3;

/// The paper's 10 × 15 × 5 m space at d = 1 m with two walls and two columns.
pub fn paper_grid() -> Grid {
    let mut g = Grid::new([0.0; 3], [10.0, 15.0, 5.0], 1.0).expect("valid paper grid");
    let r = VEHICLE_RADIUS;
    g.block_box([0.0, 5.0, 0.0], [4.0, 6.0, 4.0], r);
    g.block_box([6.0, 9.0, 0.0], [10.0, 10.0, 5.0], r);
    g.block_cylinder([7.0, 5.5], 0.7, 0.0, 5.0, r);
    g.block_cylinder([3.0, 11.0], 0.5, 0.0, 3.0, r);
    g
}

/// Three UAVs from the south side to the north side, the outer two crossing.
pub fn paper_jobs() -> [Job; 3] {
    [
        Job {
            vehicle: 1,
            start: Cell::new(1, 1, 2),
            goal: Cell::new(8, 13, 2),
            start_slot: 0,
        },
        Job {
            vehicle: 2,
            start: Cell::new(5, 1, 2),
            goal: Cell::new(5, 13, 2),
            start_slot: 0,
        },
        Job {
            vehicle: 3,
            start: Cell::new(8, 1, 2),
            goal: Cell::new(1, 13, 2),
            start_slot: 0,
        },
    ]
}

/// The paper's grid made harder: a third wall with a single low gap, so the cheapest route
/// has to dive under it.
pub fn hard_grid() -> Grid {
    let mut g = paper_grid();
    let r = VEHICLE_RADIUS;
    g.block_box([0.0, 12.0, 1.5], [10.0, 12.5, 5.0], r);
    g.block_box([4.0, 12.0, 0.0], [10.0, 12.5, 1.5], r);
    g
}

/// 100 × 100 × 20 cells of 1 m with a 6 × 6 forest of columns and two floating slabs.
pub fn swarm_grid() -> Grid {
    let mut g = Grid::new([0.0; 3], [100.0, 100.0, 20.0], 1.0).expect("valid swarm grid");
    let r = VEHICLE_RADIUS;
    for a in 0..6 {
        for b in 0..6 {
            let x = 20.0 + 12.0 * f64::from(a) + if b % 2 == 0 { 0.0 } else { 6.0 };
            g.block_cylinder([x, 15.0 + 14.0 * f64::from(b)], 2.0, 0.0, 16.0, r);
        }
    }
    g.block_box([40.0, 30.0, 8.0], [60.0, 70.0, 10.0], r);
    g.block_box([25.0, 45.0, 12.0], [75.0, 55.0, 14.0], r);
    g
}

/// 100 vehicles: starts on the west face in a 25 × 4 lattice (4 m apart across, 5 m apart
/// up, about r* = 3.9 m), goals on the east face in reversed order, so every path crosses
/// the others.
pub fn swarm_jobs() -> Vec<Job> {
    (0..100u16)
        .map(|v| {
            let (col, row) = (v % 25, v / 25);
            Job {
                vehicle: u32::from(v),
                start: Cell::new(1, 2 + 4 * col, 2 + 5 * row),
                goal: Cell::new(98, 2 + 4 * (24 - col), 2 + 5 * (3 - row)),
                start_slot: 0,
            }
        })
        .collect()
}
