//! The heuristic of [`crate::astar`]: the static 26-connected distance to the goal around
//! obstacles, found lazily by a backward search from the goal (Silver 2005, "Cooperative
//! pathfinding", Reverse Resumable A*).
//!
//! A move's length is `d·1`, `d·√2` or `d·√3`, so a path's length is `d·(n₁ + √2·n₂ + √3·n₃)`
//! with `n₁, n₂, n₃` its numbers of straight, face-diagonal and body-diagonal moves. Distances
//! are kept as these counts and valued with exactly the expression of the free-space
//! ("octile") distance, so where no obstacle is in the way the heuristic is the octile
//! distance bit for bit (1, √2, √3 are linearly independent over ℚ, so a shortest length
//! has one count triple). Around obstacles it is larger, still admissible and consistent:
//! it is the true shortest length of the static graph (same moves, same no-corner-cutting
//! rule), and the time-dependent search only removes moves and adds non-negative costs.
//!
//! The backward search is A* towards the forward search's start (octile, consistent), resumed
//! until the cell asked for is closed; cells the forward search never asks about are mostly
//! never touched.

use std::cmp::Ordering;
use std::collections::BinaryHeap;

/// √2 and √3 as in the octile distance.
pub(crate) const S2: f64 = std::f64::consts::SQRT_2;
pub(crate) const S3: f64 = 1.732_050_807_568_877_2;

/// Length in cells of a path with `n[0]` straight, `n[1]` face-diagonal and `n[2]`
/// body-diagonal moves.
#[inline]
pub(crate) fn length(n: [u32; 3]) -> f64 {
    S3 * f64::from(n[2]) + S2 * f64::from(n[1]) + f64::from(n[0])
}

/// Octile move counts between index gaps: `[n₁, n₂, n₃]`.
#[inline]
pub(crate) fn octile_counts(dx: u32, dy: u32, dz: u32) -> [u32; 3] {
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
    [a - b, b - c, c]
}

#[derive(Debug, Clone, Copy)]
struct Entry {
    /// Bits of `length + octile to the start` (non-negative: bits order like values).
    f: u64,
    seq: u32,
    cell: u32,
}

impl PartialEq for Entry {
    fn eq(&self, other: &Self) -> bool {
        self.cmp(other) == Ordering::Equal
    }
}
impl Eq for Entry {}
impl PartialOrd for Entry {
    fn partial_cmp(&self, other: &Self) -> Option<Ordering> {
        Some(self.cmp(other))
    }
}
impl Ord for Entry {
    fn cmp(&self, other: &Self) -> Ordering {
        (other.f, other.seq).cmp(&(self.f, self.seq))
    }
}

#[derive(Debug, Clone, Copy, Default)]
struct Back {
    stamp: u32,
    closed: bool,
    seq: u32,
    counts: [u32; 3],
    /// `length(counts)`.
    len: f64,
}

/// A resumable backward search from one goal over the static grid.
#[derive(Debug, Default)]
pub(crate) struct StaticDistance {
    cells: Vec<Back>,
    open: BinaryHeap<Entry>,
    generation: u32,
    seq: u32,
    /// Forward start, in cells: the backward search's target.
    start: [u32; 3],
}

/// One of the 26 moves as the backward search uses it.
#[derive(Debug, Clone, Copy)]
pub(crate) struct BackMove {
    /// The move's step.
    pub(crate) off: [i32; 3],
    /// Flat-index delta of the step.
    pub(crate) delta: isize,
    /// 0, 1 or 2: straight, face-diagonal, body-diagonal.
    pub(crate) kind: usize,
}

impl StaticDistance {
    /// Starts a search from `goal` towards `start` on a grid of `ncells` cells.
    pub(crate) fn reset(&mut self, ncells: usize, goal: usize, start: [u32; 3]) {
        if self.cells.len() < ncells {
            self.cells.resize(ncells, Back::default());
        }
        self.generation = self.generation.wrapping_add(1);
        if self.generation == 0 {
            self.cells.fill(Back::default());
            self.generation = 1;
        }
        self.open.clear();
        self.seq = 0;
        self.start = start;
        self.cells[goal] = Back {
            stamp: self.generation,
            closed: false,
            seq: 0,
            counts: [0; 3],
            len: 0.0,
        };
        self.open.push(Entry {
            f: 0f64.to_bits(),
            seq: 0,
            cell: goal as u32,
        });
        self.seq = 1;
    }

    /// Shortest static path from the unblocked cell `idx` to the goal as move counts, or
    /// `None` if there is none. `dims` are the grid's, `moves` the 26 moves, `allowed(n)` the
    /// set of moves (bit `k` for `moves[k]`) statically allowed from the unblocked cell `n`.
    ///
    /// Between two unblocked cells a move is allowed one way iff the other way (the swept box
    /// is the same), so the backward search follows the moves allowed from the cell it
    /// expands. Only unblocked cells are reached: distances are exact for those.
    pub(crate) fn counts(
        &mut self,
        idx: usize,
        dims: [u32; 3],
        moves: &[BackMove],
        mut allowed: impl FnMut(usize) -> u32,
    ) -> Option<[u32; 3]> {
        let [nx, ny, _] = dims.map(|x| x as usize);
        loop {
            let b = self.cells[idx];
            if b.stamp == self.generation && b.closed {
                return Some(b.counts);
            }
            let top = self.open.pop()?;
            let n = top.cell as usize;
            let nb = self.cells[n];
            if nb.closed || nb.seq != top.seq {
                continue;
            }
            self.cells[n].closed = true;
            let (ni, nj, nk) = (n % nx, (n / nx) % ny, n / (nx * ny));
            let mut todo = allowed(n);
            while todo != 0 {
                let k = todo.trailing_zeros() as usize;
                todo &= todo - 1;
                let m = &moves[k];
                let c = (n as isize + m.delta) as usize;
                let cb = self.cells[c];
                let seen = cb.stamp == self.generation;
                if seen && cb.closed {
                    continue;
                }
                let mut counts = nb.counts;
                counts[m.kind] += 1;
                let len = length(counts);
                if seen && len >= cb.len {
                    continue;
                }
                let (i, j, kk) = (
                    (ni as i32 + m.off[0]) as u32,
                    (nj as i32 + m.off[1]) as u32,
                    (nk as i32 + m.off[2]) as u32,
                );
                let f = len
                    + length(octile_counts(
                        i.abs_diff(self.start[0]),
                        j.abs_diff(self.start[1]),
                        kk.abs_diff(self.start[2]),
                    ));
                self.cells[c] = Back {
                    stamp: self.generation,
                    closed: false,
                    seq: self.seq,
                    counts,
                    len,
                };
                self.open.push(Entry {
                    f: f.to_bits(),
                    seq: self.seq,
                    cell: c as u32,
                });
                self.seq += 1;
            }
        }
    }
}
