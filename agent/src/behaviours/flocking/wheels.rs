//! From the desired heading to the wheels (eq. 10-13), and from the wheels to the unicycle
//! command (v, omega) the world takes.

/// Eq. 10: the forward speed. `top` is 2 pi R, the speed at full wheel rotation
/// (`robots.max_speed`); `a_x` the desired heading's forward component; `dot_ch` the scalar
/// product of the (unit) heading-alignment and cohesion directions, 0 inside the desired
/// distance. A robot ahead of its flock (dot_ch < 0) slows by sqrt(1 - |dot_ch|) to wait;
/// a desired heading behind it (a_x < 0) with the flock ahead (dot_ch >= 0) stops it to turn
/// on the spot. The paper's second case reads `dot_ch > 0`; we read `>= 0` (dot_ch is 0
/// inside the circle), or a robot inside its flock's circle could never move.
pub fn forward_speed(top: f64, a_x: f64, dot_ch: f64) -> f64 {
    let slow = (1.0 - dot_ch.abs()).max(0.0).sqrt();
    if a_x > 0.0 && dot_ch < 0.0 {
        top * a_x * slow
    } else if a_x > 0.0 {
        top * a_x
    } else if a_x < 0.0 && dot_ch < 0.0 {
        top * a_x.abs() * slow
    } else {
        0.0
    }
}

/// Eq. 11: omega = kappa theta_a 8 W_r / l, theta_a the desired heading's angle from ahead.
pub fn turn_rate(kappa: f64, theta_a: f64, wheel_radius: f64, axle: f64) -> f64 {
    kappa * theta_a * 8.0 * wheel_radius / axle
}

/// Eq. 12-13 and back: left and right wheel speeds `u -/+ omega l / 2`, each limited to
/// `top` (motor_max steps per second is full rotation, 2 pi R = `top`), then the unicycle
/// command `((left + right) / 2, (right - left) / l)`. Limiting each wheel, as the e-puck's
/// motors do, keeps the turn when the forward speed saturates.
pub fn unicycle(u: f64, omega: f64, axle: f64, top: f64) -> (f64, f64) {
    let left = (u - omega * axle / 2.0).clamp(-top, top);
    let right = (u + omega * axle / 2.0).clamp(-top, top);
    ((left + right) / 2.0, (right - left) / axle)
}
