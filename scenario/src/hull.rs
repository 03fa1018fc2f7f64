//! The convex hull of a polygon obstacle's points, worked out here so that a degenerate polygon
//! (every point the same, all on one line, no area) is refused with its key before the
//! world's geometry library sees it: parry2d's hull panics on some of those (all points equal,
//! or distinct points so close that their distance squared underflows to zero).

/// What the hull of a polygon's points is.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HullShape {
    /// Distinct points among those given.
    pub distinct: usize,
    /// Vertices of the convex hull (collinear points dropped).
    pub vertices: usize,
    /// Area of the hull in m² (0 when it has fewer than 3 vertices).
    pub area: f64,
}

/// The hull of `points` (Andrew's monotone chain, O(n log n)). Finite points only: the
/// validator checks every coordinate first.
pub fn hull_shape(points: &[[f64; 2]]) -> HullShape {
    let mut pts: Vec<[f64; 2]> = points.to_vec();
    pts.sort_by(|a, b| a[0].total_cmp(&b[0]).then(a[1].total_cmp(&b[1])));
    pts.dedup();
    let distinct = pts.len();
    if distinct < 3 {
        return HullShape {
            distinct,
            vertices: distinct,
            area: 0.0,
        };
    }
    let mut hull: Vec<[f64; 2]> = Vec::with_capacity(2 * distinct);
    half_hull(pts.iter().copied(), &mut hull);
    half_hull(pts.iter().rev().copied(), &mut hull);
    let vertices = hull.len();
    let area = if vertices < 3 {
        0.0
    } else {
        let twice: f64 = (0..vertices)
            .map(|i| {
                let (a, b) = (hull[i], hull[(i + 1) % vertices]);
                a[0] * b[1] - b[0] * a[1]
            })
            .sum();
        (twice / 2.0).abs()
    };
    HullShape {
        distinct,
        vertices,
        area,
    }
}

/// Appends to `hull` the chain of `points` (sorted) turning left, without its last point
/// (the first of the other chain).
fn half_hull(points: impl Iterator<Item = [f64; 2]>, hull: &mut Vec<[f64; 2]>) {
    let cross = |o: [f64; 2], a: [f64; 2], b: [f64; 2]| {
        (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])
    };
    let start = hull.len();
    for p in points {
        while hull.len() >= start + 2 && cross(hull[hull.len() - 2], hull[hull.len() - 1], p) <= 0.0
        {
            hull.pop();
        }
        hull.push(p);
    }
    hull.pop();
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_square_with_an_inner_and_a_repeated_point_is_its_four_corners() {
        let h = hull_shape(&[
            [0.0, 0.0],
            [2.0, 0.0],
            [2.0, 2.0],
            [0.0, 2.0],
            [1.0, 1.0],
            [0.0, 0.0],
        ]);
        assert_eq!(
            h,
            HullShape {
                distinct: 5,
                vertices: 4,
                area: 4.0
            }
        );
    }

    #[test]
    fn degenerate_point_sets_have_no_area() {
        let same = hull_shape(&[[1.0, 1.0]; 3]);
        assert_eq!((same.distinct, same.area), (1, 0.0));
        let line = hull_shape(&[[1.0, 1.0], [2.0, 2.0], [3.0, 3.0], [4.0, 4.0]]);
        assert_eq!((line.distinct, line.vertices, line.area), (4, 2, 0.0));
        let tiny = hull_shape(&[[0.0, 0.0], [5e-324, 0.0], [0.0, 5e-324]]);
        assert!(tiny.area < 1e-300, "{tiny:?}");
    }
}
