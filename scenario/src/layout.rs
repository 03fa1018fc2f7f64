//! Where robots start: a square grid around `robots.start`, derived from the count, so
//! changing `robots.count` alone gives a valid layout.

use crate::config::Config;

impl Config {
    /// Start positions: the `robots.count` points of a square grid of `start.spacing` nearest
    /// to `start.(x, y)` that lie inside the bounds and satisfy `clear` (the world passes its
    /// obstacle clearance), so any count that fits the map gives a valid layout. `None` when
    /// the map has no room for that many.
    pub fn start_positions(&self, clear: impl Fn(f64, f64) -> bool) -> Option<Vec<(f64, f64)>> {
        let r = &self.robots;
        nearest_grid_points(
            r.count as usize,
            (r.start.x, r.start.y),
            r.start.spacing,
            self.map.bounds,
            r.radius,
            clear,
        )
    }

    /// Initial heading of every robot, radians.
    pub fn start_heading(&self) -> f64 {
        self.robots.start.heading_deg.to_radians()
    }
}

/// Most grid candidates [`nearest_grid_points`] will consider (bounds a huge map with a tiny
/// spacing).
const MAX_GRID_CANDIDATES: i64 = 4_000_000;

/// The `n` points of a square grid of `spacing` through `centre` that are nearest to `centre`,
/// at least `margin` inside `bounds` and accepted by `ok`; ordered by grid distance, then row,
/// then column (integer keys, so the order is exact). `None` if fewer than `n` qualify.
pub fn nearest_grid_points(
    n: usize,
    centre: (f64, f64),
    spacing: f64,
    bounds: [f64; 4],
    margin: f64,
    ok: impl Fn(f64, f64) -> bool,
) -> Option<Vec<(f64, f64)>> {
    if n == 0 {
        return Some(Vec::new());
    }
    if !spacing.is_finite() || spacing <= 0.0 {
        return None;
    }
    // Index ranges in f64 first: a tiny spacing on a large map must not overflow i64.
    let lo_i = ((bounds[0] + margin - centre.0) / spacing).ceil();
    let hi_i = ((bounds[2] - margin - centre.0) / spacing).floor();
    let lo_j = ((bounds[1] + margin - centre.1) / spacing).ceil();
    let hi_j = ((bounds[3] - margin - centre.1) / spacing).floor();
    if !(hi_i >= lo_i && hi_j >= lo_j)
        || (hi_i - lo_i + 1.0) * (hi_j - lo_j + 1.0) > MAX_GRID_CANDIDATES as f64
    {
        return None;
    }
    let (lo_i, hi_i, lo_j, hi_j) = (lo_i as i64, hi_i as i64, lo_j as i64, hi_j as i64);
    let mut cells: Vec<(i64, i64, i64)> = Vec::new();
    for j in lo_j..=hi_j {
        for i in lo_i..=hi_i {
            cells.push((i * i + j * j, j, i));
        }
    }
    cells.sort_unstable();
    let mut out = Vec::with_capacity(n);
    for (_, j, i) in cells {
        let (x, y) = (centre.0 + spacing * i as f64, centre.1 + spacing * j as f64);
        if x - margin > bounds[0]
            && x + margin < bounds[2]
            && y - margin > bounds[1]
            && y + margin < bounds[3]
            && ok(x, y)
        {
            out.push((x, y));
            if out.len() == n {
                return Some(out);
            }
        }
    }
    None
}
