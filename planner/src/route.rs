//! A planned route and its compact radio form.
//!
//! The A* of Marchenko & Ponomarenko 2024 (pseudo code, `reconstruct_path`) returns a list of
//! cells; here `cells[k]` is the cell held at slot `start_slot + k`, so the route carries the
//! timing eq. (1) needs. Over the radio a route is its start plus one byte per step.
//!
//! Move byte: `(di+1)·9 + (dj+1)·3 + (dk+1)` for a step by `(di, dj, dk)` in `{-1,0,1}³`;
//! 13 is "wait".

use serde::{Deserialize, Serialize};

use crate::error::PlanError;
use crate::grid::{Cell, Grid};

/// Move code for waiting in place.
pub const WAIT: u8 = 13;

/// The step `(di, dj, dk)` of a move code in `0..27`.
#[inline]
pub const fn offset(code: u8) -> [i32; 3] {
    [
        (code / 9) as i32 - 1,
        ((code / 3) % 3) as i32 - 1,
        (code % 3) as i32 - 1,
    ]
}

/// The move code of a step with each component in `{-1, 0, 1}`.
#[inline]
pub const fn code_of(di: i32, dj: i32, dk: i32) -> u8 {
    ((di + 1) * 9 + (dj + 1) * 3 + (dk + 1)) as u8
}

/// A timed route: `cells[k]` is held at slot `start_slot + k`; consecutive cells are equal
/// (wait) or 26-neighbours. After the last cell the vehicle parks there.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Route {
    /// Slot at which the vehicle is at `cells[0]`.
    pub start_slot: u32,
    /// Cells held at consecutive slots.
    pub cells: Vec<Cell>,
    /// Path cost g (metres of travel + waits + potential, eq. (3)); 0 when rebuilt from moves.
    pub cost: f64,
    /// States the search expanded (0 when rebuilt from moves).
    pub expansions: u64,
}

impl Route {
    /// Slot at which the vehicle reaches its last cell.
    pub fn end_slot(&self) -> u32 {
        self.start_slot + (self.cells.len().max(1) as u32 - 1)
    }

    /// The cell held at `slot`: the first cell before the start, the last after the end.
    pub fn cell_at(&self, slot: i64) -> Cell {
        let k = (slot - i64::from(self.start_slot)).clamp(0, self.cells.len() as i64 - 1);
        self.cells[k as usize]
    }

    /// Runs of equal consecutive cells, in order: `(cell, first slot, last slot, last run)`.
    /// The last run is where the vehicle parks (it holds that cell for ever after).
    pub fn runs(&self) -> impl Iterator<Item = (Cell, i64, i64, bool)> + '_ {
        let n = self.cells.len();
        let mut k = 0;
        std::iter::from_fn(move || {
            if k >= n {
                return None;
            }
            let c = self.cells[k];
            let mut m = k;
            while m + 1 < n && self.cells[m + 1] == c {
                m += 1;
            }
            let first = i64::from(self.start_slot) + k as i64;
            let last = i64::from(self.start_slot) + m as i64;
            k = m + 1;
            Some((c, first, last, k == n))
        })
    }

    /// One byte per step (see the module doc); `cells.len() - 1` bytes.
    pub fn moves(&self) -> Vec<u8> {
        self.cells
            .windows(2)
            .map(|w| {
                let d = |a: u16, b: u16| (i32::from(b) - i32::from(a)).clamp(-1, 1);
                code_of(d(w[0].i, w[1].i), d(w[0].j, w[1].j), d(w[0].k, w[1].k))
            })
            .collect()
    }

    /// Rebuilds a route from its start and move bytes. Cost and expansions are not carried
    /// over the radio and come back as 0. Grid bounds are not checked here (no grid).
    pub fn from_moves(start: Cell, start_slot: u32, moves: &[u8]) -> Result<Route, PlanError> {
        let mut cells = Vec::with_capacity(moves.len() + 1);
        cells.push(start);
        let mut c = start;
        for (index, &code) in moves.iter().enumerate() {
            if code > 26 {
                return Err(PlanError::BadMove { index, code });
            }
            let [di, dj, dk] = offset(code);
            let step = |v: u16, dv: i32| u16::try_from(i32::from(v) + dv).ok();
            let (Some(i), Some(j), Some(k)) = (step(c.i, di), step(c.j, dj), step(c.k, dk)) else {
                return Err(PlanError::BadMove { index, code });
            };
            c = Cell { i, j, k };
            cells.push(c);
        }
        Ok(Route {
            start_slot,
            cells,
            cost: 0.0,
            expansions: 0,
        })
    }

    /// Position at time `t` seconds, moving in straight lines between cell centres at slot
    /// instants (`slot_seconds` per slot); holds the first centre before the start and the
    /// last after the end.
    pub fn position_at(&self, grid: &Grid, slot_seconds: f64, t: f64) -> [f64; 3] {
        let u = t / slot_seconds - f64::from(self.start_slot);
        let last = self.cells.len() - 1;
        if u.is_nan() || u <= 0.0 {
            return grid.centre(self.cells[0]);
        }
        if u >= last as f64 {
            return grid.centre(self.cells[last]);
        }
        let k = u.floor() as usize;
        let s = u - k as f64;
        let a = grid.centre(self.cells[k]);
        let b = grid.centre(self.cells[k + 1]);
        [
            a[0] + s * (b[0] - a[0]),
            a[1] + s * (b[1] - a[1]),
            a[2] + s * (b[2] - a[2]),
        ]
    }
}
