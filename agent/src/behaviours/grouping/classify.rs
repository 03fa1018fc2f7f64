//! Telling robots from obstacles with the range finder alone (section 2.1, eq. 7). The paper
//! trains a neural network on range-finder patterns of cones, rectangles and circles (the
//! robots). We keep its input (the scan, cut into clusters of adjacent hits) and replace the
//! network by the geometry it learns: a robot is a cluster that is an arc of a circle of the
//! known robot radius, no wider than the robot; anything else is an obstacle. Its precision
//! p_v (eq. 17) is measured against the range-and-bearing sensor, which is exact.

use super::force::V2;

/// One cluster of adjacent lidar hits.
#[derive(Debug, Clone, PartialEq)]
pub struct Blob {
    /// Indices of its rays, in scan order.
    pub rays: Vec<usize>,
    /// Its hit points in the robot frame.
    pub points: Vec<V2>,
    /// Estimated centre of the object if it is a robot (robot frame).
    pub centre: V2,
    /// Classified as a robot.
    pub robot: bool,
}

/// Classifier settings.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Classifier {
    /// Robot body radius, metres.
    pub radius: f64,
    /// Lidar maximum range: a ray at it hit nothing.
    pub range: f64,
    /// Allowed deviation from the ideal circle, metres.
    pub tolerance: f64,
}

impl Classifier {
    /// Splits the scan (`ranges[k]` along `angles[k]`, robot frame) into blobs of adjacent
    /// hits, joining the last ray to the first when `cyclic` (a 360° scan), and classifies
    /// each.
    pub fn blobs(&self, ranges: &[f64], angles: &[f64], cyclic: bool) -> Vec<Blob> {
        let n = ranges.len().min(angles.len());
        let hit = |k: usize| ranges[k] < self.range - 1e-9;
        let point = |k: usize| V2::new(angles[k].cos(), angles[k].sin()) * ranges[k];
        // Two neighbouring hits belong together when their points are closer than a robot
        // is wide: a gap a robot could fill separates objects.
        let joined = |a: usize, b: usize| {
            hit(a) && hit(b) && (point(a) - point(b)).norm() < self.radius * 1.5
        };
        let mut groups: Vec<Vec<usize>> = Vec::new();
        for k in 0..n {
            if !hit(k) {
                continue;
            }
            match groups.last_mut() {
                Some(g) if *g.last().unwrap_or(&usize::MAX) + 1 == k && joined(k - 1, k) => {
                    g.push(k)
                }
                _ => groups.push(vec![k]),
            }
        }
        if cyclic && groups.len() > 1 && n > 1 && joined(n - 1, 0) {
            let first = groups.remove(0);
            if let Some(last) = groups.last_mut()
                && *last.last().unwrap_or(&0) == n - 1
            {
                last.extend(first);
            } else {
                groups.insert(0, first);
            }
        }
        // A free-standing body: the rays just past either end of the cluster miss it, so they
        // read nothing or something at least a body radius farther. A cluster whose flank is
        // nearer continues a larger surface (a wall seen at a grazing angle) or is partly
        // hidden: not a robot.
        let flank = |k: Option<usize>, near: f64| match k {
            Some(k) => !hit(k) || ranges[k] >= near + self.radius,
            None => true,
        };
        let before = |k: usize| match k {
            0 if cyclic => Some(n - 1),
            0 => None,
            _ => Some(k - 1),
        };
        let after = |k: usize| match k + 1 {
            m if m == n && cyclic => Some(0),
            m if m == n => None,
            m => Some(m),
        };
        groups
            .into_iter()
            .map(|rays| {
                let points: Vec<V2> = rays.iter().map(|&k| point(k)).collect();
                let (shape, centre) = self.judge(&points);
                let near = rays.iter().map(|&k| ranges[k]).fold(f64::INFINITY, f64::min);
                let (first, last) = (rays[0], rays[rays.len() - 1]);
                let free = rays.len() < n
                    && flank(before(first), near)
                    && flank(after(last), near);
                let robot = shape && free;
                Blob {
                    rays,
                    points,
                    centre,
                    robot,
                }
            })
            .collect()
    }

    /// Is this cluster an arc of a robot? The centre lies one radius behind the nearest
    /// point, along the cluster's mean direction; every point must lie on that circle and
    /// the cluster must be no wider than the robot.
    fn judge(&self, points: &[V2]) -> (bool, V2) {
        let dir: V2 = points.iter().map(|p| p / p.norm().max(1e-9)).sum();
        let dir = dir / dir.norm().max(1e-9);
        let nearest = points.iter().map(|p| p.norm()).fold(f64::INFINITY, f64::min);
        let centre = dir * (nearest + self.radius);
        let width = match (points.first(), points.last()) {
            (Some(a), Some(b)) => (a - b).norm(),
            _ => 0.0,
        };
        let on_circle = points
            .iter()
            .all(|p| ((p - centre).norm() - self.radius).abs() <= self.tolerance);
        (
            on_circle && width <= 2.0 * self.radius + self.tolerance,
            centre,
        )
    }
}

/// True and false matches of the robot blobs against the robots the range-and-bearing sensor
/// reports (robot frame, within `range`): a robot blob is correct when a true robot's centre
/// lies within `tolerance` of its estimated centre (one body diameter: a ray grazing a body's
/// edge puts the estimate up to a radius aside). Blobs beyond `range` are not judged.
pub fn matches(blobs: &[Blob], truth: &[V2], range: f64, tolerance: f64) -> (u32, u32) {
    let (mut correct, mut wrong) = (0, 0);
    for b in blobs.iter().filter(|b| b.robot && b.centre.norm() <= range) {
        if truth.iter().any(|t| (t - b.centre).norm() <= tolerance) {
            correct += 1;
        } else {
            wrong += 1;
        }
    }
    (correct, wrong)
}
