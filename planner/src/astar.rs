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
//!
//! Speed (same results, see the tests): per search, lazily, each cell gets its heuristic and
//! two move masks (moves allowed by the grid; of those, moves sweeping a cell with any
//! reservation, the only ones whose occupancy is checked); each `(cell, slot)` keeps its
//! node and its eq. (2) potential, computed once; a closed neighbour is skipped before its
//! cost is computed; a cheaper path to an open state updates its open-list entry in place.

use std::collections::HashMap;
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

/// No node.
const NONE: u32 = u32::MAX;
/// Flag on [`Slot::node`]: the node is closed (expanded or dropped by dominance).
const CLOSED: u32 = 1 << 31;

/// What the search knows about one state `(cell, t)`: its node, if generated, and the
/// potential of eq. (2) at that cell and slot, once computed (NaN before).
#[derive(Debug, Clone, Copy)]
struct Slot {
    stamp: u32,
    /// Node index, with [`CLOSED`] once closed; `NONE` if none yet.
    node: u32,
    p: f64,
}

impl Slot {
    const FRESH: Slot = Slot {
        stamp: 0,
        node: NONE,
        p: f64::NAN,
    };
}

/// How [`StateMap`] stores its slots.
#[derive(Debug, Default, Clone, Copy, PartialEq, Eq)]
enum Layout {
    /// One slot per state, stamped with the search generation.
    #[default]
    Flat,
    /// Pages of [`PAGE`] consecutive states, allocated on first touch from a pool, found
    /// through a stamped directory.
    Paged,
    /// A hash map (astronomically many states).
    Hashed,
}

/// State id → [`Slot`]: flat with generation stamps when `cells × slots` is small, paged when
/// larger, hashed beyond that.
#[derive(Debug, Default)]
struct StateMap {
    /// Flat: every state's slot. Paged: the page pool.
    slots: Vec<Slot>,
    /// Paged: per page of states, (generation, page index in the pool).
    dir: Vec<(u32, u32)>,
    /// Paged: pages handed out in this search.
    pages: usize,
    generation: u32,
    layout: Layout,
    hashed: HashMap<u64, Slot, BuildHasherDefault<KeyHasher>>,
}

/// Most flat entries (16 bytes each) a planner keeps: 32 MiB.
const FLAT_MAX: usize = 1 << 21;
/// States per page, as a shift.
const PAGE_BITS: u32 = 6;
/// States per page.
const PAGE: usize = 1 << PAGE_BITS;
/// Most directory entries (8 bytes each) a planner keeps: 128 MiB.
const DIR_MAX: usize = 1 << 24;

impl StateMap {
    fn reset(&mut self, states: usize) {
        let dir_len = states.div_ceil(PAGE);
        self.layout = if states <= FLAT_MAX {
            Layout::Flat
        } else if dir_len <= DIR_MAX {
            Layout::Paged
        } else {
            Layout::Hashed
        };
        self.generation = self.generation.wrapping_add(1);
        if self.generation == 0 {
            self.slots.fill(Slot::FRESH);
            self.dir.fill((0, 0));
            self.generation = 1;
        }
        match self.layout {
            Layout::Flat => {
                if self.slots.len() < states {
                    self.slots.resize(states, Slot::FRESH);
                }
            }
            Layout::Paged => {
                if self.dir.len() < dir_len {
                    self.dir.resize(dir_len, (0, 0));
                }
                self.pages = 0;
            }
            Layout::Hashed => self.hashed.clear(),
        }
    }

    /// The entry of state `key`, fresh (no node, no potential) if not seen in this search.
    #[inline(always)]
    fn slot(&mut self, key: usize) -> &mut Slot {
        if self.layout == Layout::Flat {
            let generation = self.generation;
            let s = &mut self.slots[key];
            if s.stamp != generation {
                *s = Slot {
                    stamp: generation,
                    ..Slot::FRESH
                };
            }
            return s;
        }
        self.slot_paged_or_hashed(key)
    }

    /// [`StateMap::slot`] for the paged and hashed layouts.
    #[inline(never)]
    fn slot_paged_or_hashed(&mut self, key: usize) -> &mut Slot {
        let at = match self.layout {
            Layout::Flat => key,
            Layout::Paged => {
                let d = &mut self.dir[key >> PAGE_BITS];
                if d.0 != self.generation {
                    let start = self.pages * PAGE;
                    if self.slots.len() < start + PAGE {
                        self.slots.resize(start + PAGE, Slot::FRESH);
                    } else {
                        self.slots[start..start + PAGE].fill(Slot::FRESH);
                    }
                    *d = (self.generation, self.pages as u32);
                    self.pages += 1;
                }
                ((d.1 as usize) << PAGE_BITS) | (key & (PAGE - 1))
            }
            Layout::Hashed => {
                return self.hashed.entry(key as u64).or_insert(Slot {
                    stamp: self.generation,
                    ..Slot::FRESH
                });
            }
        };
        let s = &mut self.slots[at];
        if s.stamp != self.generation {
            *s = Slot {
                stamp: self.generation,
                ..Slot::FRESH
            };
        }
        s
    }
}

#[derive(Debug, Clone, Copy)]
struct Node {
    cell: u32,
    t: u32,
    g: f64,
    parent: u32,
    /// Position in the open list, `NONE` when not in it.
    pos: u32,
}

/// An open-list entry: a node and its key `(f, h, seq)`, smallest first. `f` and `h` are
/// non-negative finite, so their bit patterns order like the values; `seq` numbers the
/// (re)insertions, so keys are unique and ties go to the first pushed.
#[derive(Debug, Clone, Copy)]
struct Open {
    f: u64,
    h: u64,
    seq: u32,
    node: u32,
}

impl Open {
    #[inline]
    fn before(&self, other: &Open) -> bool {
        (self.f, self.h, self.seq) < (other.f, other.h, other.seq)
    }
}

/// Binary min-heap of open nodes with their positions kept in [`Node::pos`], so a cheaper
/// path to an open node updates its entry in place (no stale entries). Pops in the same
/// order as a heap holding every push and skipping superseded ones: the entries in the heap
/// are exactly the latest push of each open node, with the same keys.
#[derive(Debug, Default)]
struct OpenList {
    heap: Vec<Open>,
}

impl OpenList {
    fn clear(&mut self) {
        self.heap.clear();
    }

    /// Inserts `e`, or replaces the entry of its node (the key may go up or down).
    #[inline]
    fn set(&mut self, nodes: &mut [Node], e: Open) {
        let pos = nodes[e.node as usize].pos;
        if pos == NONE {
            self.heap.push(e);
            self.sift_up(nodes, self.heap.len() - 1);
        } else {
            self.heap[pos as usize] = e;
            if !self.sift_up(nodes, pos as usize) {
                self.sift_down(nodes, pos as usize);
            }
        }
    }

    #[inline]
    fn pop(&mut self, nodes: &mut [Node]) -> Option<Open> {
        if self.heap.is_empty() {
            return None;
        }
        let top = self.heap.swap_remove(0);
        nodes[top.node as usize].pos = NONE;
        if !self.heap.is_empty() {
            self.sift_down(nodes, 0);
        }
        Some(top)
    }

    /// Moves the entry at `i` up to its place; whether it moved.
    #[inline]
    fn sift_up(&mut self, nodes: &mut [Node], mut i: usize) -> bool {
        let e = self.heap[i];
        let start = i;
        while i > 0 {
            let p = (i - 1) / 2;
            let q = self.heap[p];
            if !e.before(&q) {
                break;
            }
            self.heap[i] = q;
            nodes[q.node as usize].pos = i as u32;
            i = p;
        }
        self.heap[i] = e;
        nodes[e.node as usize].pos = i as u32;
        i != start
    }

    #[inline]
    fn sift_down(&mut self, nodes: &mut [Node], mut i: usize) {
        let e = self.heap[i];
        let n = self.heap.len();
        loop {
            let mut c = 2 * i + 1;
            if c >= n {
                break;
            }
            if c + 1 < n && self.heap[c + 1].before(&self.heap[c]) {
                c += 1;
            }
            let q = self.heap[c];
            if !q.before(&e) {
                break;
            }
            self.heap[i] = q;
            nodes[q.node as usize].pos = i as u32;
            i = c;
        }
        self.heap[i] = e;
        nodes[e.node as usize].pos = i as u32;
    }
}

/// One of the 26 moves with what it sweeps, as flat-index deltas for the current grid.
#[derive(Debug, Clone)]
struct Move {
    len: f64,
    /// Cells of the swept box other than the origin; the target is the last one.
    sweep: Vec<isize>,
    /// Flat-index delta of the target (the last of `sweep`).
    target: isize,
    /// The same cells as a set of move codes ([`route::offset`]), bit per code.
    bits: u32,
}

/// Per cell, filled lazily once per search: the heuristic, and which moves leave the cell.
#[derive(Debug, Clone, Copy, Default)]
struct CellInfo {
    h_gen: u32,
    mask_gen: u32,
    h: f64,
    /// Moves (bit = index in `Planner::moves`) that stay in the grid and sweep no blocked cell.
    ok: u32,
    /// Of those, the moves that sweep a cell with any reservation (occupancy to check).
    reserved: u32,
}

/// Move codes with `di = -1` (codes 0..9); `<< 18` gives `di = +1`.
const CODES_DI_NEG: u32 = 0x1ff;
/// Move codes with `dj = -1`; `<< 6` gives `dj = +1`.
const CODES_DJ_NEG: u32 = 0b111 | 0b111 << 9 | 0b111 << 18;
/// Move codes with `dk = -1`; `<< 2` gives `dk = +1`.
const CODES_DK_NEG: u32 = 0o1_111_111_111;

/// Fills `info`'s move masks for the cell `idx` if not done in this search.
#[inline]
fn fill_masks(
    info: &mut CellInfo,
    idx: usize,
    grid: &Grid,
    reservations: &Reservations,
    moves: &[Move],
    deltas: &[isize; 27],
    generation: u32,
) {
    if info.mask_gen == generation {
        return;
    }
    // The 3 × 3 × 3 neighbourhood as bit sets over move codes: outside the grid or blocked,
    // and reserved by anyone.
    let cell = grid.cell_at(idx);
    let [nx, ny, nz] = grid.dims();
    let mut out = 0u32;
    if cell.i == 0 {
        out |= CODES_DI_NEG;
    }
    if cell.i + 1 == nx {
        out |= CODES_DI_NEG << 18;
    }
    if cell.j == 0 {
        out |= CODES_DJ_NEG;
    }
    if cell.j + 1 == ny {
        out |= CODES_DJ_NEG << 6;
    }
    if cell.k == 0 {
        out |= CODES_DK_NEG;
    }
    if cell.k + 1 == nz {
        out |= CODES_DK_NEG << 2;
    }
    let mut blocked = out;
    let mut taken = 0u32;
    let mut inside = !out & ((1 << 27) - 1) & !(1 << route::WAIT);
    while inside != 0 {
        let code = inside.trailing_zeros();
        inside &= inside - 1;
        let b = (idx as isize + deltas[code as usize]) as usize;
        blocked |= u32::from(grid.blocked_index(b)) << code;
        taken |= u32::from(reservations.any_at(b)) << code;
    }
    let (mut ok, mut reserved) = (0u32, 0u32);
    for (bit, m) in moves.iter().enumerate() {
        if m.bits & blocked == 0 {
            ok |= 1 << bit;
            if m.bits & taken != 0 {
                reserved |= 1 << bit;
            }
        }
    }
    info.mask_gen = generation;
    info.ok = ok;
    info.reserved = reserved;
}

/// Reusable search buffers: keep one per thread and call [`Planner::plan`] repeatedly to
/// avoid re-allocating (results do not depend on what was planned before).
#[derive(Debug, Default)]
pub struct Planner {
    nodes: Vec<Node>,
    open: OpenList,
    states: StateMap,
    moves: Vec<Move>,
    /// Flat-index delta of each move code's step.
    deltas: [isize; 27],
    moves_for: Option<([u16; 3], u64)>,
    positions: Vec<Vec<[f64; 3]>>,
    positions_gen: Vec<u32>,
    generation: u32,
    /// Per cell: (generation, slot, g) of the first state of that cell expanded.
    first: Vec<(u32, u32, f64)>,
    /// Per cell: heuristic and move masks.
    cells: Vec<CellInfo>,
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
            let bits = sweep
                .iter()
                .map(|o| 1u32 << route::code_of(o[0], o[1], o[2]))
                .fold(0, |a, b| a | b);
            self.moves.push(Move {
                bits,
                target: off[0] as isize + nx * (off[1] as isize + ny * off[2] as isize),
                len: (nz as f64).sqrt() * grid.d(),
                sweep: sweep
                    .iter()
                    .map(|o| o[0] as isize + nx * (o[1] as isize + ny * o[2] as isize))
                    .collect(),
            });
        }
        for code in 0u8..27 {
            let o = route::offset(code);
            self.deltas[usize::from(code)] =
                o[0] as isize + nx * (o[1] as isize + ny * o[2] as isize);
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
        self.nodes.clear();
        self.open.clear();
        self.states.reset(ncells * (horizon as usize + 1));
        self.generation = self.generation.wrapping_add(1);
        if self.generation == 0 {
            // Stamps of 0 could alias the initial state of the per-cell tables.
            self.first.fill((0, 0, 0.0));
            self.cells.fill(CellInfo::default());
            self.positions_gen.fill(u32::MAX);
            self.generation = 1;
        }
        let generation = self.generation;
        if self.positions.len() < horizon as usize + 2 {
            self.positions.resize(horizon as usize + 2, Vec::new());
            self.positions_gen.resize(horizon as usize + 2, u32::MAX);
        }
        if self.first.len() < ncells {
            self.first.resize(ncells, (0, 0, 0.0));
        }
        if self.cells.len() < ncells {
            self.cells.resize(ncells, CellInfo::default());
        }
        let off = potential.is_off();
        let steady = reservations.steady_from(job.vehicle);
        let near_r2 = (potential.range() + 3f64.sqrt() * d + 1e-9).powi(2);
        let start_idx = grid.index(job.start);
        let goal = job.goal;
        let h_of = |c: Cell| {
            d * octile(
                u32::from(c.i.abs_diff(goal.i)),
                u32::from(c.j.abs_diff(goal.j)),
                u32::from(c.k.abs_diff(goal.k)),
            )
        };
        let h0 = h_of(job.start);
        self.cells[start_idx].h = h0;
        self.cells[start_idx].h_gen = generation;
        let Planner {
            nodes,
            open,
            states,
            moves,
            positions,
            positions_gen,
            first,
            cells,
            near,
            deltas,
            ..
        } = self;
        let deltas: &[isize; 27] = deltas;
        let moves: &[Move] = moves;
        nodes.push(Node {
            cell: start_idx as u32,
            t: 0,
            g: 0.0,
            parent: NONE,
            pos: NONE,
        });
        states.slot(start_idx).node = 0;
        open.set(
            nodes,
            Open {
                f: (weight * h0).to_bits(),
                h: h0.to_bits(),
                seq: 0,
                node: 0,
            },
        );
        let mut seq: u32 = 1;
        let mut expansions: u64 = 0;
        let base = i64::from(job.start_slot);

        while let Some(top) = open.pop(nodes) {
            let ni = top.node as usize;
            let node = nodes[ni];
            let slot = base + i64::from(node.t);
            if node.cell as usize == goal_idx && slot >= goal_free {
                return Ok(reconstruct(grid, nodes, ni, job.start_slot, expansions));
            }
            states
                .slot(node.t as usize * ncells + node.cell as usize)
                .node |= CLOSED;
            let idx = node.cell as usize;
            let cell = grid.cell_at(idx);
            let centre = grid.centre(cell);
            // Dominance: if this cell was expanded earlier at slot t0 with g0 and waiting
            // there from t0 to now is allowed and strictly cheaper than this state's g, the
            // wait chain reaches this very state for less; expanding it cannot help.
            // In the steady part of time (nothing changes any more), an earlier-or-equal slot
            // with no larger g dominates outright: the same continuation is valid earlier.
            let rec = first[idx];
            if rec.0 != generation {
                first[idx] = (generation, node.t, node.g);
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
                        let s = states.slot(t as usize * ncells + idx);
                        if s.p.is_nan() {
                            fill_positions(
                                positions,
                                positions_gen,
                                generation,
                                reservations,
                                job.vehicle,
                                base,
                                t,
                            );
                            s.p = potential.sum(centre, &positions[t as usize]);
                        }
                        s.p
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
            // Other vehicles close enough to this cell to reach a neighbour: the potential of
            // eq. (2) over them equals the one over all vehicles, bit for bit (same order,
            // the others add nothing).
            near.clear();
            if !off {
                fill_positions(
                    positions,
                    positions_gen,
                    generation,
                    reservations,
                    job.vehicle,
                    base,
                    t1,
                );
                for q in &positions[t1 as usize] {
                    let d2 = (q[0] - centre[0]).powi(2)
                        + (q[1] - centre[1]).powi(2)
                        + (q[2] - centre[2]).powi(2);
                    if d2 <= near_r2 {
                        near.push(*q);
                    }
                }
            }
            let others: &[[f64; 3]] = near;
            let row = t1 as usize * ncells;

            // Wait.
            if !(reservations.any_at(idx) && reservations.occupied(idx, slot + 1, job.vehicle)) {
                let s = states.slot(row + idx);
                if s.node == NONE || s.node & CLOSED == 0 {
                    let p = if others.is_empty() {
                        0.0
                    } else {
                        if s.p.is_nan() {
                            s.p = potential.sum(centre, others);
                        }
                        s.p
                    };
                    let cost = params.wait_cost + p;
                    let h = cells[idx].h;
                    relax(
                        nodes,
                        s,
                        open,
                        &mut seq,
                        ni,
                        idx,
                        t1,
                        node.g + cost,
                        h,
                        weight,
                    );
                }
            }
            // The 26 moves.
            let info = &mut cells[idx];
            fill_masks(info, idx, grid, reservations, moves, deltas, generation);
            let (mut todo, reserved) = (info.ok, info.reserved);
            'moves: while todo != 0 {
                let bit = todo.trailing_zeros();
                todo &= todo - 1;
                let m = &moves[bit as usize];
                if reserved & (1 << bit) != 0 {
                    for &delta in &m.sweep {
                        let b = (idx as isize + delta) as usize;
                        if reservations.any_at(b)
                            && (reservations.occupied(b, slot, job.vehicle)
                                || reservations.occupied(b, slot + 1, job.vehicle))
                        {
                            continue 'moves;
                        }
                    }
                }
                let nidx = (idx as isize + m.target) as usize;
                let s = states.slot(row + nidx);
                if s.node != NONE && s.node & CLOSED != 0 {
                    continue;
                }
                let p = if others.is_empty() {
                    0.0
                } else {
                    if s.p.is_nan() {
                        s.p = potential.sum(grid.centre(grid.cell_at(nidx)), others);
                    }
                    s.p
                };
                let cost = m.len + p;
                let ci = &mut cells[nidx];
                if ci.h_gen != generation {
                    ci.h = h_of(grid.cell_at(nidx));
                    ci.h_gen = generation;
                }
                let h = ci.h;
                relax(
                    nodes,
                    s,
                    open,
                    &mut seq,
                    ni,
                    nidx,
                    t1,
                    node.g + cost,
                    h,
                    weight,
                );
            }
        }
        Err(PlanError::NoRoute { expansions })
    }
}

/// Offers `g` to the state `(cell, t)` whose entry is `slot`: a new node, or a cheaper path
/// to an open one, is put on the open list.
#[allow(clippy::too_many_arguments)]
#[inline]
fn relax(
    nodes: &mut Vec<Node>,
    slot: &mut Slot,
    open: &mut OpenList,
    seq: &mut u32,
    parent: usize,
    cell: usize,
    t: u32,
    g: f64,
    h: f64,
    weight: f64,
) {
    let ni = if slot.node != NONE {
        // Closed slots never get here.
        let n = &mut nodes[slot.node as usize];
        if g >= n.g {
            return;
        }
        n.g = g;
        n.parent = parent as u32;
        slot.node
    } else {
        let ni = nodes.len() as u32;
        assert!(ni < CLOSED, "more than 2^31 search nodes");
        nodes.push(Node {
            cell: cell as u32,
            t,
            g,
            parent: parent as u32,
            pos: NONE,
        });
        slot.node = ni;
        ni
    };
    open.set(
        nodes,
        Open {
            f: (g + weight * h).to_bits(),
            h: h.to_bits(),
            seq: *seq,
            node: ni,
        },
    );
    *seq += 1;
}

fn reconstruct(
    grid: &Grid,
    nodes: &[Node],
    goal_node: usize,
    start_slot: u32,
    expansions: u64,
) -> Route {
    let mut cells = Vec::with_capacity(nodes[goal_node].t as usize + 1);
    let mut ni = goal_node as u32;
    while ni != NONE {
        let n = &nodes[ni as usize];
        cells.push(grid.cell_at(n.cell as usize));
        ni = n.parent;
    }
    cells.reverse();
    Route {
        start_slot,
        cells,
        cost: nodes[goal_node].g,
        expansions,
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

#[cfg(test)]
mod tests {
    use super::*;

    /// Every layout of the state table behaves like a map from key to slot that forgets
    /// everything on reset.
    #[test]
    fn state_map_layouts_agree_with_a_map() {
        for states in [1000, FLAT_MAX + 1, (DIR_MAX + 1) * PAGE] {
            let mut map = StateMap::default();
            let mut x: u64 = 0x2545_f491_4f6c_dd1d;
            for round in 0..3u32 {
                map.reset(states);
                let mut reference: HashMap<usize, u32> = HashMap::new();
                for i in 0..5000u32 {
                    x ^= x << 13;
                    x ^= x >> 7;
                    x ^= x << 17;
                    // Keys cluster like a search's: a few hot pages, some far away.
                    let key = if x.is_multiple_of(4) {
                        (x >> 8) as usize % states
                    } else {
                        (x >> 8) as usize % 300 + states / 2
                    };
                    let s = map.slot(key);
                    match reference.get(&key) {
                        Some(&node) => assert_eq!(s.node, node, "round {round} key {key}"),
                        None => {
                            assert_eq!(s.node, NONE, "round {round} key {key}");
                            assert!(s.p.is_nan());
                        }
                    }
                    s.node = i;
                    reference.insert(key, i);
                }
                assert_eq!(
                    map.layout,
                    if states <= FLAT_MAX {
                        Layout::Flat
                    } else if states <= DIR_MAX * PAGE {
                        Layout::Paged
                    } else {
                        Layout::Hashed
                    }
                );
            }
        }
    }
}
