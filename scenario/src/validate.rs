//! Bounds checks: every value is checked before any process starts, and a failure names the
//! key and what was expected (with the bounds). Behaviours check their own `[behaviour]`
//! parameters with the same helpers.

pub use crate::bounds::{check, finite, range_f, range_u64, short};
use crate::config::Config;
use crate::error::KeyError;
use crate::hull::hull_shape;
use crate::limits::{MAX_NAME_BYTES, MAX_OBSTACLES, MAX_POLYGON_POINTS, MIN_POLYGON_AREA};
use crate::reference::{KEYS, check_f, check_u, hi, lo};

/// `v` within the bounds the config reference gives `key` (indices allowed).
fn f(key: &str, v: f64) -> Result<(), KeyError> {
    check_f(KEYS, key, v)
}

/// `v` within `[lower end the config reference gives key, ceiling]`.
fn below(key: &str, v: f64, ceiling: f64) -> Result<(), KeyError> {
    range_f(key, v, lo(KEYS, key), ceiling)
}

/// `v` within the bounds the config reference gives `key`, an integer.
fn u(key: &str, v: u64) -> Result<(), KeyError> {
    check_u(KEYS, key, v)
}

impl Config {
    /// Checks every value against its bounds; the error names the key and the bounds.
    /// `[behaviour]` is opaque here: the behaviour that owns it validates it.
    pub fn validate(&self) -> Result<(), KeyError> {
        let s = &self.scenario;
        check(!s.name.is_empty(), "scenario.name", "a non-empty name")?;
        check(
            s.name.len() <= MAX_NAME_BYTES,
            "scenario.name",
            &format!(
                "a name of at most {MAX_NAME_BYTES} bytes (it becomes a directory name), got {} bytes",
                s.name.len()
            ),
        )?;
        check(
            s.name
                .chars()
                .all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-'),
            "scenario.name",
            "letters, digits, '_' or '-' only (it becomes a directory name)",
        )?;
        u("scenario.ticks", s.ticks)?;
        f("scenario.dt", s.dt)?;
        u("scenario.deadline_ms", s.deadline_ms)?;
        u("scenario.stall_ticks", s.stall_ticks)?;
        range_u64(
            "scenario.unresponsive_ms",
            s.unresponsive_ms,
            s.deadline_ms,
            hi(KEYS, "scenario.unresponsive_ms") as u64,
        )?;

        let m = &self.map;
        for (i, v) in m.bounds.iter().enumerate() {
            f(&format!("map.bounds[{i}]"), *v)?;
        }
        check(
            m.bounds[2] > m.bounds[0] && m.bounds[3] > m.bounds[1],
            "map.bounds",
            "[min_x, min_y, max_x, max_y] with max > min",
        )?;
        finite("map.goal.x", m.goal.x)?;
        finite("map.goal.y", m.goal.y)?;
        f("map.goal.radius", m.goal.radius)?;
        check(
            self.inside_bounds(m.goal.x, m.goal.y, 0.0),
            "map.goal",
            "a goal inside map.bounds",
        )?;
        for (kind, n) in [
            ("circles", m.circles.len()),
            ("rectangles", m.rectangles.len()),
            ("polygons", m.polygons.len()),
        ] {
            check(
                n <= MAX_OBSTACLES,
                &format!("map.{kind}"),
                &format!("at most {MAX_OBSTACLES} {kind}, got {n}"),
            )?;
        }
        // Obstacles stay within MAX_COORD like the bounds: a rectangle from -1e308 to 1e308
        // is finite, but its width is not, and the map's BVH panics on it.
        for (i, c) in m.circles.iter().enumerate() {
            f(&format!("map.circles[{i}].x"), c.x)?;
            f(&format!("map.circles[{i}].y"), c.y)?;
            f(&format!("map.circles[{i}].r"), c.r)?;
        }
        for (i, r) in m.rectangles.iter().enumerate() {
            for (k, v) in [
                ("x_min", r.x_min),
                ("y_min", r.y_min),
                ("x_max", r.x_max),
                ("y_max", r.y_max),
            ] {
                f(&format!("map.rectangles[{i}].{k}"), v)?;
            }
            check(
                r.x_max > r.x_min && r.y_max > r.y_min,
                &format!("map.rectangles[{i}]"),
                "x_max > x_min and y_max > y_min",
            )?;
        }
        for (i, p) in m.polygons.iter().enumerate() {
            let key = format!("map.polygons[{i}].points");
            check(
                (3..=MAX_POLYGON_POINTS).contains(&p.points.len()),
                &key,
                &format!(
                    "3 to {MAX_POLYGON_POINTS} points [x, y], got {}",
                    p.points.len()
                ),
            )?;
            for (j, pt) in p.points.iter().enumerate() {
                for (k, v) in pt.iter().enumerate() {
                    f(&format!("{key}[{j}][{k}]"), *v)?;
                }
            }
            polygon_area(&key, &p.points)?;
        }

        let r = &self.robots;
        u("robots.count", r.count as u64)?;
        crate::program::validate(self)?;
        u("ipc.observers", self.ipc.observers as u64)?;
        f("robots.radius", r.radius)?;
        f("robots.max_speed", r.max_speed)?;
        f("robots.max_turn_rate", r.max_turn_rate)?;
        let st = &r.start;
        check(
            !st.groups.is_empty() || st.group_sizes.is_empty(),
            "robots.start.group_sizes",
            "no sizes without robots.start.groups",
        )?;
        if !st.path.is_empty() {
            self.validate_path()?;
        } else if st.groups.is_empty() {
            for (key, v) in [("robots.start.x", st.x), ("robots.start.y", st.y)] {
                let v = v.ok_or_else(|| {
                    (
                        key.to_string(),
                        "expected a number (the centre of the start grid), or robots.start.groups"
                            .to_string(),
                    )
                })?;
                f(key, v)?;
            }
        } else {
            check(
                st.x.is_none() && st.y.is_none(),
                "robots.start.x",
                "either robots.start.x/y (one grid) or robots.start.groups (one grid per group), not both",
            )?;
            check(
                st.groups.len() <= r.count as usize,
                "robots.start.groups",
                &format!("at most robots.count = {} groups", r.count),
            )?;
            if !st.group_sizes.is_empty() {
                let sum: u64 = st.group_sizes.iter().map(|&s| s as u64).sum();
                check(
                    st.group_sizes.len() == st.groups.len()
                        && sum == r.count as u64
                        && st.group_sizes.iter().all(|&s| s > 0),
                    "robots.start.group_sizes",
                    &format!(
                        "one positive size per start group ({}) summing to robots.count = {}, got {:?}",
                        st.groups.len(),
                        r.count,
                        st.group_sizes
                    ),
                )?;
            }
            for (i, g) in st.groups.iter().enumerate() {
                f(&format!("robots.start.groups[{i}].x"), g.x)?;
                f(&format!("robots.start.groups[{i}].y"), g.y)?;
                if let Some(h) = g.heading_deg {
                    finite(&format!("robots.start.groups[{i}].heading_deg"), h)?;
                }
                if let Some([x, y]) = g.goal {
                    self.check_point(&format!("robots.start.groups[{i}].goal"), x, y)?;
                }
            }
        }
        // At most half the gap between neighbouring bodies, so robots never start overlapping
        // (with a hair of slack so (0.3 - 0.1) / 2 admits 0.1).
        let max_jitter = ((st.spacing - 2.0 * r.radius) / 2.0).max(0.0);
        check(
            st.jitter.is_finite() && st.jitter >= 0.0 && st.jitter <= max_jitter + 1e-9,
            "robots.start.jitter",
            &format!(
                "a number in [0, {}] ((spacing - 2 * radius) / 2, so robots never start \
                 overlapping), got {}",
                short((max_jitter * 1e9).round() / 1e9),
                short(st.jitter)
            ),
        )?;
        f("robots.start.scatter", st.scatter)?;
        f("robots.start.heading_jitter_deg", st.heading_jitter_deg)?;
        let max_spacing = hi(KEYS, "robots.start.spacing");
        range_f("robots.start.spacing", r.start.spacing, 2.0 * r.radius + 1e-6, max_spacing)
            .map_err(|(k, _)| {
                (
                    k,
                    format!(
                        "a value above 2 * robots.radius = {} so robots do not start overlapping, got {}",
                        2.0 * r.radius,
                        short(r.start.spacing)
                    ),
                )
            })?;
        finite("robots.start.heading_deg", r.start.heading_deg)?;
        u("robots.lidar.rays", r.lidar.rays as u64)?;
        f("robots.lidar.fov_deg", r.lidar.fov_deg)?;
        if !r.lidar.angles_deg.is_empty() {
            check(
                r.lidar.rays as usize == r.lidar.angles_deg.len(),
                "robots.lidar.rays",
                &format!(
                    "{} (the number of robots.lidar.angles_deg), got {}",
                    r.lidar.angles_deg.len(),
                    r.lidar.rays
                ),
            )?;
            for (k, a) in r.lidar.angles_deg.iter().enumerate() {
                f(&format!("robots.lidar.angles_deg[{k}]"), *a)?;
            }
        }
        f("robots.lidar.range", r.lidar.range)?;
        f("robots.range_bearing.range", r.range_bearing.range)?;
        f("robots.goal_sensor.range", r.goal_sensor.range)?;
        f("robots.goal_sensor.fov_deg", r.goal_sensor.fov_deg)?;
        f("robots.noise.pose", r.noise.pose)?;
        f("robots.noise.heading", r.noise.heading)?;
        f("robots.noise.lidar", r.noise.lidar)?;
        f("robots.noise.wheel_slip", r.noise.wheel_slip)?;

        let q = &self.radio;
        f("radio.range", q.range)?;
        f("radio.loss", q.loss)?;
        f("radio.ge_p", q.ge_p)?;
        f("radio.ge_r", q.ge_r)?;
        f("radio.ge_loss_good", q.ge_loss_good)?;
        f("radio.ge_loss_bad", q.ge_loss_bad)?;
        u("radio.delay_ticks", q.delay_ticks as u64)?;
        u("radio.jitter_ticks", q.jitter_ticks as u64)?;
        u("radio.capacity", q.capacity as u64)?;
        u("radio.rounds", q.rounds as u64)?;
        if q.rounds > 0 {
            check(
                q.delay_ticks == 0 && q.jitter_ticks == 0,
                "radio.rounds",
                &format!(
                    "0 while radio.delay_ticks or radio.jitter_ticks is set (got delay_ticks = {}, \
                     jitter_ticks = {}): a frame that takes ticks cannot also arrive within one",
                    q.delay_ticks, q.jitter_ticks
                ),
            )?;
            check(
                self.robots.program.is_empty() && self.robots.programs.is_empty(),
                "radio.rounds",
                "0 with robots.program or robots.programs: only the built-in robot answers \
                 propagation rounds so far",
            )?;
        }

        self.validate_heights()?;
        self.faults.validate(self.robots.count)?;

        if let Some(c) = &self.consensus {
            c.validate(&crate::consensus::Around {
                delay_ticks: self.radio.delay_ticks as u64,
                jitter_ticks: self.radio.jitter_ticks as u64,
                bounds: self.map.bounds,
                max_speed: self.robots.max_speed,
            })?;
        }

        Ok(())
    }

    /// `[x, y]` at `key` is a finite point inside the bounds.
    fn check_point(&self, key: &str, x: f64, y: f64) -> Result<(), KeyError> {
        finite(key, x)?;
        finite(key, y)?;
        check(
            self.inside_bounds(x, y, 0.0),
            key,
            &format!(
                "a point inside map.bounds, got [{}, {}]",
                short(x),
                short(y)
            ),
        )
    }

    /// `robots.start.path`: alone (no grid centre, groups or scatter), at least two points
    /// inside the bounds, long enough for the chain, and no two robots overlapping on it.
    fn validate_path(&self) -> Result<(), KeyError> {
        let st = &self.robots.start;
        check(
            st.x.is_none() && st.y.is_none() && st.groups.is_empty() && st.scatter == 0.0,
            "robots.start.path",
            "either robots.start.path (a chain) or robots.start.x/y, groups or scatter, not both",
        )?;
        check(
            st.path.len() >= 2,
            "robots.start.path",
            &format!("at least two points [x, y], got {}", st.path.len()),
        )?;
        for (i, &[x, y]) in st.path.iter().enumerate() {
            self.check_point(&format!("robots.start.path[{i}]"), x, y)?;
        }
        let need = (self.robots.count.max(1) - 1) as f64 * st.spacing;
        let have = crate::layout::polyline_length(&st.path);
        check(
            have + 1e-9 >= need,
            "robots.start.path",
            &format!(
                "a polyline at least (robots.count - 1) * spacing = {} m long, got {} m",
                short((need * 1e9).round() / 1e9),
                short((have * 1e9).round() / 1e9)
            ),
        )?;
        if let Some((a, b)) = self.path_overlap() {
            return Err((
                "robots.start.path".to_string(),
                format!(
                    "a path on which robots do not overlap, but robots {a} and {b} start closer \
                     than 2 * robots.radius (bends too sharp for this spacing)"
                ),
            ));
        }
        Ok(())
    }

    /// Obstacle heights, the ceiling and, for aerial robots, their limits and every start and
    /// goal height inside `[0, map.height]`.
    fn validate_heights(&self) -> Result<(), KeyError> {
        let m = &self.map;
        let heights = (m.circles.iter().map(|c| ("circles", c.height)))
            .chain(m.rectangles.iter().map(|r| ("rectangles", r.height)))
            .chain(m.polygons.iter().map(|p| ("polygons", p.height)));
        let mut index = std::collections::BTreeMap::<&str, usize>::new();
        for (kind, h) in heights {
            let i = index.entry(kind).or_default();
            if let Some(h) = h {
                f(&format!("map.{kind}[{i}].height"), h)?;
            }
            *i += 1;
        }
        if let Some(h) = m.height {
            f("map.height", h)?;
        }
        let Some(aerial) = &self.robots.aerial else {
            return Ok(());
        };
        let ceiling = m.height.ok_or_else(|| {
            (
                "map.height".to_string(),
                "a ceiling in metres (required with [robots.aerial])".to_string(),
            )
        })?;
        f(
            "robots.aerial.max_vertical_speed",
            aerial.max_vertical_speed,
        )?;
        below("robots.aerial.start_z", aerial.start_z, ceiling)?;
        if let Some(z) = m.goal.z {
            below("map.goal.z", z, ceiling)?;
        }
        for (i, g) in self.robots.start.groups.iter().enumerate() {
            if let Some(z) = g.z {
                below(&format!("robots.start.groups[{i}].z"), z, ceiling)?;
            }
            if let Some(z) = g.goal_z {
                below(&format!("robots.start.groups[{i}].goal_z"), z, ceiling)?;
            }
        }
        Ok(())
    }

    pub(crate) fn inside_bounds(&self, x: f64, y: f64, margin: f64) -> bool {
        let b = &self.map.bounds;
        x - margin > b[0] && x + margin < b[2] && y - margin > b[1] && y + margin < b[3]
    }
}

/// The polygon at `key` has at least 3 distinct points, not all on one line, whose convex
/// hull (the obstacle the world builds) has at least [`MIN_POLYGON_AREA`] m².
fn polygon_area(key: &str, points: &[[f64; 2]]) -> Result<(), KeyError> {
    let hull = hull_shape(points);
    let got = if hull.distinct < 3 {
        format!(
            "{} distinct of its {} points (the others repeat them)",
            hull.distinct,
            points.len()
        )
    } else if hull.vertices < 3 {
        format!("its {} distinct points on one line", hull.distinct)
    } else if hull.area < MIN_POLYGON_AREA {
        format!("an area of {} m²", short(hull.area))
    } else {
        return Ok(());
    };
    Err((
        key.to_string(),
        format!(
            "expected a polygon of at least 3 distinct points, not all on one line, whose \
             convex hull has an area of at least {MIN_POLYGON_AREA:e} m², got {got}"
        ),
    ))
}
