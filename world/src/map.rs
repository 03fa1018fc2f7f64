//! The static map: obstacles and walls built once into one parry2d [`Compound`] (its BVH is
//! the acceleration structure every ray cast and contact query goes through).
//!
//! This is the only module that speaks parry2d/nalgebra types; the rest of the world uses
//! plain `(f64, f64)` points.

use std::sync::atomic::{AtomicU64, Ordering};

use nalgebra::{Isometry2, Point2, Vector2};
use parry2d_f64::query::{PointQuery, Ray, RayCast};
use parry2d_f64::shape::{Compound, ConvexPolygon, SharedShape};
use swarmrt_scenario::MapConfig;

/// Thickness of the walls placed just outside the map bounds.
const WALL: f64 = 1.0;

/// Obstacles and walls of one map.
pub struct Map {
    obstacles: Compound,
    /// Height of each shape of `obstacles`, in order (walls and obstacles without a height
    /// are infinitely tall).
    heights: Vec<f64>,
    /// Whether some obstacle has a finite height (else the 3D clearance is the 2D one).
    any_height: bool,
    /// Lower bounds of [`Map::clearance`] over the map, for the questions a bound answers.
    bounds: ClearanceBounds,
}

/// A lower bound of the clearance per cell of a grid over the map bounds, worked out the first
/// time a point of the cell is asked about: the clearance at the cell's centre minus half its
/// diagonal (a distance moves by at most as much as the point does) and a margin far above
/// rounding. Most robots are far from every obstacle most of the time, so "is it nearer than
/// r?" is answered without a query of the compound (the kinematics' every sub-step asks).
struct ClearanceBounds {
    origin: (f64, f64),
    cell: f64,
    cols: usize,
    rows: usize,
    /// Per cell, the bound's bits, or [`UNKNOWN`] until asked (threads that race to fill a
    /// cell store the same value).
    cells: Vec<AtomicU64>,
}

/// Bits of a cell of [`ClearanceBounds`] not worked out yet (a NaN no bound can be).
const UNKNOWN: u64 = u64::MAX;
/// Side of a bound's cell, unless the map needs larger ones to stay within [`MAX_CELLS`].
const BOUND_CELL: f64 = 0.5;
/// Most cells of [`ClearanceBounds`] by area (8 MB of bounds); a side has at most ~1,024.
const MAX_CELLS: f64 = 1_048_576.0;
/// Metres taken off each bound beyond half the diagonal, for rounding in the clearance, the
/// cell arithmetic and parry's projections (all far below it at map scales).
const BOUND_MARGIN: f64 = 1e-6;

impl ClearanceBounds {
    fn new(cfg: &MapConfig) -> ClearanceBounds {
        let [x0, y0, x1, y1] = cfg.bounds;
        let (w, h) = (x1 - x0, y1 - y0);
        let usable = w.is_finite() && h.is_finite() && w > 0.0 && h > 0.0;
        if !usable {
            return ClearanceBounds {
                origin: (0.0, 0.0),
                cell: 1.0,
                cols: 0,
                rows: 0,
                cells: Vec::new(),
            };
        }
        // At most ~1,024 cells a side too, so a long thin map stays within the budget.
        let cell = BOUND_CELL
            .max((w * h / MAX_CELLS).sqrt())
            .max(w.max(h) / 1024.0);
        let cols = (w / cell).ceil() as usize + 1;
        let rows = (h / cell).ceil() as usize + 1;
        ClearanceBounds {
            origin: (x0, y0),
            cell,
            cols,
            rows,
            cells: (0..cols * rows).map(|_| AtomicU64::new(UNKNOWN)).collect(),
        }
    }

    /// A lower bound of `clearance(p)` (minus infinity outside the grid).
    fn at(&self, p: (f64, f64), clearance: impl FnOnce((f64, f64)) -> f64) -> f64 {
        let c = ((p.0 - self.origin.0) / self.cell).floor();
        let r = ((p.1 - self.origin.1) / self.cell).floor();
        // Also false for NaN.
        if !(c >= 0.0 && r >= 0.0 && c < self.cols as f64 && r < self.rows as f64) {
            return f64::NEG_INFINITY;
        }
        let (c, r) = (c as usize, r as usize);
        let slot = &self.cells[r * self.cols + c];
        let bits = slot.load(Ordering::Relaxed);
        if bits != UNKNOWN {
            return f64::from_bits(bits);
        }
        let centre = (
            self.origin.0 + (c as f64 + 0.5) * self.cell,
            self.origin.1 + (r as f64 + 0.5) * self.cell,
        );
        let half_diagonal = self.cell * std::f64::consts::FRAC_1_SQRT_2;
        let bound = clearance(centre) - half_diagonal - BOUND_MARGIN;
        slot.store(bound.to_bits(), Ordering::Relaxed);
        bound
    }
}

/// Why a map could not be built.
#[derive(Debug, Clone, PartialEq)]
pub struct MapError {
    /// Config key of the offending obstacle.
    pub key: String,
    /// What is wrong with it.
    pub message: String,
}

impl std::fmt::Display for MapError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        if self.key.is_empty() {
            f.write_str(&self.message)
        } else {
            write!(f, "key `{}`: {}", self.key, self.message)
        }
    }
}

impl std::error::Error for MapError {}

impl Map {
    /// Builds the compound once per run: bounds become four walls.
    pub fn build(cfg: &MapConfig) -> Result<Map, MapError> {
        let [x0, y0, x1, y1] = cfg.bounds;
        let (w, h) = (x1 - x0, y1 - y0);
        let mut shapes: Vec<(Isometry2<f64>, SharedShape)> = vec![
            // left, right, bottom, top walls, each overlapping the corners
            (
                Isometry2::translation(x0 - WALL / 2.0, y0 + h / 2.0),
                SharedShape::cuboid(WALL / 2.0, h / 2.0 + WALL),
            ),
            (
                Isometry2::translation(x1 + WALL / 2.0, y0 + h / 2.0),
                SharedShape::cuboid(WALL / 2.0, h / 2.0 + WALL),
            ),
            (
                Isometry2::translation(x0 + w / 2.0, y0 - WALL / 2.0),
                SharedShape::cuboid(w / 2.0 + WALL, WALL / 2.0),
            ),
            (
                Isometry2::translation(x0 + w / 2.0, y1 + WALL / 2.0),
                SharedShape::cuboid(w / 2.0 + WALL, WALL / 2.0),
            ),
        ];
        let mut heights = vec![f64::INFINITY; shapes.len()];
        let tall = |h: Option<f64>| h.unwrap_or(f64::INFINITY);
        for c in &cfg.circles {
            shapes.push((Isometry2::translation(c.x, c.y), SharedShape::ball(c.r)));
            heights.push(tall(c.height));
        }
        for r in &cfg.rectangles {
            shapes.push((
                Isometry2::translation((r.x_min + r.x_max) / 2.0, (r.y_min + r.y_max) / 2.0),
                SharedShape::cuboid((r.x_max - r.x_min) / 2.0, (r.y_max - r.y_min) / 2.0),
            ));
            heights.push(tall(r.height));
        }
        for (i, p) in cfg.polygons.iter().enumerate() {
            let points: Vec<Point2<f64>> =
                p.points.iter().map(|q| Point2::new(q[0], q[1])).collect();
            let poly = ConvexPolygon::from_convex_hull(&points).ok_or_else(|| MapError {
                key: format!("map.polygons[{i}].points"),
                message: "expected a polygon with non-zero area".to_string(),
            })?;
            shapes.push((Isometry2::identity(), SharedShape::new(poly)));
            heights.push(tall(p.height));
        }
        Ok(Map {
            bounds: ClearanceBounds::new(cfg),
            obstacles: Compound::new(shapes),
            any_height: heights.iter().any(|h| h.is_finite()),
            heights,
        })
    }

    /// Distance from the point `p` at height `z` to the nearest obstacle or wall, each a
    /// prism from the ground up to its height (0 when inside one). For aerial robots.
    pub fn clearance_3d(&self, p: (f64, f64), z: f64) -> f64 {
        if !self.any_height {
            return self.clearance(p);
        }
        let point = Point2::new(p.0, p.1);
        self.obstacles
            .shapes()
            .iter()
            .zip(&self.heights)
            .map(|((pose, shape), &h)| {
                let flat = shape.distance_to_point(pose, &point, true);
                let above = (z - h).max(0.0);
                (flat * flat + above * above).sqrt()
            })
            .fold(f64::INFINITY, f64::min)
    }

    /// Distance from `p` to the nearest obstacle or wall (0 when inside one).
    pub fn clearance(&self, p: (f64, f64)) -> f64 {
        self.obstacles
            .distance_to_point(&Isometry2::identity(), &Point2::new(p.0, p.1), true)
    }

    /// A lower bound of [`Map::clearance`] at `p`, cheap once its cell was asked about (minus
    /// infinity outside the map bounds). For a test that only needs to know the clearance is
    /// above some distance: when the bound is, the clearance is too.
    pub fn clearance_bound(&self, p: (f64, f64)) -> f64 {
        self.bounds.at(p, |q| self.clearance(q))
    }

    /// `clearance(p) < dist`, answered from [`Map::clearance_bound`] when it can be.
    pub fn nearer_than(&self, p: (f64, f64), dist: f64) -> bool {
        self.clearance_bound(p) < dist && self.clearance(p) < dist
    }

    /// Distance along the ray from `origin` in direction `angle` to the first obstacle, if any
    /// within `max_range`. A ray starting inside an obstacle hits at 0.
    pub fn cast(&self, origin: (f64, f64), angle: f64, max_range: f64) -> Option<f64> {
        self.cast_dir(origin, (angle.cos(), angle.sin()), max_range)
    }

    /// [`Map::cast`] along the unit direction `dir` = (cos, sin) of the angle, for a caller
    /// that has them already. A hit's distance does not depend on `max_range`, which only
    /// decides whether it counts: a shorter `max_range` prunes more of the tree.
    pub fn cast_dir(&self, origin: (f64, f64), dir: (f64, f64), max_range: f64) -> Option<f64> {
        let ray = Ray::new(Point2::new(origin.0, origin.1), Vector2::new(dir.0, dir.1));
        self.obstacles
            .cast_ray(&Isometry2::identity(), &ray, max_range, true)
    }

    /// True when an obstacle lies on the segment from `a` to `b`.
    pub fn blocks(&self, a: (f64, f64), b: (f64, f64)) -> bool {
        let (dx, dy) = (b.0 - a.0, b.1 - a.1);
        let d = (dx * dx + dy * dy).sqrt();
        if d == 0.0 {
            return false;
        }
        self.cast(a, dy.atan2(dx), d).is_some_and(|t| t < d)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use swarmrt_scenario::{CircleObstacle, Goal, PolygonObstacle, RectObstacle};

    fn map() -> Map {
        Map::build(&MapConfig {
            bounds: [0.0, 0.0, 10.0, 10.0],
            goal: Goal {
                x: 9.0,
                y: 9.0,
                radius: 0.5,
                z: None,
            },
            circles: vec![CircleObstacle {
                x: 5.0,
                y: 5.0,
                r: 1.0,
                height: None,
            }],
            rectangles: vec![RectObstacle {
                x_min: 1.0,
                y_min: 7.0,
                x_max: 2.0,
                y_max: 8.0,
                height: None,
            }],
            polygons: vec![PolygonObstacle {
                points: vec![[7.0, 1.0], [8.0, 1.0], [7.5, 2.0]],
                height: None,
            }],
            height: None,
        })
        .unwrap()
    }

    /// A 10 x 10 map with no obstacles.
    fn empty_map() -> MapConfig {
        MapConfig {
            bounds: [0.0, 0.0, 10.0, 10.0],
            goal: Goal {
                x: 1.0,
                y: 1.0,
                radius: 0.5,
                z: None,
            },
            circles: vec![],
            rectangles: vec![],
            polygons: vec![],
            height: None,
        }
    }

    #[test]
    fn an_aerial_robot_clears_a_low_obstacle_from_above() {
        let mut cfg = empty_map();
        cfg.rectangles.push(RectObstacle {
            x_min: 4.0,
            y_min: 4.0,
            x_max: 6.0,
            y_max: 6.0,
            height: Some(2.0),
        });
        let m = Map::build(&cfg).unwrap();
        assert_eq!(m.clearance_3d((5.0, 5.0), 1.0), 0.0);
        assert!((m.clearance_3d((5.0, 5.0), 2.5) - 0.5).abs() < 1e-9);
        // Diagonally off the top edge: sqrt(1^2 + 1^2).
        assert!((m.clearance_3d((7.0, 5.0), 3.0) - 2f64.sqrt()).abs() < 1e-9);
        // Walls are infinitely tall.
        assert!((m.clearance_3d((0.3, 8.0), 4.0) - 0.3).abs() < 1e-9);
        cfg.rectangles[0].height = None;
        let m = Map::build(&cfg).unwrap();
        assert_eq!(m.clearance_3d((5.0, 5.0), 4.0), 0.0);
    }

    #[test]
    fn ray_hits_circle_at_known_distance() {
        let t = map().cast((2.0, 5.0), 0.0, 10.0).unwrap();
        assert!((t - 2.0).abs() < 1e-9, "{t}");
    }

    #[test]
    fn ray_hits_wall_and_misses_beyond_range() {
        let m = map();
        let t = m.cast((2.0, 2.0), std::f64::consts::PI, 10.0).unwrap();
        assert!((t - 2.0).abs() < 1e-9, "{t}");
        assert_eq!(m.cast((2.0, 2.0), std::f64::consts::PI, 1.5), None);
    }

    #[test]
    fn clearance_to_rectangle_and_polygon() {
        let m = map();
        assert!((m.clearance((1.5, 6.5)) - 0.5).abs() < 1e-9);
        assert_eq!(m.clearance((7.5, 1.2)), 0.0);
        assert!((m.clearance((5.0, 3.0)) - 1.0).abs() < 1e-9);
    }

    #[test]
    fn line_of_sight_is_blocked_by_the_circle() {
        let m = map();
        assert!(m.blocks((3.0, 5.0), (7.0, 5.0)));
        assert!(!m.blocks((3.0, 3.0), (7.0, 3.0)));
    }

    #[test]
    fn degenerate_polygon_is_refused_with_its_key() {
        let mut cfg = empty_map();
        cfg.polygons.push(PolygonObstacle {
            points: vec![[1.0, 1.0], [2.0, 2.0], [3.0, 3.0]],
            height: None,
        });
        let e = Map::build(&cfg).err().unwrap();
        assert_eq!(e.key, "map.polygons[0].points");
        assert_eq!(
            e.to_string(),
            "key `map.polygons[0].points`: expected a polygon with non-zero area"
        );
        let keyless = MapError {
            key: String::new(),
            message: "no room".to_string(),
        };
        assert_eq!(keyless.to_string(), "no room");
        cfg.polygons.clear();
        assert!(Map::build(&cfg).is_ok());
    }
    /// The bound never exceeds the clearance, anywhere (near walls, inside obstacles, at cell
    /// edges, outside the map), so `nearer_than` answers as the clearance does; and it is
    /// useful: most points of the open map are settled by it.
    #[test]
    fn the_clearance_bound_is_below_the_clearance_and_settles_open_space() {
        let m = map();
        let mut seed = 3u64;
        let mut unit = move || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed >> 11) as f64 / (1u64 << 53) as f64
        };
        let mut settled = 0;
        let n = 50_000;
        for k in 0..n {
            // Some points on cell edges (multiples of the cell), some outside the bounds.
            let p = if k % 10 == 0 {
                ((unit() * 24.0).round() * 0.5, (unit() * 24.0).round() * 0.5)
            } else {
                (unit() * 14.0 - 1.0, unit() * 14.0 - 1.0)
            };
            let (bound, clear) = (m.clearance_bound(p), m.clearance(p));
            assert!(
                bound <= clear,
                "{p:?}: bound {bound} above clearance {clear}"
            );
            for dist in [0.15, 0.5, 1.0] {
                assert_eq!(m.nearer_than(p, dist), clear < dist, "{p:?} {dist}");
            }
            // Within the map, a point a cell's diagonal farther than 0.15 m from everything
            // is settled by the bound alone.
            let inside = (0.0..10.0).contains(&p.0) && (0.0..10.0).contains(&p.1);
            if inside && clear >= 0.15 + BOUND_CELL * std::f64::consts::SQRT_2 + 1e-5 {
                assert!(bound >= 0.15, "{p:?}: clearance {clear}, bound {bound}");
                settled += 1;
            }
        }
        assert!(settled > n / 5, "only {settled} of {n} in the open");
    }
    /// However long or large the map, the bounds stay within their budget of cells.
    #[test]
    fn the_bounds_grid_stays_small_for_long_or_huge_maps() {
        for bounds in [
            [0.0, 0.0, 1e9, 1.0],
            [0.0, 0.0, 1e6, 1e6],
            [0.0, 0.0, 3.0, 2.0],
        ] {
            let cfg = MapConfig {
                bounds,
                ..empty_map()
            };
            let b = ClearanceBounds::new(&cfg);
            assert!(
                b.cols * b.rows <= 1_100_000,
                "{bounds:?}: {} x {}",
                b.cols,
                b.rows
            );
            assert!(b.cols * b.rows > 0, "{bounds:?}");
        }
    }
}
