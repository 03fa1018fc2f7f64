//! Go to the goal with reactive lidar obstacle avoidance and periodic pose beacons.
//!
//! Each robot heads for its own slot on a grid around the goal centre (so nine robots do not
//! fight for one point), steers proportionally toward it, and when the lidar sees something
//! closer than `avoid_distance` ahead, turns toward the more open side and slows down.

mod overlay;
mod params;

use std::f64::consts::PI;
use std::sync::{Arc, Mutex};

use serde::{Deserialize, Serialize};
use swarmrt_protocol::{BROADCAST, MAX_LIDAR_RAYS, Observation};
use swarmrt_scenario::layout::nearest_grid_points;
use swarmrt_scenario::{Config, LidarConfig, wrap_angle};

use crate::behaviour::{Act, Behaviour, NoNote};
use crate::consensus::Decision;
use crate::inbox::Heard;
pub use params::GotoParams;

/// Periodic pose beacon: a robot's pose as it estimates it.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Beacon {
    /// Sender's estimated x in metres.
    pub x: f64,
    /// Sender's estimated y in metres.
    pub y: f64,
    /// Sender's estimated heading in radians.
    pub theta: f64,
}

/// Go-to-goal state for one robot.
pub struct Goto {
    id: u32,
    params: GotoParams,
    /// `ray_angle(k)` of the scenario's lidar for each of its rays, worked out once: the
    /// avoidance loop reads one per ray every tick.
    ray_angles: Vec<f64>,
    radius: f64,
    dt: f64,
    max_speed: f64,
    max_turn: f64,
    slot: (f64, f64),
    goal: (f64, f64),
    goal_radius: f64,
    count: usize,
    bounds: [f64; 4],
    /// The side (+1 left, -1 right) this robot committed to while going around an obstacle.
    avoid_side: Option<f64>,
}

/// Distance to the slot under which the robot stops.
const ARRIVE: f64 = 0.05;
/// Half-width of the sector ahead that counts for avoidance.
const AHEAD: f64 = 70.0 * PI / 180.0;

impl Goto {
    /// Robot `id`'s behaviour for this scenario.
    pub fn new(cfg: &Config, params: &GotoParams, id: u32) -> Goto {
        let g = cfg.goal_of(id);
        let mut goto = Goto {
            id,
            params: *params,
            ray_angles: ray_angles(&cfg.robots.lidar),
            radius: cfg.robots.radius,
            dt: cfg.scenario.dt,
            max_speed: cfg.robots.max_speed,
            max_turn: cfg.robots.max_turn_rate,
            slot: (g.x, g.y),
            goal: (g.x, g.y),
            goal_radius: g.radius,
            count: cfg.robots.count as usize,
            bounds: cfg.map.bounds,
            avoid_side: None,
        };
        goto.slot = goto.slot_around(goto.goal);
        goto
    }

    /// This robot's slot around `goal`: the grid points nearest the goal centre inside the
    /// map. The robot does not know the obstacles (it only senses them), so a slot may be
    /// unreachable; it then parks as close as the lidar lets it.
    fn slot_around(&self, goal: (f64, f64)) -> (f64, f64) {
        let spacing = self.params.slot_spacing.max(2.5 * self.radius);
        goal_slots(self.count, goal, spacing, self.bounds, self.radius)
            .and_then(|slots| slots.get(self.id as usize).copied())
            .unwrap_or(goal)
    }

    /// The point this robot is heading for.
    pub fn slot(&self) -> (f64, f64) {
        self.slot
    }
}

/// The slots of all `count` robots around `goal`, computed once per process for the same
/// inputs: every robot of a swarm asks for the same grid (and a run in one process holds
/// them all), and sorting the map's grid cells per robot made setting up 10,000 robots
/// in-process take seconds. A memo of a pure function: the slots are the same either way.
fn goal_slots(
    count: usize,
    goal: (f64, f64),
    spacing: f64,
    bounds: [f64; 4],
    radius: f64,
) -> Option<Arc<[(f64, f64)]>> {
    /// The inputs, floats by their bits.
    type Key = (usize, [u64; 8]);
    type Slots = Option<Arc<[(f64, f64)]>>;
    static LAST: Mutex<Option<(Key, Slots)>> = Mutex::new(None);
    let b = bounds.map(f64::to_bits);
    let key: Key = (
        count,
        [
            goal.0.to_bits(),
            goal.1.to_bits(),
            spacing.to_bits(),
            radius.to_bits(),
            b[0],
            b[1],
            b[2],
            b[3],
        ],
    );
    let mut last = LAST.lock().unwrap_or_else(|e| e.into_inner());
    if let Some((k, slots)) = last.as_ref()
        && *k == key
    {
        return slots.clone();
    }
    let slots = nearest_grid_points(count, goal, spacing, bounds, radius, |_, _| true)
        .map(Arc::from);
    *last = Some((key, slots.clone()));
    slots
}

/// The angle of each ray the lidar has (at most [`MAX_LIDAR_RAYS`]), as `ray_angle` gives it.
fn ray_angles(lidar: &LidarConfig) -> Vec<f64> {
    (0..(lidar.rays as usize).min(MAX_LIDAR_RAYS))
        .map(|k| lidar.ray_angle(k))
        .collect()
}

impl Behaviour for Goto {
    const KIND: &'static str = "goto";
    /// Beacons are sent for observers and other robots' programs; goto itself steers by its
    /// lidar alone.
    const LISTENS: bool = false;
    type Params = GotoParams;
    type Msg = Beacon;
    type Note = NoNote;

    fn new(cfg: &Config, params: &GotoParams, id: u32) -> Goto {
        Goto::new(cfg, params, id)
    }

    /// `SetGoal`: head for this robot's slot around the new goal (same radius);
    /// `SetSpeed`: cruise at the new speed.
    fn apply(&mut self, decision: &Decision) {
        match *decision {
            Decision::SetGoal { x, y } => {
                self.goal = (x, y);
                self.slot = self.slot_around(self.goal);
                self.avoid_side = None;
            }
            Decision::SetSpeed { speed } => self.params.speed = speed.max(0.0),
            Decision::Route(_) => {}
        }
    }

    fn step(&mut self, obs: &Observation, _inbox: &[Heard<Beacon>], act: &mut Act<Beacon, NoNote>) {
        act.lidar_on = true;
        let p = self.params;
        if p.beacon_period > 0 && (obs.tick + self.id as u64).is_multiple_of(p.beacon_period as u64)
        {
            act.send(
                BROADCAST,
                Beacon {
                    x: obs.x,
                    y: obs.y,
                    theta: obs.theta,
                },
            );
        }

        let (dx, dy) = (self.slot.0 - obs.x, self.slot.1 - obs.y);
        let dist = (dx * dx + dy * dy).sqrt();
        if dist < ARRIVE {
            return;
        }
        let err = wrap_angle(dy.atan2(dx) - obs.theta);
        let mut omega = 2.0 * err;
        // Slow down when facing away and when close, so the robot does not orbit its slot.
        let mut v = p.speed * err.cos().max(0.0) * (dist / (4.0 * self.radius)).min(1.0);

        // Avoidance: nearest return in the sector ahead, which side is more open, and what
        // the ray closest to the slot's direction sees.
        let (mut nearest, mut left, mut right) = (f64::INFINITY, 0.0, 0.0);
        let (mut toward_slot, mut best) = (f64::INFINITY, f64::INFINITY);
        for (k, &d) in obs.lidar().iter().enumerate() {
            let Some(&a) = self.ray_angles.get(k) else {
                break;
            };
            if a.abs() <= AHEAD {
                nearest = nearest.min(d);
            }
            if a > 0.0 {
                left += d;
            } else if a < 0.0 {
                right += d;
            }
            if (a - err).abs() < best {
                best = (a - err).abs();
                toward_slot = d;
            }
        }
        let goal = self.goal;
        let in_goal_area =
            ((obs.x - goal.0).powi(2) + (obs.y - goal.1).powi(2)).sqrt() < self.goal_radius * 0.9;
        // Only obstacles closer than the slot matter.
        if nearest < p.avoid_distance && nearest < dist {
            if in_goal_area {
                // Inside the goal area but blocked, most likely by a robot parked at its
                // slot: park here instead of circling.
                return;
            }
            // Commit to one side until the way to the slot is open: choosing afresh each
            // tick dithers left-right in front of an obstacle (a local minimum).
            let side = *self
                .avoid_side
                .get_or_insert(if left >= right { 1.0 } else { -1.0 });
            let urgency =
                1.0 - (nearest - self.radius).max(0.0) / (p.avoid_distance - self.radius).max(1e-6);
            omega = side * self.max_turn * urgency.clamp(0.3, 1.0);
            v = p.speed * (1.0 - urgency).clamp(0.0, 1.0);
            if nearest < self.radius + 0.1 {
                v = 0.0;
            }
        } else if let Some(side) = self.avoid_side {
            if toward_slot < p.avoid_distance.max(dist.min(1.5 * p.avoid_distance))
                && best < AHEAD * 2.0
            {
                // The slot is still behind the obstacle: follow its edge, bending back
                // toward it slowly so the robot goes around instead of away.
                omega = -side * 0.3 * self.max_turn;
                v = p.speed;
            } else {
                self.avoid_side = None;
            }
        }

        // Never overshoot the slot within one tick.
        act.v = v.min(dist / self.dt).clamp(0.0, self.max_speed);
        act.omega = omega.clamp(-self.max_turn, self.max_turn);
    }
}

#[cfg(test)]
mod tests;
