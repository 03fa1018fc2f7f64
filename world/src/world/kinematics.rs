//! Stage `kinematics`: every active robot's unicycle is integrated over one `dt` (heading
//! first, then position); the clearance is checked at sub-steps of at most half a radius
//! along the move, and a robot that touches an obstacle or a wall goes down where it is.

use swarmrt_protocol::{Command, RobotState};

use rand_distr::{Distribution, Normal};

use super::{Event, World, wrap_angle};
use crate::rng::Rng;

impl World {
    /// Applies each accepted command's speeds (a robot without one stands still, its lidar as
    /// it was); robots that are not active stand still.
    pub(super) fn integrate(&mut self, accepted: &[Option<&Command>]) {
        let tick = self.tick;
        let dt = self.cfg.scenario.dt;
        let radius = self.cfg.robots.radius;
        let slip_sd = self.cfg.robots.noise.wheel_slip;
        for (i, accepted) in accepted.iter().enumerate() {
            let r = &mut self.robots[i];
            if r.state != RobotState::Active {
                r.v = 0.0;
                r.omega = 0.0;
                continue;
            }
            let (v, omega, lidar) = match accepted {
                Some(c) => (c.v, c.omega, c.lidar_on != 0),
                None => (0.0, 0.0, r.lidar_on),
            };
            let (v, omega) = slip(v, omega, radius, slip_sd, &mut self.slip_rng[i]);
            r.v = v;
            r.omega = omega;
            r.lidar_on = lidar;
            r.theta = wrap_angle(r.theta + omega * dt);
            let (dx, dy) = (v * dt * r.theta.cos(), v * dt * r.theta.sin());
            let dist = (dx * dx + dy * dy).sqrt();
            let sub = ((dist / (radius * 0.5)).ceil() as usize).max(1);
            let (x0, y0) = (r.x, r.y);
            for s in 1..=sub {
                let f = s as f64 / sub as f64;
                r.x = x0 + dx * f;
                r.y = y0 + dy * f;
                if self.map.clearance((r.x, r.y)) < radius {
                    r.state = RobotState::Down;
                    break;
                }
            }
            if r.state == RobotState::Down {
                self.metrics.collisions += 1;
                self.metrics.down += 1;
                self.events.push(Event::Collision {
                    tick,
                    robot: i as u32,
                    other: None,
                });
            }
        }
    }
}

/// The speeds the wheels actually produce for the commanded `(v, omega)`: each wheel of a
/// differential drive with axle `2 * radius` moves `1 + N(0, sd)` times its command. No draw
/// when `sd` is zero (or the robot is told to stand still), so such runs keep their records.
fn slip(v: f64, omega: f64, radius: f64, sd: f64, rng: &mut Rng) -> (f64, f64) {
    if sd <= 0.0 || (v == 0.0 && omega == 0.0) {
        return (v, omega);
    }
    let Ok(normal) = Normal::new(0.0, sd) else {
        return (v, omega);
    };
    let (left, right) = (v - omega * radius, v + omega * radius);
    let left = left * (1.0 + normal.sample(rng));
    let right = right * (1.0 + normal.sample(rng));
    ((left + right) / 2.0, (right - left) / (2.0 * radius))
}
