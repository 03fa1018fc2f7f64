//! What chain robots say to their two chain neighbours, and what they report.

use serde::{Deserialize, Serialize};

/// Sent every tick to each chain neighbour (unicast, so a 450-robot chain costs two frames
/// per robot and tick, not a broadcast storm).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Link {
    /// The sender's position as it sensed it.
    pub x: f32,
    /// y.
    pub y: f32,
    /// The sender's own master's position, as the sender sees it: the third corner of the
    /// receiver's connector angle when range-and-bearing cannot see it.
    pub master: Option<[f32; 2]>,
    /// Non-zero to its master: the sender vetoes its master's motion, and the veto has now
    /// travelled this many robots (1 at the robot that objected). Always 0 to a slave.
    pub veto: u16,
}

/// What a chain robot reports in `events.jsonl`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ChainNote {
    /// This robot started vetoing its master `master`; `depth` robots carry the veto up to
    /// and including this one (1: it objected itself).
    Veto {
        /// The master it objects to.
        master: u32,
        /// How far back the veto has travelled.
        depth: u16,
        /// Why it objected.
        why: VetoWhy,
    },
    /// The initiator heard a veto that travelled `depth` robots: it stopped and turned
    /// `turn_deg` in place (its re-plan) before wall following again.
    Replan {
        /// How far back the veto travelled.
        depth: u16,
        /// Signed turn in degrees (positive: left).
        turn_deg: f32,
    },
}

/// Why a slave vetoes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum VetoWhy {
    /// It is stationary and its master left its rod limits.
    Stationary,
    /// It found no collision-free guiding line for `trapped_ticks` ticks.
    Trapped,
    /// Its own slave vetoed, and its master is out of reach of where that leaves it.
    Passed,
}
