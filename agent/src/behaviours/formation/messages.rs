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
    /// Non-zero when that lidar saw an obstacle in the role's cone.
    pub obstacle: u8,
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
