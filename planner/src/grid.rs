//! The shared 3D occupancy grid ("матриця-сітка") of Marchenko & Ponomarenko 2024, 2.1.
//!
//! Space is cut into d × d × d cubes; a cube is blocked (value 1) when a static obstacle,
//! grown by the vehicle's safe radius r (item 2 of section 2.1), touches it. Frame: x east,
//! y north, z up (the paper uses local NED; only the axis names differ). Cell `(i, j, k)`
//! covers `[min + (i,j,k)·d, min + (i+1,j+1,k+1)·d]`.

use serde::{Deserialize, Serialize};

use crate::error::PlanError;

/// Most cells a grid may have (16 M): the blocked map is one byte per cell.
pub const MAX_CELLS: u64 = 1 << 24;

/// One cube of the grid, by integer index along x, y, z.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
pub struct Cell {
    /// Index along x (east).
    pub i: u16,
    /// Index along y (north).
    pub j: u16,
    /// Index along z (up).
    pub k: u16,
}

impl Cell {
    /// A cell from its three indices.
    pub const fn new(i: u16, j: u16, k: u16) -> Cell {
        Cell { i, j, k }
    }
}

/// The static part of the grid: bounds, cell size and which cells obstacles block.
#[derive(Debug, Clone, PartialEq)]
pub struct Grid {
    min: [f64; 3],
    d: f64,
    dims: [u16; 3],
    blocked: Vec<bool>,
}

/// Gap between the intervals `[lo, hi]` and `[a, b]`: positive = distance apart,
/// negative = overlap depth.
fn gap(lo: f64, hi: f64, a: f64, b: f64) -> f64 {
    (a - hi).max(lo - b)
}

/// Distance from point `p` to the segment `a`–`b` in the plane.
fn point_segment(p: [f64; 2], a: [f64; 2], b: [f64; 2]) -> f64 {
    let ab = [b[0] - a[0], b[1] - a[1]];
    let ap = [p[0] - a[0], p[1] - a[1]];
    let len2 = ab[0] * ab[0] + ab[1] * ab[1];
    let s = if len2 > 0.0 {
        ((ap[0] * ab[0] + ap[1] * ab[1]) / len2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    let q = [a[0] + s * ab[0] - p[0], a[1] + s * ab[1] - p[1]];
    q[0].hypot(q[1])
}

fn cross(o: [f64; 2], a: [f64; 2], b: [f64; 2]) -> f64 {
    (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])
}

/// Whether the closed segments `p1p2` and `q1q2` meet.
fn segments_meet(p1: [f64; 2], p2: [f64; 2], q1: [f64; 2], q2: [f64; 2]) -> bool {
    let d1 = cross(q1, q2, p1);
    let d2 = cross(q1, q2, p2);
    let d3 = cross(p1, p2, q1);
    let d4 = cross(p1, p2, q2);
    if ((d1 > 0.0 && d2 < 0.0) || (d1 < 0.0 && d2 > 0.0))
        && ((d3 > 0.0 && d4 < 0.0) || (d3 < 0.0 && d4 > 0.0))
    {
        return true;
    }
    let on = |a: [f64; 2], b: [f64; 2], p: [f64; 2], c: f64| {
        c == 0.0
            && p[0] >= a[0].min(b[0])
            && p[0] <= a[0].max(b[0])
            && p[1] >= a[1].min(b[1])
            && p[1] <= a[1].max(b[1])
    };
    on(q1, q2, p1, d1) || on(q1, q2, p2, d2) || on(p1, p2, q1, d3) || on(p1, p2, q2, d4)
}

/// Even-odd point-in-polygon test.
fn point_in_polygon(p: [f64; 2], poly: &[[f64; 2]]) -> bool {
    let mut inside = false;
    let mut j = poly.len() - 1;
    for i in 0..poly.len() {
        let (a, b) = (poly[i], poly[j]);
        if (a[1] > p[1]) != (b[1] > p[1])
            && p[0] < (b[0] - a[0]) * (p[1] - a[1]) / (b[1] - a[1]) + a[0]
        {
            inside = !inside;
        }
        j = i;
    }
    inside
}

/// Distance in the plane between the rectangle `[lo, hi]` and the filled polygon `poly`
/// (0 when they meet). Exact: if they do not meet, the closest pair involves a vertex of one
/// of them and an edge of the other.
fn rect_polygon_distance(lo: [f64; 2], hi: [f64; 2], poly: &[[f64; 2]]) -> f64 {
    let corners = [lo, [hi[0], lo[1]], hi, [lo[0], hi[1]]];
    let centre = [(lo[0] + hi[0]) / 2.0, (lo[1] + hi[1]) / 2.0];
    if point_in_polygon(centre, poly) {
        return 0.0;
    }
    let mut best = f64::INFINITY;
    for e in 0..poly.len() {
        let (a, b) = (poly[e], poly[(e + 1) % poly.len()]);
        let a_in = a[0] >= lo[0] && a[0] <= hi[0] && a[1] >= lo[1] && a[1] <= hi[1];
        if a_in {
            return 0.0;
        }
        for r in 0..4 {
            if segments_meet(a, b, corners[r], corners[(r + 1) % 4]) {
                return 0.0;
            }
            best = best.min(point_segment(corners[r], a, b)).min(point_segment(
                a,
                corners[r],
                corners[(r + 1) % 4],
            ));
        }
    }
    best
}

impl Grid {
    /// A grid of d × d × d cubes over `[min, max]`; `ceil(extent / d)` cells per axis, so the
    /// last cells may stick out past `max`. All cells start free.
    pub fn new(min: [f64; 3], max: [f64; 3], d: f64) -> Result<Grid, PlanError> {
        if !(d.is_finite() && d > 0.0) {
            return Err(PlanError::InvalidGrid {
                reason: "cell size d must be finite and > 0",
            });
        }
        let mut dims = [0u16; 3];
        let mut total: u64 = 1;
        for a in 0..3 {
            let ext = max[a] - min[a];
            if !(min[a].is_finite() && max[a].is_finite() && ext > 0.0) {
                return Err(PlanError::InvalidGrid {
                    reason: "every axis needs finite bounds with max > min",
                });
            }
            // Tolerance so 10 m / 1 m is 10 cells, not 11 after rounding.
            let n = (ext / d - 1e-9).ceil().max(1.0);
            if n > f64::from(u16::MAX) {
                return Err(PlanError::TooManyCells {
                    cells: n as u64,
                    max: MAX_CELLS,
                });
            }
            dims[a] = n as u16;
            total = total.saturating_mul(n as u64);
        }
        if total > MAX_CELLS {
            return Err(PlanError::TooManyCells {
                cells: total,
                max: MAX_CELLS,
            });
        }
        Ok(Grid {
            min,
            d,
            dims,
            blocked: vec![false; total as usize],
        })
    }

    /// Cells per axis `[nx, ny, nz]`.
    pub fn dims(&self) -> [u16; 3] {
        self.dims
    }

    /// Cell edge length, metres.
    pub fn d(&self) -> f64 {
        self.d
    }

    /// The grid's lower corner.
    pub fn min(&self) -> [f64; 3] {
        self.min
    }

    /// Number of cells.
    pub fn len(&self) -> usize {
        self.blocked.len()
    }

    /// Never true: a grid has at least one cell.
    pub fn is_empty(&self) -> bool {
        self.blocked.is_empty()
    }

    /// Whether `c` lies inside the grid.
    pub fn contains(&self, c: Cell) -> bool {
        c.i < self.dims[0] && c.j < self.dims[1] && c.k < self.dims[2]
    }

    /// Flat index of `c` (x fastest); callers must pass a cell inside the grid.
    #[inline]
    pub fn index(&self, c: Cell) -> usize {
        let [nx, ny, _] = self.dims;
        usize::from(c.i) + usize::from(nx) * (usize::from(c.j) + usize::from(ny) * usize::from(c.k))
    }

    /// The cell with flat index `idx`.
    #[inline]
    pub fn cell_at(&self, idx: usize) -> Cell {
        let nx = usize::from(self.dims[0]);
        let ny = usize::from(self.dims[1]);
        Cell {
            i: (idx % nx) as u16,
            j: ((idx / nx) % ny) as u16,
            k: (idx / (nx * ny)) as u16,
        }
    }

    /// Centre of cell `c`, metres.
    #[inline]
    pub fn centre(&self, c: Cell) -> [f64; 3] {
        [
            self.min[0] + (f64::from(c.i) + 0.5) * self.d,
            self.min[1] + (f64::from(c.j) + 0.5) * self.d,
            self.min[2] + (f64::from(c.k) + 0.5) * self.d,
        ]
    }

    /// The cell containing point `p`, or `None` outside the grid. A point on a face between
    /// two cells belongs to the upper one, except on the grid's upper faces.
    pub fn cell_of(&self, p: [f64; 3]) -> Option<Cell> {
        let mut idx = [0u16; 3];
        for a in 0..3 {
            let u = (p[a] - self.min[a]) / self.d;
            if !(u >= 0.0 && u <= f64::from(self.dims[a])) {
                return None;
            }
            idx[a] = (u.floor() as u32).min(u32::from(self.dims[a]) - 1) as u16;
        }
        Some(Cell {
            i: idx[0],
            j: idx[1],
            k: idx[2],
        })
    }

    /// The cell containing `p` after clamping `p` into the grid (NaN goes to index 0).
    pub fn nearest_cell(&self, p: [f64; 3]) -> Cell {
        let mut idx = [0u16; 3];
        for a in 0..3 {
            let u = ((p[a] - self.min[a]) / self.d).floor();
            let top = f64::from(self.dims[a] - 1);
            idx[a] = if u >= 0.0 { u.min(top) as u16 } else { 0 };
        }
        Cell {
            i: idx[0],
            j: idx[1],
            k: idx[2],
        }
    }

    /// Whether cell `c` is blocked by a static obstacle (cells outside the grid count as blocked).
    #[inline]
    pub fn blocked(&self, c: Cell) -> bool {
        !self.contains(c) || self.blocked[self.index(c)]
    }

    /// Whether the cell with flat index `idx` is blocked.
    #[inline]
    pub fn blocked_index(&self, idx: usize) -> bool {
        self.blocked[idx]
    }

    /// Marks cell `c` blocked (no-op outside the grid).
    pub fn set_blocked(&mut self, c: Cell, blocked: bool) {
        if self.contains(c) {
            let idx = self.index(c);
            self.blocked[idx] = blocked;
        }
    }

    /// Number of blocked cells.
    pub fn blocked_count(&self) -> usize {
        self.blocked.iter().filter(|b| **b).count()
    }

    /// The 26 neighbours of `c` that lie inside the grid, in move-code order (see
    /// [`crate::route`]).
    pub fn neighbours26(&self, c: Cell) -> impl Iterator<Item = Cell> + '_ {
        (0u8..27)
            .filter(|code| *code != crate::route::WAIT)
            .filter_map(move |code| {
                let [di, dj, dk] = crate::route::offset(code);
                let n = Cell {
                    i: u16::try_from(i32::from(c.i) + di).ok()?,
                    j: u16::try_from(i32::from(c.j) + dj).ok()?,
                    k: u16::try_from(i32::from(c.k) + dk).ok()?,
                };
                self.contains(n).then_some(n)
            })
    }

    /// Cube bounds of cell `(i, j, k)`.
    fn cube(&self, idx: [usize; 3]) -> ([f64; 3], [f64; 3]) {
        let lo = [
            self.min[0] + idx[0] as f64 * self.d,
            self.min[1] + idx[1] as f64 * self.d,
            self.min[2] + idx[2] as f64 * self.d,
        ];
        (lo, [lo[0] + self.d, lo[1] + self.d, lo[2] + self.d])
    }

    /// Index ranges of the cells whose cubes meet the box `[lo, hi]` grown by `pad`.
    fn range(&self, lo: [f64; 3], hi: [f64; 3], pad: f64) -> Option<[std::ops::Range<usize>; 3]> {
        let mut r: [std::ops::Range<usize>; 3] = [0..0, 0..0, 0..0];
        for a in 0..3 {
            let n = f64::from(self.dims[a]);
            let s = (((lo[a] - pad - self.min[a]) / self.d).floor()).max(0.0);
            let e = (((hi[a] + pad - self.min[a]) / self.d).floor() + 1.0).min(n);
            if s.partial_cmp(&e) != Some(std::cmp::Ordering::Less) {
                return None;
            }
            r[a] = s as usize..e as usize;
        }
        Some(r)
    }

    /// Blocks every cell accepted by `hit(cube_lo, cube_hi)` among the cells near the
    /// obstacle's bounding box `[lo, hi]` grown by `inflate`.
    fn block_where(
        &mut self,
        lo: [f64; 3],
        hi: [f64; 3],
        inflate: f64,
        hit: impl Fn([f64; 3], [f64; 3]) -> bool,
    ) {
        let Some([ri, rj, rk]) = self.range(lo, hi, inflate.max(0.0)) else {
            return;
        };
        let nx = usize::from(self.dims[0]);
        let ny = usize::from(self.dims[1]);
        for k in rk {
            for j in rj.clone() {
                for i in ri.clone() {
                    let (clo, chi) = self.cube([i, j, k]);
                    if hit(clo, chi) {
                        self.blocked[i + nx * (j + ny * k)] = true;
                    }
                }
            }
        }
    }

    /// Blocks every cell whose cube comes closer than `inflate` to the box `[min, max]`, or
    /// whose interior overlaps it (exact box-to-box distance). A cell that only shares a face
    /// with the box is blocked only when `inflate > 0`.
    pub fn block_box(&mut self, min: [f64; 3], max: [f64; 3], inflate: f64) {
        self.block_where(min, max, inflate, |lo, hi| {
            let g = [
                gap(lo[0], hi[0], min[0], max[0]),
                gap(lo[1], hi[1], min[1], max[1]),
                gap(lo[2], hi[2], min[2], max[2]),
            ];
            let dist = g.iter().map(|x| x.max(0.0).powi(2)).sum::<f64>().sqrt();
            dist < inflate || g.iter().all(|x| *x < 0.0)
        });
    }

    /// Blocks every cell whose cube comes closer than `inflate` to the vertical cylinder of
    /// radius `r` about `centre` between `z_min` and `z_max`, or overlaps its interior. Exact:
    /// cube and cylinder are both products (plane shape × z interval), so their distance is
    /// `hypot(plane distance, z gap)`.
    pub fn block_cylinder(
        &mut self,
        centre: [f64; 2],
        r: f64,
        z_min: f64,
        z_max: f64,
        inflate: f64,
    ) {
        let lo = [centre[0] - r, centre[1] - r, z_min];
        let hi = [centre[0] + r, centre[1] + r, z_max];
        self.block_where(lo, hi, inflate, |clo, chi| {
            let qx = centre[0].clamp(clo[0], chi[0]);
            let qy = centre[1].clamp(clo[1], chi[1]);
            let to_axis = (qx - centre[0]).hypot(qy - centre[1]);
            let gz = gap(clo[2], chi[2], z_min, z_max);
            let dist = (to_axis - r).max(0.0).hypot(gz.max(0.0));
            dist < inflate || (to_axis < r && gz < 0.0)
        });
    }

    /// Blocks every cell whose cube comes closer than `inflate` to the prism `points` ×
    /// `[z_min, z_max]` (any simple polygon, convex or not), or meets it. The plane distance
    /// is exact (rectangle-to-polygon: zero on overlap, else the closest vertex–edge pair);
    /// unlike the box and cylinder, a cube that only touches the prism's side is blocked even
    /// with `inflate = 0` (conservative).
    pub fn block_prism(&mut self, points: &[[f64; 2]], z_min: f64, z_max: f64, inflate: f64) {
        if points.len() < 3 {
            return;
        }
        let mut lo = [f64::INFINITY, f64::INFINITY, z_min];
        let mut hi = [f64::NEG_INFINITY, f64::NEG_INFINITY, z_max];
        for p in points {
            lo[0] = lo[0].min(p[0]);
            lo[1] = lo[1].min(p[1]);
            hi[0] = hi[0].max(p[0]);
            hi[1] = hi[1].max(p[1]);
        }
        self.block_where(lo, hi, inflate, |clo, chi| {
            let gz = gap(clo[2], chi[2], z_min, z_max);
            if gz > inflate {
                return false;
            }
            let dxy = rect_polygon_distance([clo[0], clo[1]], [chi[0], chi[1]], points);
            let dist = dxy.hypot(gz.max(0.0));
            dist < inflate || (dxy == 0.0 && gz < 0.0)
        });
    }
}
