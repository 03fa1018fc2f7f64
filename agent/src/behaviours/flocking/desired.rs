//! The desired heading a(t) of eq. 1-9, in the robot's frame (x ahead, y to the left): pure
//! functions of what the robot sensed and heard, so each equation is tested on its own.

use nalgebra::Vector2;

/// A vector in the robot's frame.
pub type V2 = Vector2<f64>;

/// Highest proximity level O_k (the paper's lookup table runs 0..=7).
pub const LEVEL_MAX: f64 = 7.0;

/// e_1: the unit vector along the robot's own heading.
pub fn e1() -> V2 {
    V2::new(1.0, 0.0)
}

/// The unit vector at `angle` radians from the heading, e^{i angle}.
pub fn unit(angle: f64) -> V2 {
    V2::new(angle.cos(), angle.sin())
}

/// `v` normalised, or `None` when it has (almost) no length.
fn normalised(v: V2) -> Option<V2> {
    let n = v.norm();
    (n > 1e-12).then(|| v / n)
}

/// Eq. 6: l = (sum_j e^{i theta_j} + e_1) / (N + 1), the mean heading of the flock-mates heard
/// and of the robot itself; `rel_headings` are theta_j minus the robot's own heading. (The
/// paper prints e_1 outside the fraction; with it inside, l is a mean of N + 1 unit vectors
/// and a lone robot keeps its heading, which is what the text says e_1 is for.)
pub fn alignment(rel_headings: &[f64]) -> V2 {
    let sum: V2 = rel_headings.iter().map(|&t| unit(t)).sum::<V2>() + e1();
    sum / (rel_headings.len() + 1) as f64
}

/// Eq. 5: h = (M_b m + (1 - M_b) l) / ||.||, with m the unit vector toward the migration
/// direction (`migration_rel`, relative to the heading). e_1 when the two cancel out.
pub fn heading_alignment(mb: f64, migration_rel: f64, l: V2) -> V2 {
    normalised(unit(migration_rel) * mb + l * (1.0 - mb)).unwrap_or_else(e1)
}

/// O_k: a proximity sensor's level, linear from 0 at the sensor's `range` (the no-detect
/// threshold) to [`LEVEL_MAX`] at contact (`radius`, the body's edge); distances measured
/// from the robot's centre. The paper maps raw IR values between a max and a min threshold
/// linearly onto 0..=7; our rays measure distance, so the map is linear in distance.
pub fn level(distance: f64, radius: f64, range: f64) -> f64 {
    if range <= radius {
        return if distance < range { LEVEL_MAX } else { 0.0 };
    }
    (LEVEL_MAX * (range - distance) / (range - radius)).clamp(0.0, LEVEL_MAX)
}

/// Eq. 8: f_k = -O_k^2 / (O_max - O_no_detect)^2 with O_max = 7, O_no_detect = 0: a
/// repulsion that grows with the square of the level.
pub fn repulsion(level: f64) -> f64 {
    -(level * level) / (LEVEL_MAX * LEVEL_MAX)
}

/// Eq. 7: p = sum_k f_k e^{i phi_k} / ||.||, sensors at `angles` (radians from the heading).
/// Zero when nothing is sensed (or the pushes cancel out).
pub fn proximal(levels: &[f64], angles: &[f64]) -> V2 {
    let sum: V2 = levels
        .iter()
        .zip(angles)
        .map(|(&o, &phi)| unit(phi) * repulsion(o))
        .sum();
    normalised(sum).unwrap_or_else(V2::zeros)
}

/// s(t) of eq. 2: the highest level read this tick over the highest possible.
pub fn strongest(levels: &[f64]) -> f64 {
    levels.iter().cloned().fold(0.0, f64::max) / LEVEL_MAX
}

/// Eq. 2: Gamma = beta^(iota + s), growing as the robot nears anything.
pub fn proximal_weight(beta: f64, iota: f64, s: f64) -> f64 {
    beta.powf(iota + s)
}

/// Eq. 9: c = (1/N) sum_j x'_j, the centre of mass of the flock-mates heard, relative to the
/// robot. Zero when none is known.
pub fn cohesion(rel_positions: &[V2]) -> V2 {
    if rel_positions.is_empty() {
        return V2::zeros();
    }
    rel_positions.iter().sum::<V2>() / rel_positions.len() as f64
}

/// Eq. 3-4: Delta = delta^(zeta + d) with d = ||c|| when the robot is farther than D from the
/// centre of mass, else 0 (inside the circle, cohesion does not pull).
pub fn cohesion_weight(delta: f64, zeta: f64, d: f64, desired_distance: f64) -> f64 {
    if d > desired_distance {
        delta.powf(zeta + d)
    } else {
        0.0
    }
}

/// Eq. 1: a = (alpha h + Gamma p + Delta c) / ||.||; e_1 when everything cancels out.
pub fn desired(alpha: f64, h: V2, gamma: f64, p: V2, delta_w: f64, c: V2) -> V2 {
    normalised(h * alpha + p * gamma + c * delta_w).unwrap_or_else(e1)
}
