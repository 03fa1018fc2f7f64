//! Stage `kinematics`: every active robot's unicycle is integrated over one `dt` (heading
//! first, then position); the clearance is checked at sub-steps of at most half a radius
//! along the move, and a robot that touches an obstacle or a wall goes down where it is.
//! Aerial robots (`[robots.aerial]`) move holonomically instead: their world-frame velocity
//! is integrated in 3D, between the ground and `map.height`, against obstacles as prisms.

use swarmrt_protocol::{Command, RobotState};

use rand_distr::{Distribution, Normal};

use super::{Event, World, wrap_angle};
use crate::rng::Rng;

impl World {
    /// Applies each accepted command's speeds (a robot without one stands still, its lidar as
    /// it was); robots that are not active stand still.
    pub(super) fn integrate(&mut self, accepted: &[Option<&Command>]) {
        if self.cfg.robots.aerial.is_some() {
            return self.fly(accepted);
        }
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
                if self.map.nearer_than((r.x, r.y), radius) {
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

impl World {
    /// The aerial kinematics: each active robot flies its commanded `(vx, vy, vz)` (the world
    /// validated the limits) for `dt`; the heading follows the horizontal velocity. Sub-steps
    /// of at most half a radius check the 3D clearance; a robot that touches an obstacle goes
    /// down where it is. The height is held between the ground and the ceiling.
    fn fly(&mut self, accepted: &[Option<&Command>]) {
        let tick = self.tick;
        let dt = self.cfg.scenario.dt;
        let radius = self.cfg.robots.radius;
        let ceiling = self.cfg.map.height.unwrap_or(f64::INFINITY);
        for (i, accepted) in accepted.iter().enumerate() {
            let r = &mut self.robots[i];
            if r.state != RobotState::Active {
                (r.v, r.vz, r.omega) = (0.0, 0.0, 0.0);
                continue;
            }
            let (vx, vy, vz, lidar) = match accepted {
                Some(c) => (c.vx, c.vy, c.vz, c.lidar_on != 0),
                None => (0.0, 0.0, 0.0, r.lidar_on),
            };
            r.lidar_on = lidar;
            r.v = vx.hypot(vy);
            r.vz = vz;
            let theta = if r.v > 1e-9 { vy.atan2(vx) } else { r.theta };
            r.omega = wrap_angle(theta - r.theta) / dt;
            r.theta = theta;
            let (dx, dy) = (vx * dt, vy * dt);
            let dz = (r.z + vz * dt).clamp(0.0, ceiling) - r.z;
            let dist = (dx * dx + dy * dy + dz * dz).sqrt();
            let sub = ((dist / (radius * 0.5)).ceil() as usize).max(1);
            let (x0, y0, z0) = (r.x, r.y, r.z);
            for s in 1..=sub {
                let f = s as f64 / sub as f64;
                (r.x, r.y, r.z) = (x0 + dx * f, y0 + dy * f, z0 + dz * f);
                if self.map.clearance_3d((r.x, r.y), r.z) < radius {
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
