//! Where robots start: a square grid around `robots.start`, derived from the count, so
//! changing `robots.count` alone gives a valid layout.

use crate::config::Config;

impl Config {
    /// Start positions: see [`Config::start_poses`].
    pub fn start_positions(&self, clear: impl Fn(f64, f64) -> bool) -> Option<Vec<(f64, f64)>> {
        self.start_poses(clear)
            .map(|p| p.into_iter().map(|(x, y, _)| (x, y)).collect())
    }

    /// Start poses `(x, y, heading)`: for each start group, its robots' share of the points of
    /// a square grid of `start.spacing` nearest to the group's centre that lie inside the
    /// bounds, satisfy `clear` (the world passes its obstacle clearance) and are not taken by
    /// an earlier group; so any count that fits the map gives a valid layout. With
    /// `start.jitter` / `start.heading_jitter_deg`, each robot is then moved off its point by a
    /// uniform draw from the seed's `start` stream (a draw that is not `clear` is retried, up to
    /// 32 times, then the grid point is kept). `None` when the map has no room for that many.
    pub fn start_poses(&self, clear: impl Fn(f64, f64) -> bool) -> Option<Vec<(f64, f64, f64)>> {
        if !self.robots.start.path.is_empty() {
            let poses = self.path_poses();
            return poses.iter().all(|p| clear(p.0, p.1)).then_some(poses);
        }
        let r = &self.robots;
        let n = r.count as usize;
        let groups = self.start_group_count();
        let mut poses: Vec<(f64, f64, f64)> = Vec::with_capacity(n);
        for g in 0..groups {
            let members = (0..n).filter(|&i| self.start_group(i as u32) == g).count();
            let (centre, _) = self.start_group_centre(g);
            let taken = poses.clone();
            let min_gap = r.start.spacing * 0.999;
            let ok = |x: f64, y: f64| {
                clear(x, y)
                    && taken
                        .iter()
                        .all(|p| (p.0 - x).powi(2) + (p.1 - y).powi(2) >= min_gap * min_gap)
            };
            if r.start.scatter > 0.0 {
                let mut rng = crate::rng::stream(self.scenario.seed, "start_scatter", g as u64);
                let points = self.scatter(members, centre, &mut rng, &ok)?;
                let heading = self.nominal_heading(poses.len() as u32);
                poses.extend(points.into_iter().map(|(x, y)| (x, y, heading)));
                continue;
            }
            let points = nearest_grid_points(
                members,
                centre,
                r.start.spacing,
                self.map.bounds,
                r.radius,
                ok,
            )?;
            let heading = self.nominal_heading(poses.len() as u32);
            poses.extend(points.into_iter().map(|(x, y)| (x, y, heading)));
        }
        let s = &r.start;
        if s.jitter > 0.0 || s.heading_jitter_deg > 0.0 {
            use rand::Rng as _;
            for (i, p) in poses.iter_mut().enumerate() {
                let mut rng = crate::rng::stream(self.scenario.seed, "start", i as u64);
                if s.jitter > 0.0 {
                    for _ in 0..32 {
                        let x = p.0 + rng.random_range(-s.jitter..=s.jitter);
                        let y = p.1 + rng.random_range(-s.jitter..=s.jitter);
                        if self.inside_bounds(x, y, r.radius) && clear(x, y) {
                            (p.0, p.1) = (x, y);
                            break;
                        }
                    }
                }
                if s.heading_jitter_deg > 0.0 {
                    let h = s.heading_jitter_deg.to_radians();
                    p.2 = crate::wrap_angle(p.2 + rng.random_range(-h..=h));
                }
            }
        }
        Some(poses)
    }

    /// A chain along `robots.start.path`: robot `i` at arc length `i * spacing` from the
    /// first point, facing back along the path (towards robot `i - 1`; the head towards the
    /// first point's side). Points beyond the path's end stay at its last point (validation
    /// refuses a path too short for the count).
    pub fn path_poses(&self) -> Vec<(f64, f64, f64)> {
        let path = &self.robots.start.path;
        let spacing = self.robots.start.spacing;
        (0..self.robots.count as usize)
            .map(|i| {
                let (x, y, along) = point_at(path, i as f64 * spacing);
                (x, y, crate::wrap_angle(along + std::f64::consts::PI))
            })
            .collect()
    }

    /// Two robots of `robots.start.path` that would start overlapping (bodies closer than
    /// `2 * radius`), the first such pair by ids.
    pub fn path_overlap(&self) -> Option<(u32, u32)> {
        let poses = self.path_poses();
        let min = 2.0 * self.robots.radius;
        for (a, p) in poses.iter().enumerate() {
            for (b, q) in poses.iter().enumerate().skip(a + 1) {
                if (p.0 - q.0).powi(2) + (p.1 - q.1).powi(2) < min * min {
                    return Some((a as u32, b as u32));
                }
            }
        }
        None
    }

    /// Initial heading of every robot, radians (`robots.start.heading_deg`).
    pub fn start_heading(&self) -> f64 {
        self.robots.start.heading_deg.to_radians()
    }

    /// Number of start groups (one when `robots.start.groups` is empty).
    pub fn start_group_count(&self) -> usize {
        self.robots.start.groups.len().max(1)
    }

    /// The start group of robot `id`: contiguous blocks of ids, of `start.group_sizes` or
    /// else sizes differing by at most one.
    pub fn start_group(&self, id: u32) -> usize {
        let sizes = &self.robots.start.group_sizes;
        if !sizes.is_empty() {
            let mut end = 0u64;
            for (g, &size) in sizes.iter().enumerate() {
                end += size as u64;
                if (id as u64) < end {
                    return g;
                }
            }
            return sizes.len() - 1;
        }
        let n = self.robots.count.max(1) as u64;
        let g = self.start_group_count() as u64;
        ((id as u64).min(n - 1) * g / n) as usize
    }

    /// The heading robot `id` is meant to start with, before any `heading_jitter_deg`:
    /// what a robot that can only count its own wheel turns takes as its initial heading.
    pub fn nominal_heading(&self, id: u32) -> f64 {
        if !self.robots.start.path.is_empty() {
            return self.path_poses().get(id as usize).map_or(0.0, |p| p.2);
        }
        let (_, heading) = self.start_group_centre(self.start_group(id));
        crate::wrap_angle(heading.to_radians())
    }

    /// The goal robot `id` seeks: its start group's own `goal`, else `map.goal`.
    pub fn goal_of(&self, id: u32) -> crate::Goal {
        let g = self.map.goal;
        let group = self.robots.start.groups.get(self.start_group(id));
        let mut goal = match group.and_then(|s| s.goal) {
            Some([x, y]) => crate::Goal { x, y, ..g },
            None => g,
        };
        if self.robots.aerial.is_some() {
            // Two UAVs cannot hover in one cell: each member of a group gets its own slot.
            if let Some((x, y)) = self.aerial_goal_slot(id) {
                (goal.x, goal.y) = (x, y);
            }
            goal.z = Some(
                group
                    .and_then(|s| s.goal_z)
                    .or(g.z)
                    .unwrap_or(self.start_z(id)),
            );
        }
        goal
    }

    /// An aerial robot's own goal point when its start group has several members: the group's
    /// goal points laid out like a start group ([`nearest_grid_points`], nearest the group's
    /// goal first) but twice `robots.start.spacing` apart, kept that far from the slots of
    /// the groups before it and from every other group's goal, and clear of obstacles at the
    /// goal's height. Twice: a hovering UAV keeps a safe zone around it (seed 002's eq. 1, one
    /// start spacing in its configs), so the next slot must lie past it. A group's first member
    /// keeps the goal itself when it is clear. `None` for a one-member group (unchanged), or
    /// when the slots do not fit the map (the planner's validation then names the shared goal).
    fn aerial_goal_slot(&self, id: u32) -> Option<(f64, f64)> {
        let n = self.robots.count;
        let mine = self.start_group(id);
        let members = |g: usize| (0..n).filter(move |&i| self.start_group(i) == g);
        if members(mine).count() < 2 {
            return None;
        }
        let spacing = 2.0 * self.robots.start.spacing;
        let min_gap = spacing * 0.999;
        let centre_of = |g: usize| match self.robots.start.groups.get(g).and_then(|s| s.goal) {
            Some([x, y]) => (x, y),
            None => (self.map.goal.x, self.map.goal.y),
        };
        let groups = self.start_group_count();
        let mut taken: Vec<(f64, f64)> = Vec::new();
        for g in 0..=mine {
            let ids: Vec<u32> = members(g).collect();
            let centre = centre_of(g);
            // Every other group's own goal stays its first member's; earlier groups' slots
            // are taken.
            let mut before = taken.clone();
            before.extend(
                (0..groups)
                    .filter(|&o| o != g && members(o).next().is_some())
                    .map(centre_of)
                    .filter(|&c| c != centre),
            );
            let z = self.robots.start.groups.get(g).and_then(|s| s.goal_z);
            let z = z.or(self.map.goal.z).unwrap_or(self.start_z(ids[0]));
            let ok = |x: f64, y: f64| {
                self.clear_of_obstacles(x, y, z)
                    && before
                        .iter()
                        .all(|p| (p.0 - x).powi(2) + (p.1 - y).powi(2) >= min_gap * min_gap)
            };
            let points = nearest_grid_points(
                ids.len(),
                centre,
                spacing,
                self.map.bounds,
                self.robots.radius,
                ok,
            )?;
            if g == mine {
                let k = ids.iter().position(|&i| i == id)?;
                return points.get(k).copied();
            }
            taken.extend(points);
        }
        None
    }

    /// Whether a robot at `(x, y)` and height `z` stays more than `robots.radius` clear of every
    /// obstacle (each a prism from the ground to its height, or to `map.height`).
    fn clear_of_obstacles(&self, x: f64, y: f64, z: f64) -> bool {
        let r = self.robots.radius;
        let top = self.map.height.unwrap_or(f64::INFINITY);
        let below = |h: Option<f64>| z < h.unwrap_or(top).min(top) + r;
        let circles = self
            .map
            .circles
            .iter()
            .all(|c| !below(c.height) || (c.x - x).hypot(c.y - y) > c.r + r);
        let rects = self.map.rectangles.iter().all(|b| {
            let dx = (b.x_min - x).max(x - b.x_max).max(0.0);
            let dy = (b.y_min - y).max(y - b.y_max).max(0.0);
            !below(b.height) || dx.hypot(dy) > r
        });
        let polygons = self
            .map
            .polygons
            .iter()
            .all(|poly| !below(poly.height) || !point_near_polygon(&poly.points, (x, y), r));
        circles && rects && polygons
    }

    /// The height robot `id` starts at: 0 for ground robots; for aerial ones its start
    /// group's `z`, else `robots.aerial.start_z`.
    pub fn start_z(&self, id: u32) -> f64 {
        let Some(aerial) = self.robots.aerial else {
            return 0.0;
        };
        self.robots
            .start
            .groups
            .get(self.start_group(id))
            .and_then(|s| s.z)
            .unwrap_or(aerial.start_z)
    }

    /// Every goal of the run: `map.goal` (when some robot seeks it) and each group's own.
    pub fn goals(&self) -> Vec<crate::Goal> {
        let mut out: Vec<crate::Goal> = Vec::new();
        for id in 0..self.robots.count.max(1) {
            let g = self.goal_of(id);
            if !out.contains(&g) {
                out.push(g);
            }
        }
        out
    }

    /// `n` points drawn uniformly in the disc of `robots.start.scatter` around `centre`, inside
    /// the bounds, accepted by `ok`, `spacing` apart and no three within [`MIN_TRIANGLE_HEIGHT`]
    /// of one line; each point gets up to 10,000 draws. `None` when the disc has no room.
    fn scatter(
        &self,
        n: usize,
        centre: (f64, f64),
        rng: &mut crate::rng::Rng,
        ok: &impl Fn(f64, f64) -> bool,
    ) -> Option<Vec<(f64, f64)>> {
        use rand::Rng as _;
        let (radius, gap) = (self.robots.start.scatter, self.robots.start.spacing);
        let mut out: Vec<(f64, f64)> = Vec::with_capacity(n);
        for _ in 0..n {
            let mut placed = false;
            for _ in 0..10_000 {
                let (d, a) = (
                    radius * rng.random::<f64>().sqrt(),
                    rng.random_range(-std::f64::consts::PI..std::f64::consts::PI),
                );
                let (x, y) = (centre.0 + d * a.cos(), centre.1 + d * a.sin());
                let apart = out
                    .iter()
                    .all(|p| (p.0 - x).powi(2) + (p.1 - y).powi(2) >= gap * gap);
                if apart
                    && self.inside_bounds(x, y, self.robots.radius)
                    && ok(x, y)
                    && !collinear_with(&out, (x, y))
                {
                    out.push((x, y));
                    placed = true;
                    break;
                }
            }
            if !placed {
                return None;
            }
        }
        Some(out)
    }

    /// Centre and heading (degrees) of start group `g`.
    fn start_group_centre(&self, g: usize) -> ((f64, f64), f64) {
        let s = &self.robots.start;
        match s.groups.get(g) {
            Some(grp) => ((grp.x, grp.y), grp.heading_deg.unwrap_or(s.heading_deg)),
            None => ((s.x.unwrap_or(0.0), s.y.unwrap_or(0.0)), s.heading_deg),
        }
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

/// Whether `p` is inside the polygon `pts` (even-odd rule) or at most `margin` from an edge.
fn point_near_polygon(pts: &[[f64; 2]], p: (f64, f64), margin: f64) -> bool {
    let n = pts.len();
    let mut inside = false;
    for i in 0..n {
        let (a, b) = (pts[i], pts[(i + 1) % n]);
        if (a[1] > p.1) != (b[1] > p.1) {
            let x = a[0] + (p.1 - a[1]) / (b[1] - a[1]) * (b[0] - a[0]);
            if p.0 < x {
                inside = !inside;
            }
        }
        let (ex, ey) = (b[0] - a[0], b[1] - a[1]);
        let len2 = ex * ex + ey * ey;
        let t = if len2 > 0.0 {
            (((p.0 - a[0]) * ex + (p.1 - a[1]) * ey) / len2).clamp(0.0, 1.0)
        } else {
            0.0
        };
        if (a[0] + t * ex - p.0).hypot(a[1] + t * ey - p.1) <= margin {
            return true;
        }
    }
    inside
}

/// Metres a third robot must lie off the line through two others for the three not to count
/// as "on one line" (seed 001's leader choice assumes no three robots start collinear).
pub const MIN_TRIANGLE_HEIGHT: f64 = 0.05;

/// True when `p` and some two of `pts` are nearly on one line: the triangle's smallest height
/// (twice its area over its longest side) is under [`MIN_TRIANGLE_HEIGHT`].
pub fn collinear_with(pts: &[(f64, f64)], p: (f64, f64)) -> bool {
    let dist = |a: (f64, f64), b: (f64, f64)| ((a.0 - b.0).powi(2) + (a.1 - b.1).powi(2)).sqrt();
    for (i, a) in pts.iter().enumerate() {
        for b in &pts[i + 1..] {
            let area2 = ((b.0 - a.0) * (p.1 - a.1) - (b.1 - a.1) * (p.0 - a.0)).abs();
            let longest = dist(*a, *b).max(dist(*a, p)).max(dist(*b, p));
            if longest > 0.0 && area2 / longest < MIN_TRIANGLE_HEIGHT {
                return true;
            }
        }
    }
    false
}

/// Total length of a polyline.
pub fn polyline_length(path: &[[f64; 2]]) -> f64 {
    path.windows(2)
        .map(|w| (w[1][0] - w[0][0]).hypot(w[1][1] - w[0][1]))
        .sum()
}

/// The point at arc length `s` along `path` and the direction (radians) of the segment it
/// lies on, pointing away from the first point; past the end, the last point.
fn point_at(path: &[[f64; 2]], s: f64) -> (f64, f64, f64) {
    let mut left = s;
    let mut along = 0.0;
    for w in path.windows(2) {
        let (dx, dy) = (w[1][0] - w[0][0], w[1][1] - w[0][1]);
        let len = dx.hypot(dy);
        if len <= 0.0 {
            continue;
        }
        along = dy.atan2(dx);
        if left <= len {
            let f = left / len;
            return (w[0][0] + dx * f, w[0][1] + dy * f, along);
        }
        left -= len;
    }
    let last = path.last().copied().unwrap_or([0.0, 0.0]);
    (last[0], last[1], along)
}
