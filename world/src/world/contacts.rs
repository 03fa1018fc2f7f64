//! Stage `contacts`: after the kinematics, two robots whose bodies overlap both go down (a
//! robot that is not active is an obstacle and stays as it is). Bodies are discs for ground
//! robots and balls for aerial ones (ground robots all have height 0).

use swarmrt_protocol::RobotState;

use super::{Event, World};
use crate::grid::Grid;

impl World {
    /// Finds every overlapping pair with an active robot in it and knocks its active robots
    /// down, pairs in ascending order.
    pub(super) fn robot_contacts(&mut self) {
        let n = self.robots.len();
        let tick = self.tick;
        let radius = self.cfg.robots.radius;
        let positions: Vec<(f64, f64)> = self.robots.iter().map(|r| (r.x, r.y)).collect();
        let heights: Vec<f64> = self.robots.iter().map(|r| r.z).collect();
        let grid = Grid::build(&positions, 2.0 * radius);
        let mut pairs: Vec<(usize, usize)> = Vec::new();
        for i in 0..n {
            if self.robots[i].state != RobotState::Active {
                continue;
            }
            grid.near(positions[i], 2.0 * radius, |j| {
                if j != i {
                    let d = ((positions[j].0 - positions[i].0).powi(2)
                        + (positions[j].1 - positions[i].1).powi(2)
                        + (heights[j] - heights[i]).powi(2))
                    .sqrt();
                    if d < 2.0 * radius {
                        pairs.push((i.min(j), i.max(j)));
                    }
                }
            });
        }
        pairs.sort_unstable();
        pairs.dedup();
        for (a, b) in pairs {
            for (me, other) in [(a, b), (b, a)] {
                if self.robots[me].state == RobotState::Active {
                    self.robots[me].state = RobotState::Down;
                    self.metrics.collisions += 1;
                    self.metrics.down += 1;
                    self.events.push(Event::Collision {
                        tick,
                        robot: me as u32,
                        other: Some(other as u32),
                    });
                }
            }
        }
    }
}
