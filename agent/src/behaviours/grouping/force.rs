//! Force analysis (section 2.1, eq. 3-6): every robot a robot senses pulls it with the
//! universal gravitational force, and the robot moves along the resultant until its closest
//! neighbour is within the clustering threshold.

use nalgebra::Vector2;

/// A 2D vector in metres (or newtons), robot or world frame as the caller says.
pub type V2 = Vector2<f64>;

/// Eq. 3 with unit masses: F = G m1 m2 / r^2, capped at `cap` (the paper limits the largest
/// force "to avoid unexpected collisions"). `r` is the centre distance of eq. 4.
pub fn pull(gravity: f64, r: f64, cap: f64) -> f64 {
    if r <= 0.0 {
        return cap;
    }
    (gravity / (r * r)).min(cap)
}

/// Eq. 6: R_i A = sum of F_j over the robots sensed, each along its direction theta (eq. 5),
/// given as positions relative to the robot.
pub fn resultant(sensed: &[V2], gravity: f64, cap: f64) -> V2 {
    sensed
        .iter()
        .filter(|p| p.norm() > 0.0)
        .map(|p| {
            let r = p.norm();
            p / r * pull(gravity, r, cap)
        })
        .sum()
}

/// The pseudo code's test: the robot has finished clustering when its closest sensed robot
/// is nearer than `threshold`. A robot that senses nobody never finishes (it stays alone).
pub fn clustered(sensed: &[V2], threshold: f64) -> bool {
    sensed.iter().any(|p| p.norm() < threshold)
}
