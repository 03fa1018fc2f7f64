//! What formation robots say to each other and what they note about themselves (seed 000).

use serde::{Deserialize, Serialize};

/// The formation's per-tick broadcast: pose for the virtual leader estimate, the sender's
/// swarm heading, and its observer role and lidar verdict.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct FormationMsg {
    /// Sender's x in metres.
    pub x: f64,
    /// Sender's y in metres.
    pub y: f64,
    /// Sender's heading in radians.
    pub theta: f64,
    /// Sender's speed in m/s (receivers extrapolate stale poses with it).
    pub v: f64,
    /// The swarm heading the sender holds, radians.
    pub psi: f64,
    /// The observer role the sender's lidar was on for: 0 none, 1 middle, 2 left, 3 right.
    pub role: u8,
    /// Non-zero when that lidar saw an obstacle in the role's cone: the distance to the
    /// nearest one in decimetres (1-255, see [`range_to_wire`]).
    pub obstacle: u8,
}

/// An observer's verdict on the wire: 0 nothing seen, else the nearest obstacle's distance in
/// decimetres, at least 1 and at most 255 (25.5 m, beyond every detect range we use).
pub fn range_to_wire(range: Option<f64>) -> u8 {
    match range {
        None => 0,
        Some(r) => (r * 10.0).round().clamp(1.0, 255.0) as u8,
    }
}

/// The inverse of [`range_to_wire`], in metres.
pub fn range_from_wire(v: u8) -> Option<f64> {
    (v != 0).then_some(v as f64 / 10.0)
}

/// A formation robot's note about its own decisions, e.g. `{"role":{"role":2}}` or
/// `"epsilon_flip"` in `events.jsonl`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum FormationNote {
    /// The observer role this robot believes it holds changed (eq. 4-5): 0 none, 1 middle,
    /// 2 left, 3 right.
    Role {
        /// The new role.
        role: u8,
    },
    /// The turn this robot decided for the swarm changed: -1 right, 0 straight, +1 left.
    Turn {
        /// The new direction.
        dir: i8,
    },
    /// Epsilon-greedy chose the opposite turn this tick (section 5.3).
    EpsilonFlip,
}
