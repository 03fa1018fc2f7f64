//! The leader's own lidar map and the cheapest way through it (our addition for S4's maze,
//! opt-in with `behaviour.leader_nav = "map"`).
//!
//! The paper's groups cross a maze (section 3.2.4, Fig. 16) with no planner printed; local
//! avoidance (eq. 10-11) and the COG shift (Fig. 8) alone stall in dead ends. Here the leader
//! marks in a grid the walls its own range finder hits and steers the formation's centre along
//! the cheapest path to the goal through that grid, taking what it has not seen to be free
//! (the free-space assumption of navigation in unknown terrain): a dead end is entered only
//! until its walls are seen, then the path goes round. Cells nearer a wall than the formation
//! needs cost more, so the centre keeps its circle clear of walls where the way is wide enough.

use std::cmp::Reverse;
use std::collections::BinaryHeap;

use super::force::V2;

/// Scans that must hit a cell before it is a wall: one stray reading does not block a door.
const SEEN: u8 = 2;
/// Extra cost per metre of a cell with no clearance, over a free cell's 1 (scaled linearly
/// down to 0 at the clearance the formation needs).
const CROWDED: f64 = 10.0;

/// What the leader has seen of the arena: per cell, how many scans hit a wall in it.
#[derive(Debug, Clone)]
pub struct LidarMap {
    x0: f64,
    y0: f64,
    cell: f64,
    nx: usize,
    ny: usize,
    hits: Vec<u8>,
    /// Cells that have become walls so far: the clearance below is of this many.
    walls_seen: u64,
    /// The last clearance computed, for (its cap, `walls_seen` then): a robot asks several
    /// times between two new walls.
    clear: Vec<(f64, u64, Vec<f64>)>,
}

impl LidarMap {
    /// An empty map of the arena `bounds` ([x_min, y_min, x_max, y_max]) in square cells.
    pub fn new(bounds: [f64; 4], cell: f64) -> LidarMap {
        let [x0, y0, x1, y1] = bounds;
        let nx = (((x1 - x0) / cell).ceil() as usize).max(1);
        let ny = (((y1 - y0) / cell).ceil() as usize).max(1);
        LidarMap {
            x0,
            y0,
            cell,
            nx,
            ny,
            hits: vec![0; nx * ny],
            walls_seen: 0,
            clear: Vec::new(),
        }
    }

    fn index(&self, p: V2) -> Option<usize> {
        let (fx, fy) = ((p.x - self.x0) / self.cell, (p.y - self.y0) / self.cell);
        if fx < 0.0 || fy < 0.0 || fx >= self.nx as f64 || fy >= self.ny as f64 {
            return None;
        }
        Some(fy as usize * self.nx + fx as usize)
    }

    /// The cell nearest `p`, inside the arena.
    fn nearest(&self, p: V2) -> usize {
        let ix = ((p.x - self.x0) / self.cell).floor().clamp(0.0, (self.nx - 1) as f64) as usize;
        let iy = ((p.y - self.y0) / self.cell).floor().clamp(0.0, (self.ny - 1) as f64) as usize;
        iy * self.nx + ix
    }

    fn centre(&self, i: usize) -> V2 {
        let (ix, iy) = (i % self.nx, i / self.nx);
        V2::new(
            self.x0 + (ix as f64 + 0.5) * self.cell,
            self.y0 + (iy as f64 + 0.5) * self.cell,
        )
    }

    /// A wall hit at `p` (world frame) in this scan.
    pub fn hit(&mut self, p: V2) {
        if let Some(i) = self.index(p) {
            self.hits[i] = self.hits[i].saturating_add(1);
            if self.hits[i] == SEEN {
                self.walls_seen += 1;
            }
        }
    }

    /// Cell `i` is a wall.
    fn wall(&self, i: usize) -> bool {
        self.hits[i] >= SEEN
    }

    /// Cells known to be walls.
    #[cfg(test)]
    pub fn walls(&self) -> usize {
        (0..self.hits.len()).filter(|&i| self.wall(i)).count()
    }

    /// Per cell, the distance in metres to the nearest wall or arena edge, capped at `cap`
    /// (a two-pass chamfer transform with steps 1 and √2).
    /// The clearance capped at `cap`, brought up to date: its index in `self.clear`.
    fn clearance(&mut self, cap: f64) -> usize {
        let k = match self.clear.iter().position(|c| c.0 == cap) {
            Some(k) if self.clear[k].1 == self.walls_seen => return k,
            Some(k) => k,
            None => {
                self.clear.push((cap, 0, Vec::new()));
                self.clear.len() - 1
            }
        };
        let d = self.chamfer(cap);
        self.clear[k] = (cap, self.walls_seen, d);
        k
    }

    fn chamfer(&self, cap: f64) -> Vec<f64> {
        let (nx, ny, c) = (self.nx, self.ny, self.cell);
        let mut d: Vec<f64> = (0..nx * ny)
            .map(|i| {
                if self.wall(i) {
                    return 0.0;
                }
                let (ix, iy) = (i % nx, i / nx);
                // The edge is a wall just outside the first and last cells.
                let edge = (ix.min(nx - 1 - ix).min(iy).min(ny - 1 - iy) as f64 + 0.5) * c;
                edge.min(cap)
            })
            .collect();
        let diag = c * std::f64::consts::SQRT_2;
        let steps = [(-1i64, -1i64, diag), (0, -1, c), (1, -1, diag), (-1, 0, c)];
        let relax = |d: &mut Vec<f64>, ix: usize, iy: usize, sign: i64| {
            let i = iy * nx + ix;
            for &(dx, dy, w) in &steps {
                let (jx, jy) = (ix as i64 + sign * dx, iy as i64 + sign * dy);
                if jx >= 0 && jy >= 0 && (jx as usize) < nx && (jy as usize) < ny {
                    let j = jy as usize * nx + jx as usize;
                    if d[j] + w < d[i] {
                        d[i] = d[j] + w;
                    }
                }
            }
        };
        for iy in 0..ny {
            for ix in 0..nx {
                relax(&mut d, ix, iy, 1);
            }
        }
        for iy in (0..ny).rev() {
            for ix in (0..nx).rev() {
                relax(&mut d, ix, iy, -1);
            }
        }
        d
    }

    /// The cell centre nearest `p` within `within` metres with `need` metres of clearance,
    /// or `p` when there is none: where a circle of robots fits.
    pub fn roomy(&mut self, p: V2, need: f64, within: f64) -> V2 {
        let k = self.clearance(need);
        let clear = &self.clear[k].2;
        if self.index(p).is_some_and(|i| clear[i] >= need) {
            return p;
        }
        let reach = (within / self.cell).ceil() as i64;
        let c = self.nearest(p) as i64;
        let (cx, cy, nx) = (c % self.nx as i64, c / self.nx as i64, self.nx as i64);
        let mut best: Option<(f64, usize)> = None;
        for jy in (cy - reach).max(0)..=(cy + reach).min(self.ny as i64 - 1) {
            for jx in (cx - reach).max(0)..=(cx + reach).min(nx - 1) {
                let j = (jy * nx + jx) as usize;
                let d = (self.centre(j) - p).norm();
                if clear[j] >= need && d <= within && best.is_none_or(|b| d < b.0) {
                    best = Some((d, j));
                }
            }
        }
        best.map_or(p, |(_, j)| self.centre(j))
    }

    /// No wall is within `body` of the straight segment from `a` to `b` (as far as the map
    /// knows): the way is direct. `need` (at least `body`) names the clearance to read, so a
    /// robot that also asks for a way with it shares one.
    pub fn straight(&mut self, a: V2, b: V2, body: f64, need: f64) -> bool {
        let k = self.clearance(need.max(body));
        let n = ((b - a).norm() / (self.cell * 0.5)).ceil().max(1.0) as usize;
        (0..=n).all(|j| {
            self.index(a + (b - a) * (j as f64 / n as f64))
                .is_none_or(|i| self.clear[k].2[i] >= body)
        })
    }

    /// The cheapest path of cell centres from `start` to `goal` for a body that needs `need`
    /// metres from every wall and cannot come closer than `body`: each step costs its length
    /// times 1 + `CROWDED` × the share of `need` it lacks. None when walls close the way.
    pub fn route(&mut self, start: V2, goal: V2, need: f64, body: f64) -> Option<Vec<V2>> {
        let k = self.clearance(need);
        let clear = &self.clear[k].2;
        let (s, g) = (self.nearest(start), self.nearest(goal));
        let nx = self.nx as i64;
        let weight = |i: usize| 1.0 + CROWDED * ((need - clear[i]) / need).max(0.0);
        let gc = self.centre(g);
        let h = |i: usize| {
            let p = self.centre(i) - gc;
            let (a, b) = (p.x.abs().max(p.y.abs()), p.x.abs().min(p.y.abs()));
            a - b + b * std::f64::consts::SQRT_2
        };
        let mut cost = vec![f64::INFINITY; self.hits.len()];
        let mut from = vec![usize::MAX; self.hits.len()];
        let mut open = BinaryHeap::new();
        cost[s] = 0.0;
        open.push(Reverse((h(s).to_bits(), s)));
        while let Some(Reverse((f, i))) = open.pop() {
            if i == g {
                break;
            }
            if f64::from_bits(f) > cost[i] + h(i) + 1e-9 {
                continue;
            }
            let (ix, iy) = ((i as i64) % nx, (i as i64) / nx);
            for (dx, dy) in [(1, 0), (-1, 0), (0, 1), (0, -1), (1, 1), (1, -1), (-1, 1), (-1, -1)] {
                let (jx, jy) = (ix + dx, iy + dy);
                if jx < 0 || jy < 0 || jx >= nx || jy >= self.ny as i64 {
                    continue;
                }
                let j = (jy * nx + jx) as usize;
                // The start may sit too near a wall (a wall just seen): it may leave, not enter.
                if j != g && clear[j] < body && clear[j] <= clear[i] {
                    continue;
                }
                // No cutting a wall's corner diagonally.
                if dx != 0 && dy != 0 {
                    let (a, b) = ((iy * nx + jx) as usize, (jy * nx + ix) as usize);
                    if self.wall(a) || self.wall(b) {
                        continue;
                    }
                }
                let len = self.cell * if dx != 0 && dy != 0 { std::f64::consts::SQRT_2 } else { 1.0 };
                let c = cost[i] + len * 0.5 * (weight(i) + weight(j));
                if c < cost[j] {
                    cost[j] = c;
                    from[j] = i;
                    open.push(Reverse(((c + h(j)).to_bits(), j)));
                }
            }
        }
        if !cost[g].is_finite() {
            return None;
        }
        let mut path = vec![goal];
        let mut i = from[g];
        while i != usize::MAX && i != s {
            path.push(self.centre(i));
            i = from[i];
        }
        path.push(start);
        path.reverse();
        Some(path)
    }
}

/// The point `dist` metres along `path` (its end if shorter): where the centre heads next.
pub fn ahead(path: &[V2], dist: f64) -> V2 {
    let mut left = dist;
    for w in path.windows(2) {
        let seg = (w[1] - w[0]).norm();
        if seg >= left && seg > 0.0 {
            return w[0] + (w[1] - w[0]) * (left / seg);
        }
        left -= seg;
    }
    *path.last().expect("a path has its start")
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A 20 × 10 m arena with a wall at x = 10 from y = 0 to 7 (a door at its top, 3 m wide),
    /// seen twice.
    fn walled() -> LidarMap {
        let mut m = LidarMap::new([0.0, 0.0, 20.0, 10.0], 0.25);
        for _ in 0..SEEN {
            let mut y = 0.05;
            while y < 7.0 {
                m.hit(V2::new(10.1, y));
                y += 0.1;
            }
        }
        m
    }

    fn length(path: &[V2]) -> f64 {
        path.windows(2).map(|w| (w[1] - w[0]).norm()).sum()
    }

    #[test]
    fn the_way_goes_through_the_door_not_the_wall() {
        let mut m = walled();
        let path = m.route(V2::new(3.0, 2.0), V2::new(17.0, 2.0), 1.4, 0.25).unwrap();
        // Crossing x = 10 only above the wall's top, with room for the formation.
        for w in path.windows(2) {
            if (w[0].x - 10.1) * (w[1].x - 10.1) <= 0.0 {
                assert!(w[0].y > 7.5 && w[1].y > 7.5, "crossed at {:?}", w);
            }
        }
        // Round the wall, not straight (14 m).
        let l = length(&path);
        assert!(l > 16.0 && l < 22.0, "length {l}");
        assert_eq!(*path.first().unwrap(), V2::new(3.0, 2.0));
        assert_eq!(*path.last().unwrap(), V2::new(17.0, 2.0));
    }

    #[test]
    fn an_unseen_wall_is_taken_to_be_free() {
        let mut m = LidarMap::new([0.0, 0.0, 20.0, 10.0], 0.25);
        let path = m.route(V2::new(3.0, 5.0), V2::new(17.0, 5.0), 1.4, 0.25).unwrap();
        assert!(length(&path) < 14.5, "{}", length(&path));
        assert_eq!(m.walls(), 0);
    }

    #[test]
    fn one_stray_reading_is_not_a_wall() {
        let mut m = LidarMap::new([0.0, 0.0, 20.0, 10.0], 0.25);
        m.hit(V2::new(10.0, 5.0));
        assert_eq!(m.walls(), 0);
        m.hit(V2::new(10.0, 5.0));
        assert_eq!(m.walls(), 1);
    }

    #[test]
    fn a_closed_wall_leaves_no_way() {
        let mut m = LidarMap::new([0.0, 0.0, 20.0, 10.0], 0.25);
        for _ in 0..SEEN {
            let mut y = 0.05;
            while y < 10.0 {
                m.hit(V2::new(10.1, y));
                y += 0.1;
            }
        }
        assert!(m.route(V2::new(3.0, 5.0), V2::new(17.0, 5.0), 1.4, 0.25).is_none());
    }

    #[test]
    fn a_circle_centred_on_a_wall_moves_off_it() {
        let mut m = walled();
        // On the wall: moved to the nearest cell 1.4 m clear of it, within 2 m.
        let p = m.roomy(V2::new(10.0, 3.0), 1.4, 2.0);
        assert!((p.x - 10.1).abs() >= 1.4 && (p.x - 10.1).abs() < 2.0, "{p:?}");
        // In the open: left where it is.
        assert_eq!(m.roomy(V2::new(4.0, 5.0), 1.4, 2.0), V2::new(4.0, 5.0));
    }

    #[test]
    fn a_segment_through_a_wall_is_not_straight() {
        let mut m = walled();
        assert!(!m.straight(V2::new(8.0, 3.0), V2::new(12.0, 3.0), 0.25, 0.4));
        assert!(m.straight(V2::new(8.0, 9.0), V2::new(12.0, 9.0), 0.25, 0.4));
        // Passing 0.1 m over the wall's top is not straight for a body of 0.3 m.
        assert!(!m.straight(V2::new(8.0, 7.1), V2::new(12.0, 7.1), 0.3, 0.4));
    }

    #[test]
    fn ahead_walks_along_the_path() {
        let path = [V2::new(0.0, 0.0), V2::new(1.0, 0.0), V2::new(1.0, 2.0)];
        assert!((ahead(&path, 0.5) - V2::new(0.5, 0.0)).norm() < 1e-12);
        assert!((ahead(&path, 2.0) - V2::new(1.0, 1.0)).norm() < 1e-12);
        assert_eq!(ahead(&path, 10.0), V2::new(1.0, 2.0));
    }
}
