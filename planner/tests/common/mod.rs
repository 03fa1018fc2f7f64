//! Test helpers: a plain Dijkstra over the same (cell, slot) graph as the A*, written
//! independently from the rules stated in `astar.rs`'s doc comment.
#![allow(dead_code)]

use std::cmp::Ordering;
use std::collections::{BinaryHeap, HashMap};

use swarmrt_planner::{Cell, Grid, Job, PlanParams, Potential, Reservations};

/// Proptest config: fixed seed, no failure files, `cases` cases.
pub fn config(cases: u32) -> proptest::test_runner::Config {
    proptest::test_runner::Config {
        cases,
        rng_seed: proptest::test_runner::RngSeed::Fixed(0x5eed_2024),
        failure_persistence: None,
        ..proptest::test_runner::Config::default()
    }
}

struct Entry(f64, Cell, u32);
impl PartialEq for Entry {
    fn eq(&self, o: &Self) -> bool {
        self.cmp(o) == Ordering::Equal
    }
}
impl Eq for Entry {}
impl PartialOrd for Entry {
    fn partial_cmp(&self, o: &Self) -> Option<Ordering> {
        Some(self.cmp(o))
    }
}
impl Ord for Entry {
    fn cmp(&self, o: &Self) -> Ordering {
        o.0.total_cmp(&self.0)
            .then((o.1, o.2).cmp(&(self.1, self.2)))
    }
}

/// Optimal cost from `job.start` at `job.start_slot` to parking at `job.goal`, or `None`.
pub fn dijkstra(grid: &Grid, res: &Reservations, job: &Job, params: &PlanParams) -> Option<f64> {
    if grid.blocked(job.goal) {
        return None;
    }
    let free_from = res.free_from(grid.index(job.goal), job.vehicle).ok()?;
    let pot = Potential::new(params.a, params.b, params.potential_range);
    let v = job.vehicle;
    let mut dist: HashMap<(Cell, u32), f64> = HashMap::new();
    let mut heap = BinaryHeap::new();
    dist.insert((job.start, 0), 0.0);
    heap.push(Entry(0.0, job.start, 0));
    let [nx, ny, nz] = grid.dims().map(i32::from);
    let mut others = Vec::new();
    while let Some(Entry(g, c, t)) = heap.pop() {
        if dist.get(&(c, t)).is_some_and(|best| *best < g) {
            continue;
        }
        let s = i64::from(job.start_slot) + i64::from(t);
        if c == job.goal && s >= free_from {
            return Some(g);
        }
        if t >= params.horizon_slots {
            continue;
        }
        res.positions_at(s + 1, v, &mut others);
        for di in -1..=1 {
            for dj in -1..=1 {
                for dk in -1..=1 {
                    let (i, j, k) = (
                        i32::from(c.i) + di,
                        i32::from(c.j) + dj,
                        i32::from(c.k) + dk,
                    );
                    if i < 0 || j < 0 || k < 0 || i >= nx || j >= ny || k >= nz {
                        continue;
                    }
                    let n = Cell::new(i as u16, j as u16, k as u16);
                    let step = if (di, dj, dk) == (0, 0, 0) {
                        if res.occupied_cell(grid, c, s + 1, v) {
                            continue;
                        }
                        params.wait_cost
                    } else {
                        // Every cell of the swept box but the origin: free and unoccupied at
                        // departure and arrival.
                        let mut ok = true;
                        for bi in [c.i, n.i] {
                            for bj in [c.j, n.j] {
                                for bk in [c.k, n.k] {
                                    let b = Cell::new(bi, bj, bk);
                                    if b != c
                                        && (grid.blocked(b)
                                            || res.occupied_cell(grid, b, s, v)
                                            || res.occupied_cell(grid, b, s + 1, v))
                                    {
                                        ok = false;
                                    }
                                }
                            }
                        }
                        if !ok {
                            continue;
                        }
                        f64::from(di * di + dj * dj + dk * dk).sqrt() * grid.d()
                    };
                    let ng = g + step + pot.sum(grid.centre(n), &others);
                    let key = (n, t + 1);
                    if dist.get(&key).is_none_or(|best| ng < *best) {
                        dist.insert(key, ng);
                        heap.push(Entry(ng, n, t + 1));
                    }
                }
            }
        }
    }
    None
}

/// A grid `dims` of 1 m cells with `blocked[idx]` cells blocked (flat index order).
pub fn grid_with(dims: [u16; 3], blocked: &[bool]) -> Grid {
    let mut g = Grid::new(
        [0.0; 3],
        [f64::from(dims[0]), f64::from(dims[1]), f64::from(dims[2])],
        1.0,
    )
    .unwrap();
    for idx in 0..g.len() {
        if blocked[idx % blocked.len()] {
            let c = g.cell_at(idx);
            g.set_blocked(c, true);
        }
    }
    g
}
