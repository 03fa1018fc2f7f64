//! What robots say to each other. Encoded with postcard into [`crate::Frame`] payloads: the
//! world only checks that a payload decodes (a command with one that does not is refused) and
//! routes the bytes, so later behaviours add variants here freely.

use serde::{Deserialize, Serialize};

/// A message carried in a radio frame.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub enum RadioMsg {
    /// Periodic pose beacon: a robot knows its neighbours' poses only through these.
    Beacon {
        /// Sender's estimated x in metres.
        x: f64,
        /// Sender's estimated y in metres.
        y: f64,
        /// Sender's estimated heading in radians.
        theta: f64,
    },
    /// The formation's per-tick message (seed 000): pose for the virtual leader estimate,
    /// the sender's swarm heading, and its observer role and lidar verdict.
    Formation {
        /// Sender's x in metres.
        x: f64,
        /// Sender's y in metres.
        y: f64,
        /// Sender's heading in radians.
        theta: f64,
        /// Sender's speed in m/s (receivers extrapolate stale poses with it).
        v: f64,
        /// The swarm heading the sender holds, radians.
        psi: f64,
        /// The observer role the sender's lidar was on for: 0 none, 1 middle, 2 left, 3 right.
        role: u8,
        /// Non-zero when that lidar saw an obstacle in the role's cone.
        obstacle: u8,
    },
    /// Election, replicated log and leader choice (`crate::consensus`).
    Consensus(crate::consensus::ConsensusMsg),
}

impl RadioMsg {
    /// Decodes a payload; `None` for bytes that are not a valid message (counted, not fatal).
    pub fn decode(bytes: &[u8]) -> Option<RadioMsg> {
        postcard::from_bytes(bytes).ok()
    }

    /// A short name per variant, used for per-kind message counts.
    pub fn kind(&self) -> &'static str {
        match self {
            RadioMsg::Beacon { .. } => "beacon",
            RadioMsg::Formation { .. } => "formation",
            RadioMsg::Consensus(m) => m.kind(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn beacon_round_trips_and_garbage_is_refused() {
        let msg = RadioMsg::Beacon {
            x: 1.5,
            y: -2.0,
            theta: 0.25,
        };
        let bytes = postcard::to_allocvec(&msg).unwrap();
        assert_eq!(RadioMsg::decode(&bytes), Some(msg));
        assert_eq!(RadioMsg::decode(&[200, 1, 2]), None);
    }
}
