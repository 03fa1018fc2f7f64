//! The time-dependent A* of Marchenko & Ponomarenko 2024 (pseudo code `uav_find_path`,
//! eq. (3)).
//!
//! States are `(cell, slot)`; every action takes one slot: one of the 26 neighbour moves or a
//! wait. Edge cost, following eq. (3)'s `D + Potential` inside `tentative_gScore`:
//! `D` = Euclidean length of the move in metres (`wait_cost` for a wait, > 0 so waiting is
//! never free) + the potential of eq. (2) at the new cell at the new slot, summed over the
//! other vehicles' planned positions at that slot ([`Reservations::positions_at`]).
//!
//! Heuristic: the paper's `H` is a distance to the goal; we use the 26-connected free-space
//! ("octile") distance, `d·(√3·n₃ + √2·(n₂-n₃) + (n₁-n₂))` with `n₁ ≥ n₂ ≥ n₃` the sorted
//! index gaps. It is ≥ the Euclidean distance (so better informed) yet still admissible and
//! consistent: every path of 26-moves between two cells has length ≥ it, each edge costs at
//! least its length, and potential and waits only add non-negative terms.
//!
//! Bounded relaxation (paper, 2.2): `f = g + (1+ε)·H`. Weighted A* with a consistent `H`
//! returns cost ≤ (1+ε)·optimal even when closed states are never reopened (Likhachev et al.,
//! ARA*, 2003, Theorem 1); this search never reopens them, so the bound holds and each state
//! is expanded at most once.
//!
//! Forbidden states and moves:
//! - a move from `c` to `n` sweeps the axis-aligned box of cells between them (1, 3 or 7
//!   cells besides `c`); every one must be free of static obstacles (no corner cutting, so
//!   the straight segment and the monotone spline of [`crate::spline`] stay in free cells)
//!   and not occupied by eq. (1) at the departure slot or the arrival slot (no swaps, no
//!   diagonal crossings through a shared corner);
//! - a wait at `c` needs `c` not occupied at the next slot;
//! - the start state is never checked: the vehicle is already there (it may hover inside an
//!   inflated obstacle cell) and may leave.
//!
//! Goal test: the goal cell at a slot from which on the goal stays free for ever
//! ([`Reservations::free_from`]), so the vehicle can park there; an earlier pass through the
//! goal is just a state like any other.
//!
//! Pruning (a time-expanded graph holds many copies of one cell): a popped state `(c, t)` is
//! dropped unexpanded when the first expanded state of `c`, `(c, t0)` with cost `g0`,
//! dominates it:
//! - steady part of time (from [`Reservations::steady_from`] on nothing changes): `t0 ≤ t`
//!   and `g0 ≤ g` — the same continuation is valid from `(c, t0)`, arriving earlier;
//! - otherwise, when waiting at `c` from `t0` to `t` is allowed and its cost (wait_cost plus
//!   the potential per slot) added to `g0` is strictly below `g` — the wait chain reaches this
//!   very state for less.
//!
//! Both keep an optimal (resp. (1+ε)-bounded) route reachable; the Dijkstra property tests
//! check it. `Route::expansions` counts expanded states, not dropped ones.
//!
//! Ties: among equal `f`, smaller `h` first, then first pushed first — fully deterministic.

use std::cmp::Ordering;
use std::collections::{BinaryHeap, HashMap};
use std::hash::{BuildHasherDefault, Hasher};

use crate::error::PlanError;
use crate::grid::{Cell, Grid};
use crate::occupancy::Reservations;
use crate::params::PlanParams;
use crate::potential::Potential;
use crate::route::{self, Route};

/// One vehicle's planning request.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Job {
    /// The vehicle's id (its own reservations are ignored).
    pub vehicle: u32,
    /// Cell at `start_slot`.
    pub start: Cell,
    /// Cell to park at.
    pub goal: Cell,
    /// Slot at which the vehicle is at `start`.
    pub start_slot: u32,
}

/// 26-connected free-space distance between index gaps, in cells.
#[inline]
fn octile(dx: u32, dy: u32, dz: u32) -> f64 {
    let (mut a, mut b, mut c) = (dx, dy, dz);
    if a < b {
        std::mem::swap(&mut a, &mut b);
    }
    if b < c {
        std::mem::swap(&mut b, &mut c);
    }
    if a < b {
        std::mem::swap(&mut a, &mut b);
    }
    const S2: f64 = std::f64::consts::SQRT_2;
    const S3: f64 = 1.732_050_807_568_877_2;
    S3 * f64::from(c) + S2 * f64::from(b - c) + f64::from(a - b)
}

/// Finalizer of splitmix64: a fast, well-mixed hash for `u64` state keys. Only used for
/// lookups; no map is ever iterated.
#[derive(Default, Clone, Copy)]
struct KeyHasher(u64);

impl Hasher for KeyHasher {
    fn finish(&self) -> u64 {
        self.0
    }
    fn write(&mut self, bytes: &[u8]) {
        for b in bytes {
            self.write_u64(self.0 ^ u64::from(*b));
        }
    }
    fn write_u64(&mut self, x: u64) {
        let mut z = x.wrapping_add(0x9E37_79B9_7F4A_7C15);
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        self.0 = z ^ (z >> 31);
    }
}

/// State id → node, flat with generation stamps when `cells × slots` is small, hashed
/// otherwise.
#[derive(Debug, Default)]
struct StateMap {
    stamp: Vec<u32>,
    node: Vec<u32>,
    generation: u32,
    flat: bool,
    hashed: HashMap<u64, u32, BuildHasherDefault<KeyHasher>>,
}

/// Most flat entries (2 × u32 each) a planner keeps: 32 MiB.
const FLAT_MAX: usize = 1 << 22;

impl StateMap {
    fn reset(&mut self, states: usize) {
        self.flat = states <= FLAT_MAX;
        if self.flat {
            if self.stamp.len() < states {
                self.stamp.resize(states, 0);
                self.node.resize(states, 0);
            }
            self.generation = self.generation.wrapping_add(1);
            if self.generation == 0 {
                self.stamp.fill(0);
                self.generation = 1;
            }
        } else {
            self.hashed.clear();
        }
    }

    #[inline]
    fn get(&self, key: usize) -> Option<u32> {
        if self.flat {
            (self.stamp[key] == self.generation).then(|| self.node[key])
        } else {
            self.hashed.get(&(key as u64)).copied()
        }
    }

    #[inline]
    fn insert(&mut self, key: usize, node: u32) {
        if self.flat {
            self.stamp[key] = self.generation;
            self.node[key] = node;
        } else {
            self.hashed.insert(key as u64, node);
        }
    }
}

#[derive(Debug, Clone, Copy)]
struct Node {
    cell: u32,
    t: u32,
    g: f64,
    parent: u32,
    closed: bool,
}

#[derive(Debug, Clone, Copy)]
struct Open {
    f: f64,
    h: f64,
    seq: u64,
    g: f64,
    node: u32,
}

impl PartialEq for Open {
    fn eq(&self, other: &Self) -> bool {
        self.cmp(other) == Ordering::Equal
    }
}
impl Eq for Open {}
impl PartialOrd for Open {
    fn partial_cmp(&self, other: &Self) -> Option<Ordering> {
        Some(self.cmp(other))
    }
}
impl Ord for Open {
    /// Reversed: `BinaryHeap` pops the smallest `(f, h, seq)`.
    fn cmp(&self, other: &Self) -> Ordering {
        other
            .f
            .total_cmp(&self.f)
            .then(other.h.total_cmp(&self.h))
            .then(other.seq.cmp(&self.seq))
    }
}

/// One of the 26 moves with what it sweeps, as flat-index deltas for the current grid.
#[derive(Debug, Clone)]
struct Move {
    off: [i32; 3],
    len: f64,
    /// Cells of the swept box other than the origin; the target is the last one.
    sweep: Vec<isize>,
}

/// Reusable search buffers: keep one per thread and call [`Planner::plan`] repeatedly to
/// avoid re-allocating (results do not depend on what was planned before).
#[derive(Debug, Default)]
pub struct Planner {
    nodes: Vec<Node>,
    open: BinaryHeap<Open>,
    states: StateMap,
    moves: Vec<Move>,
    moves_for: Option<([u16; 3], u64)>,
    positions: Vec<Vec<[f64; 3]>>,
    positions_gen: Vec<u32>,
    generation: u32,
    /// Per cell: (generation, slot, g) of the first state of that cell expanded.
    first: Vec<(u32, u32, f64)>,
    /// Other vehicles near the cell being expanded.
    near: Vec<[f64; 3]>,
}

/// Longest wait chain tried when testing dominance (see [`Planner::plan`]).
const MAX_DOMINANCE_WAIT: u32 = 16;

/// Fills the cache of other vehicles' positions at relative slot `t` once per search.
#[allow(clippy::too_many_arguments)]
#[inline]
fn fill_positions(
    positions: &mut [Vec<[f64; 3]>],
    gens: &mut [u32],
    generation: u32,
    res: &Reservations,
    vehicle: u32,
    base: i64,
    t: u32,
) {
    if gens[t as usize] != generation {
        res.positions_at(base + i64::from(t), vehicle, &mut positions[t as usize]);
        gens[t as usize] = generation;
    }
}

impl Planner {
    /// Empty buffers.
    pub fn new() -> Planner {
        Planner::default()
    }

    fn prepare_moves(&mut self, grid: &Grid) {
        let key = (grid.dims(), grid.d().to_bits());
        if self.moves_for == Some(key) {
            return;
        }
        let [nx, ny, _] = grid.dims().map(|x| x as isize);
        self.moves.clear();
        for code in 0u8..27 {
            if code == route::WAIT {
                continue;
            }
            let off = route::offset(code);
            // Every corner of the box spanned by the move, but the origin; the target last.
            let mut sweep: Vec<[i32; 3]> = Vec::new();
            for a in 1..8 {
                let o = [
                    off[0] * (a & 1),
                    off[1] * ((a >> 1) & 1),
                    off[2] * ((a >> 2) & 1),
                ];
                if o != [0, 0, 0] && o != off && !sweep.contains(&o) {
                    sweep.push(o);
                }
            }
            sweep.push(off);
            let nz = off.iter().filter(|x| **x != 0).count();
            self.moves.push(Move {
                off,
                len: (nz as f64).sqrt() * grid.d(),
                sweep: sweep
                    .iter()
                    .map(|o| o[0] as isize + nx * (o[1] as isize + ny * o[2] as isize))
                    .collect(),
            });
        }
        self.moves_for = Some(key);
    }

    /// Plans `job` on `grid` against `reservations` (eq. (1) occupancy, eq. (2) potential
    /// from the other vehicles), minimising eq. (3)'s cost within `params`' budgets.
    pub fn plan(
        &mut self,
        grid: &Grid,
        reservations: &Reservations,
        job: &Job,
        params: &PlanParams,
    ) -> Result<Route, PlanError> {
        params.validate()?;
        for c in [job.start, job.goal] {
            if !grid.contains(c) {
                return Err(PlanError::OutOfGrid { cell: c });
            }
        }
        if grid.blocked(job.goal) {
            return Err(PlanError::GoalBlocked { goal: job.goal });
        }
        let goal_idx = grid.index(job.goal);
        let goal_free = reservations
            .free_from(goal_idx, job.vehicle)
            .map_err(|vehicle| PlanError::GoalTaken {
                goal: job.goal,
                vehicle,
            })?;
        self.prepare_moves(grid);
        let potential = Potential::new(params.a, params.b, params.potential_range);
        let weight = 1.0 + params.epsilon;
        let d = grid.d();
        let horizon = params.horizon_slots;
        let ncells = grid.len();
        let [nx, ny, nz] = grid.dims().map(i32::from);
        let h_of = |c: Cell| {
            d * octile(
                u32::from(c.i.abs_diff(job.goal.i)),
                u32::from(c.j.abs_diff(job.goal.j)),
                u32::from(c.k.abs_diff(job.goal.k)),
            )
        };

        self.nodes.clear();
        self.open.clear();
        self.states.reset(ncells * (horizon as usize + 1));
        self.generation = self.generation.wrapping_add(1);
        if self.positions.len() < horizon as usize + 2 {
            self.positions.resize(horizon as usize + 2, Vec::new());
            self.positions_gen.resize(horizon as usize + 2, u32::MAX);
        }
        if self.first.len() < ncells {
            self.first.resize(ncells, (0, 0, 0.0));
        }
        let off = potential.is_off();
        let steady = reservations.steady_from(job.vehicle);
        let near_r2 = (potential.range() + 3f64.sqrt() * d + 1e-9).powi(2);
        let start_idx = grid.index(job.start);
        let h0 = h_of(job.start);
        self.nodes.push(Node {
            cell: start_idx as u32,
            t: 0,
            g: 0.0,
            parent: u32::MAX,
            closed: false,
        });
        self.states.insert(start_idx, 0);
        self.open.push(Open {
            f: weight * h0,
            h: h0,
            seq: 0,
            g: 0.0,
            node: 0,
        });
        let mut seq: u64 = 1;
        let mut expansions: u64 = 0;
        let base = i64::from(job.start_slot);

        while let Some(top) = self.open.pop() {
            let ni = top.node as usize;
            let node = self.nodes[ni];
            if node.closed || top.g > node.g {
                continue;
            }
            let slot = base + i64::from(node.t);
            if node.cell as usize == goal_idx && slot >= goal_free {
                return Ok(self.reconstruct(grid, ni, job.start_slot, expansions));
            }
            self.nodes[ni].closed = true;
            let idx = node.cell as usize;
            let cell = grid.cell_at(idx);
            let centre = grid.centre(cell);
            // Dominance: if this cell was expanded earlier at slot t0 with g0 and waiting
            // there from t0 to now is allowed and strictly cheaper than this state's g, the
            // wait chain reaches this very state for less; expanding it cannot help.
            // In the steady part of time (nothing changes any more), an earlier-or-equal slot
            // with no larger g dominates outright: the same continuation is valid earlier.
            let rec = self.first[idx];
            if rec.0 != self.generation {
                self.first[idx] = (self.generation, node.t, node.g);
            } else if rec.1 <= node.t && base + i64::from(rec.1) >= steady && rec.2 <= node.g {
                continue;
            } else if rec.1 < node.t && node.t - rec.1 <= MAX_DOMINANCE_WAIT {
                let mut gw = rec.2;
                let mut chain = true;
                for t in rec.1 + 1..=node.t {
                    if reservations.any_at(idx)
                        && reservations.occupied(idx, base + i64::from(t), job.vehicle)
                    {
                        chain = false;
                        break;
                    }
                    let p = if off {
                        0.0
                    } else {
                        fill_positions(
                            &mut self.positions,
                            &mut self.positions_gen,
                            self.generation,
                            reservations,
                            job.vehicle,
                            base,
                            t,
                        );
                        potential.sum(centre, &self.positions[t as usize])
                    };
                    gw += params.wait_cost + p;
                    if gw + 1e-9 >= node.g {
                        chain = false;
                        break;
                    }
                }
                if chain {
                    continue;
                }
            }
            expansions += 1;
            if expansions > params.max_expansions {
                return Err(PlanError::NoRoute {
                    expansions: expansions - 1,
                });
            }
            if node.t >= horizon {
                continue;
            }
            let t1 = node.t + 1;
            self.near.clear();
            if !off {
                fill_positions(
                    &mut self.positions,
                    &mut self.positions_gen,
                    self.generation,
                    reservations,
                    job.vehicle,
                    base,
                    t1,
                );
                for q in &self.positions[t1 as usize] {
                    let d2 = (q[0] - centre[0]).powi(2)
                        + (q[1] - centre[1]).powi(2)
                        + (q[2] - centre[2]).powi(2);
                    if d2 <= near_r2 {
                        self.near.push(*q);
                    }
                }
            }
            let others: &[[f64; 3]] = &self.near;

            // Wait.
            if !(reservations.any_at(idx) && reservations.occupied(idx, slot + 1, job.vehicle)) {
                let cost = params.wait_cost + potential.sum(centre, others);
                let h = h_of(cell);
                Self::relax(
                    &mut self.nodes,
                    &mut self.states,
                    &mut self.open,
                    &mut seq,
                    ni,
                    idx,
                    t1,
                    node.g + cost,
                    h,
                    weight,
                    ncells,
                );
            }
            // The 26 moves.
            'moves: for m in &self.moves {
                let (i, j, k) = (
                    i32::from(cell.i) + m.off[0],
                    i32::from(cell.j) + m.off[1],
                    i32::from(cell.k) + m.off[2],
                );
                if i < 0 || j < 0 || k < 0 || i >= nx || j >= ny || k >= nz {
                    continue;
                }
                for &delta in &m.sweep {
                    let b = (idx as isize + delta) as usize;
                    if grid.blocked_index(b)
                        || (reservations.any_at(b)
                            && (reservations.occupied(b, slot, job.vehicle)
                                || reservations.occupied(b, slot + 1, job.vehicle)))
                    {
                        continue 'moves;
                    }
                }
                let n = Cell {
                    i: i as u16,
                    j: j as u16,
                    k: k as u16,
                };
                let nidx = (idx as isize + m.sweep[m.sweep.len() - 1]) as usize;
                let cost = m.len + potential.sum(grid.centre(n), others);
                let h = h_of(n);
                Self::relax(
                    &mut self.nodes,
                    &mut self.states,
                    &mut self.open,
                    &mut seq,
                    ni,
                    nidx,
                    t1,
                    node.g + cost,
                    h,
                    weight,
                    ncells,
                );
            }
        }
        Err(PlanError::NoRoute { expansions })
    }

    #[allow(clippy::too_many_arguments)]
    #[inline]
    fn relax(
        nodes: &mut Vec<Node>,
        states: &mut StateMap,
        open: &mut BinaryHeap<Open>,
        seq: &mut u64,
        parent: usize,
        cell: usize,
        t: u32,
        g: f64,
        h: f64,
        weight: f64,
        ncells: usize,
    ) {
        let key = t as usize * ncells + cell;
        let ni = match states.get(key) {
            Some(ni) => {
                let n = &mut nodes[ni as usize];
                if n.closed || g >= n.g {
                    return;
                }
                n.g = g;
                n.parent = parent as u32;
                ni
            }
            None => {
                let ni = nodes.len() as u32;
                nodes.push(Node {
                    cell: cell as u32,
                    t,
                    g,
                    parent: parent as u32,
                    closed: false,
                });
                states.insert(key, ni);
                ni
            }
        };
        open.push(Open {
            f: g + weight * h,
            h,
            seq: *seq,
            g,
            node: ni,
        });
        *seq += 1;
    }

    fn reconstruct(
        &self,
        grid: &Grid,
        goal_node: usize,
        start_slot: u32,
        expansions: u64,
    ) -> Route {
        let mut cells = Vec::with_capacity(self.nodes[goal_node].t as usize + 1);
        let mut ni = goal_node as u32;
        while ni != u32::MAX {
            let n = &self.nodes[ni as usize];
            cells.push(grid.cell_at(n.cell as usize));
            ni = n.parent;
        }
        cells.reverse();
        Route {
            start_slot,
            cells,
            cost: self.nodes[goal_node].g,
            expansions,
        }
    }
}

/// Plans one route with fresh buffers (see [`Planner::plan`]).
pub fn plan(
    grid: &Grid,
    reservations: &Reservations,
    job: &Job,
    params: &PlanParams,
) -> Result<Route, PlanError> {
    Planner::new().plan(grid, reservations, job, params)
}
