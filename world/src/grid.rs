//! A uniform spatial hash over robot positions, rebuilt each tick, so neighbour, lidar and
//! collision queries cost O(N) per tick instead of O(N^2) (10,000 robots in-process).

/// Robots bucketed by cell.
pub struct Grid {
    cell: f64,
    origin: (f64, f64),
    cols: usize,
    rows: usize,
    starts: Vec<u32>,
    items: Vec<u32>,
    /// `points[items[k]]` for each `k`: queries scan these contiguously instead of looking
    /// each index up in the caller's scattered data.
    item_points: Vec<(f64, f64)>,
    /// Scratch for [`Grid::rebuild`], kept to reuse its allocation.
    fill: Vec<u32>,
}

impl Default for Grid {
    /// A grid holding nothing (one empty cell), to [`Grid::rebuild`] later.
    fn default() -> Self {
        Grid {
            cell: 1.0,
            origin: (0.0, 0.0),
            cols: 1,
            rows: 1,
            starts: vec![0, 0],
            items: Vec::new(),
            item_points: Vec::new(),
            fill: Vec::new(),
        }
    }
}

impl Grid {
    /// Buckets `points` into square cells of side `cell` (clamped to a sane minimum).
    pub fn build(points: &[(f64, f64)], cell: f64) -> Grid {
        let mut grid = Grid::default();
        grid.rebuild(points, cell, |_| true);
        grid
    }

    /// Buckets again, in place (reusing the allocations), the points `i` for which `keep(i)`
    /// holds; queries then report indices into `points`. The bounds of the grid are those of
    /// the kept points only, so a point left out (say, one at infinity) cannot stretch it.
    pub fn rebuild(&mut self, points: &[(f64, f64)], cell: f64, keep: impl Fn(usize) -> bool) {
        let cell = cell.max(1e-3);
        let kept = || {
            points
                .iter()
                .enumerate()
                .filter(|&(i, _)| keep(i))
                .map(|(_, p)| p)
        };
        let (mut x0, mut y0, mut x1, mut y1) = (0.0f64, 0.0f64, 0.0f64, 0.0f64);
        if let Some(&(x, y)) = kept().next() {
            (x0, y0, x1, y1) = (x, y, x, y);
        }
        for &(x, y) in kept() {
            x0 = x0.min(x);
            y0 = y0.min(y);
            x1 = x1.max(x);
            y1 = y1.max(y);
        }
        // Cap the grid size so a huge sparse map cannot allocate unbounded memory.
        let max_side = 4096.0;
        let cell = cell.max((x1 - x0) / max_side).max((y1 - y0) / max_side);
        let cols = ((x1 - x0) / cell) as usize + 1;
        let rows = ((y1 - y0) / cell) as usize + 1;
        let idx = |p: &(f64, f64)| -> usize {
            let c = (((p.0 - x0) / cell) as usize).min(cols - 1);
            let r = (((p.1 - y0) / cell) as usize).min(rows - 1);
            r * cols + c
        };
        let counts = &mut self.starts;
        counts.clear();
        counts.resize(cols * rows + 1, 0);
        let mut len = 0;
        for p in kept() {
            counts[idx(p) + 1] += 1;
            len += 1;
        }
        for i in 1..counts.len() {
            counts[i] += counts[i - 1];
        }
        self.fill.clear();
        self.fill.extend_from_slice(counts);
        self.items.clear();
        self.items.resize(len, 0);
        self.item_points.clear();
        self.item_points.resize(len, (0.0, 0.0));
        for (i, p) in points.iter().enumerate() {
            if keep(i) {
                let k = idx(p);
                let at = self.fill[k] as usize;
                self.items[at] = i as u32;
                self.item_points[at] = *p;
                self.fill[k] += 1;
            }
        }
        self.cell = cell;
        self.origin = (x0, y0);
        self.cols = cols;
        self.rows = rows;
    }

    /// Calls `f` with every index in the grid, by cell, then insertion.
    pub fn each(&self, mut f: impl FnMut(usize)) {
        for &i in &self.items {
            f(i as usize);
        }
    }

    /// Calls `f` with every index whose cell overlaps the disc (`c`, `r`); the caller checks
    /// the exact distance. Order is by cell, then insertion: sort if order matters.
    pub fn near(&self, c: (f64, f64), r: f64, mut f: impl FnMut(usize)) {
        self.near_points(c, r, |i, _| f(i));
    }

    /// [`Grid::near`], with each index's point as given to [`Grid::rebuild`] (the same bits),
    /// read from the grid's own contiguous copy.
    pub fn near_points(&self, c: (f64, f64), r: f64, mut f: impl FnMut(usize, (f64, f64))) {
        let lo_c = ((c.0 - r - self.origin.0) / self.cell).floor();
        let hi_c = ((c.0 + r - self.origin.0) / self.cell).floor();
        let lo_r = ((c.1 - r - self.origin.1) / self.cell).floor();
        let hi_r = ((c.1 + r - self.origin.1) / self.cell).floor();
        if hi_c < 0.0 || hi_r < 0.0 || lo_c >= self.cols as f64 || lo_r >= self.rows as f64 {
            return;
        }
        let c0 = lo_c.max(0.0) as usize;
        let c1 = (hi_c as usize).min(self.cols - 1);
        let r0 = lo_r.max(0.0) as usize;
        let r1 = (hi_r as usize).min(self.rows - 1);
        // The cells c0..=c1 of a row are neighbours in `items`: one contiguous run per row,
        // in the same order as cell by cell.
        for row in r0..=r1 {
            let from = self.starts[row * self.cols + c0] as usize;
            let to = self.starts[row * self.cols + c1 + 1] as usize;
            for (&i, &p) in self.items[from..to].iter().zip(&self.item_points[from..to]) {
                f(i as usize, p);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn near_finds_exactly_what_brute_force_finds() {
        let pts: Vec<(f64, f64)> = (0..500)
            .map(|i| (((i * 37) % 101) as f64 * 0.3, ((i * 53) % 97) as f64 * 0.3))
            .collect();
        let g = Grid::build(&pts, 2.0);
        for (qi, q) in pts.iter().enumerate().step_by(7) {
            let mut got = vec![];
            g.near(*q, 2.5, |i| {
                let d = ((pts[i].0 - q.0).powi(2) + (pts[i].1 - q.1).powi(2)).sqrt();
                if d <= 2.5 {
                    got.push(i)
                }
            });
            got.sort();
            let want: Vec<usize> = (0..pts.len())
                .filter(|&i| ((pts[i].0 - q.0).powi(2) + (pts[i].1 - q.1).powi(2)).sqrt() <= 2.5)
                .collect();
            assert_eq!(got, want, "query {qi}");
        }
    }

    #[test]
    fn rebuild_in_place_keeps_only_the_kept_points() {
        let pts: Vec<(f64, f64)> = (0..300)
            .map(|i| (((i * 37) % 101) as f64 * 0.3, ((i * 53) % 97) as f64 * 0.3))
            .collect();
        let keep = |i: usize| !i.is_multiple_of(3);
        // Built over everything first, then again over a subset in the same allocations.
        let mut g = Grid::build(&pts, 1.0);
        g.rebuild(&pts, 2.0, keep);
        let mut all = vec![];
        g.each(|i| all.push(i));
        all.sort();
        let kept: Vec<usize> = (0..pts.len()).filter(|&i| keep(i)).collect();
        assert_eq!(all, kept);
        for q in pts.iter().step_by(5) {
            let mut got = vec![];
            g.near(*q, 2.5, |i| {
                if ((pts[i].0 - q.0).powi(2) + (pts[i].1 - q.1).powi(2)).sqrt() <= 2.5 {
                    got.push(i)
                }
            });
            got.sort();
            let want: Vec<usize> = kept
                .iter()
                .copied()
                .filter(|&i| ((pts[i].0 - q.0).powi(2) + (pts[i].1 - q.1).powi(2)).sqrt() <= 2.5)
                .collect();
            assert_eq!(got, want);
        }
        // Nothing kept: every query finds nothing.
        g.rebuild(&pts, 2.0, |_| false);
        g.near(pts[0], 100.0, |i| panic!("found {i} in an empty grid"));
        Grid::default().near((1.0, 1.0), 5.0, |i| panic!("found {i} in an empty grid"));
    }
}
