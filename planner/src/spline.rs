//! Path smoothing: the paper smooths the A* path "by a cubic spline with N_points = 5"
//! (Marchenko & Ponomarenko 2024, 2.2) and checks it.
//!
//! Choice: a *monotone* cubic Hermite spline per axis (Fritsch–Carlson 1980) through the
//! timed knots `(t_k = (start_slot + k)·slot, centre(cells[k]))`, with zero velocity at the
//! first and last knot (a hovering UAV starts and stops at rest). A natural cubic spline
//! overshoots between knots and can swing a corner into an inflated obstacle cell; the
//! monotone one keeps every coordinate between its two knots' values, so each segment stays
//! inside the axis-aligned box of the two cell centres. The A* only takes moves whose whole
//! swept box of cells is free ([`crate::astar`]), hence the smoothed path stays in free cells
//! by construction, waits stay exactly still, and timing is exact (every knot kept).
//! [`Trajectory::check`] verifies it by sampling (N_points per segment plus every d/10), and
//! [`Trajectory::new`] falls back to the straight segment wherever a check fails (possible
//! only when the first knot is replaced by an off-centre start position).

use crate::grid::{Cell, Grid};
use crate::route::Route;

/// Hermite knots per axis: values and slopes at uniform times.
#[derive(Debug, Clone, PartialEq)]
pub struct Spline {
    t0: f64,
    h: f64,
    x: Vec<[f64; 3]>,
    m: Vec<[f64; 3]>,
    /// Segments drawn as straight lines instead (fallback after a failed check).
    linear: Vec<bool>,
}

/// Fritsch–Carlson slopes for values `y` at spacing `h`, zero at both ends.
fn monotone_slopes(y: &[f64], h: f64) -> Vec<f64> {
    let n = y.len();
    let mut m = vec![0.0; n];
    if n < 2 {
        return m;
    }
    let delta: Vec<f64> = y.windows(2).map(|w| (w[1] - w[0]) / h).collect();
    for k in 1..n - 1 {
        if delta[k - 1] * delta[k] > 0.0 {
            m[k] = (delta[k - 1] + delta[k]) / 2.0;
        }
    }
    for (k, &dk) in delta.iter().enumerate() {
        if dk == 0.0 {
            m[k] = 0.0;
            m[k + 1] = 0.0;
            continue;
        }
        let a = m[k] / dk;
        let b = m[k + 1] / dk;
        let s = a * a + b * b;
        if s > 9.0 {
            let tau = 3.0 / s.sqrt();
            m[k] = tau * a * dk;
            m[k + 1] = tau * b * dk;
        }
    }
    m
}

impl Spline {
    /// A monotone spline through `points` at times `t0 + k·h`.
    pub fn through(t0: f64, h: f64, points: &[[f64; 3]]) -> Spline {
        let mut m = vec![[0.0; 3]; points.len()];
        for a in 0..3 {
            let y: Vec<f64> = points.iter().map(|p| p[a]).collect();
            for (k, s) in monotone_slopes(&y, h).into_iter().enumerate() {
                m[k][a] = s;
            }
        }
        Spline {
            t0,
            h,
            x: points.to_vec(),
            m,
            linear: vec![false; points.len().saturating_sub(1)],
        }
    }

    /// Segment index and local parameter in `[0, 1]`, or `None` outside the knots.
    fn locate(&self, t: f64) -> Option<(usize, f64)> {
        let u = (t - self.t0) / self.h;
        let segs = self.x.len().saturating_sub(1);
        if segs == 0 || u.is_nan() || u <= 0.0 || u >= segs as f64 {
            return None;
        }
        let k = (u.floor() as usize).min(segs - 1);
        Some((k, u - k as f64))
    }

    /// Position at `t`: the first knot before, the last knot after.
    pub fn position(&self, t: f64) -> [f64; 3] {
        let Some((k, s)) = self.locate(t) else {
            return if t <= self.t0 {
                self.x[0]
            } else {
                self.x[self.x.len() - 1]
            };
        };
        let (p0, p1) = (self.x[k], self.x[k + 1]);
        if self.linear[k] {
            return [0, 1, 2].map(|a| p0[a] + s * (p1[a] - p0[a]));
        }
        let (s2, s3) = (s * s, s * s * s);
        let h00 = 2.0 * s3 - 3.0 * s2 + 1.0;
        let h10 = s3 - 2.0 * s2 + s;
        let h01 = -2.0 * s3 + 3.0 * s2;
        let h11 = s3 - s2;
        [0, 1, 2].map(|a| {
            h00 * p0[a]
                + h10 * self.h * self.m[k][a]
                + h01 * p1[a]
                + h11 * self.h * self.m[k + 1][a]
        })
    }

    /// Velocity at `t` (zero outside the knots).
    pub fn velocity(&self, t: f64) -> [f64; 3] {
        let Some((k, s)) = self.locate(t) else {
            return [0.0; 3];
        };
        let (p0, p1) = (self.x[k], self.x[k + 1]);
        if self.linear[k] {
            return [0, 1, 2].map(|a| (p1[a] - p0[a]) / self.h);
        }
        let s2 = s * s;
        let d00 = 6.0 * s2 - 6.0 * s;
        let d10 = 3.0 * s2 - 4.0 * s + 1.0;
        let d01 = -6.0 * s2 + 6.0 * s;
        let d11 = 3.0 * s2 - 2.0 * s;
        [0, 1, 2].map(|a| {
            (d00 * p0[a]
                + d10 * self.h * self.m[k][a]
                + d01 * p1[a]
                + d11 * self.h * self.m[k + 1][a])
                / self.h
        })
    }
}

/// What a vehicle follows: the smoothed route, checked against the grid.
#[derive(Debug, Clone, PartialEq)]
pub struct Trajectory {
    spline: Spline,
    start_cell: Cell,
    segments_linear: usize,
}

impl Trajectory {
    /// Smooths `route` (`slot` seconds per slot), optionally starting from the vehicle's exact
    /// `start` position instead of its start cell's centre, then checks every segment with
    /// `n_points` samples plus every d/10 and draws the segments that fail as straight lines.
    pub fn new(
        grid: &Grid,
        route: &Route,
        slot: f64,
        start: Option<[f64; 3]>,
        n_points: usize,
    ) -> Trajectory {
        let mut pts: Vec<[f64; 3]> = route.cells.iter().map(|c| grid.centre(*c)).collect();
        if let Some(p) = start {
            pts[0] = p;
        }
        let spline = Spline::through(f64::from(route.start_slot) * slot, slot, &pts);
        let mut traj = Trajectory {
            spline,
            start_cell: route.cells[0],
            segments_linear: 0,
        };
        for k in 0..traj.spline.linear.len() {
            if traj.check_segment(grid, k, n_points).is_some() {
                traj.spline.linear[k] = true;
                traj.segments_linear += 1;
            }
        }
        traj
    }

    /// Position at time `t` seconds.
    pub fn position(&self, t: f64) -> [f64; 3] {
        self.spline.position(t)
    }

    /// Velocity at time `t` seconds.
    pub fn velocity(&self, t: f64) -> [f64; 3] {
        self.spline.velocity(t)
    }

    /// Time of the first knot.
    pub fn start_time(&self) -> f64 {
        self.spline.t0
    }

    /// Time of the last knot (the vehicle holds still after it).
    pub fn end_time(&self) -> f64 {
        self.spline.t0 + self.spline.h * self.spline.linear.len() as f64
    }

    /// Segments drawn straight because the smooth curve failed the check.
    pub fn segments_linear(&self) -> usize {
        self.segments_linear
    }

    fn check_segment(&self, grid: &Grid, k: usize, n_points: usize) -> Option<(f64, Cell)> {
        let (p0, p1) = (self.spline.x[k], self.spline.x[k + 1]);
        let len =
            ((p1[0] - p0[0]).powi(2) + (p1[1] - p0[1]).powi(2) + (p1[2] - p0[2]).powi(2)).sqrt();
        let fine = (len / (grid.d() / 10.0)).ceil() as usize;
        let n = n_points.max(fine).max(1);
        let t0 = self.spline.t0 + self.spline.h * k as f64;
        (0..=n).find_map(|q| {
            let t = t0 + self.spline.h * q as f64 / n as f64;
            let p = self.position(t);
            match grid.cell_of(p) {
                Some(c) if c == self.start_cell || !grid.blocked(c) => None,
                Some(c) => Some((t, c)),
                None => Some((t, grid.nearest_cell(p))),
            }
        })
    }

    /// The first sample (time, cell) inside a blocked cell or outside the grid, sampling
    /// `n_points` per segment plus every d/10 along it; `None` = collision-free. The start
    /// cell is exempt: the vehicle is already there.
    pub fn check(&self, grid: &Grid, n_points: usize) -> Option<(f64, Cell)> {
        (0..self.spline.linear.len()).find_map(|k| self.check_segment(grid, k, n_points))
    }
}
