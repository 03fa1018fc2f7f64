//! What grouping robots say over the radio, and what they note in the run record.

use serde::{Deserialize, Serialize};

use crate::consensus::ConsensusMsg;

/// Largest group a formation message can number (its member list must fit one frame).
pub const MAX_GROUP: usize = 48;

/// A grouping robot's radio message.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub enum GroupMsg {
    /// The quadrant leader choice (section 2.2), the core of `consensus/quadrant.rs`.
    Quad(ConsensusMsg),
    /// A member to its leader: "I follow `leader` and stand at (x, y)" (world frame, from its
    /// own pose estimate), for members the leader's sensor cannot see.
    Join {
        /// The leader it follows.
        leader: u32,
        /// Its x.
        x: f32,
        /// Its y.
        y: f32,
    },
    /// The leader's formation (section 2.3): the COG at tick `stamp` moving at `vel` m/s,
    /// the radius, c_diff and the members in FRN order (the leader first). Other leaders
    /// read the COG for exploration (section 2.4).
    Form {
        /// COG x at `stamp`.
        x: f32,
        /// COG y at `stamp`.
        y: f32,
        /// COG velocity x, m/s.
        vx: f32,
        /// COG velocity y, m/s.
        vy: f32,
        /// Formation radius f_r.
        radius: f32,
        /// c_diff of eq. 8-9.
        c_diff: f32,
        /// Tick at which the COG was at (x, y).
        stamp: u64,
        /// Robot ids in FRN order: member k goes to slot k.
        members: Vec<u32>,
    },
    /// A leader that found the goal tells the others where it is (world frame).
    Goal {
        /// Goal x.
        x: f32,
        /// Goal y.
        y: f32,
    },
}

/// A grouping robot's note about its own decisions, e.g. `{"leader":{...}}` or `"arrived"`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum GroupNote {
    /// Its closest neighbour came within the clustering threshold (section 2.2).
    Clustered,
    /// The leader it believes in changed.
    Leader {
        /// The leader.
        leader: u32,
        /// It is the leader itself.
        leads: bool,
        /// Its own quadrant score.
        score: u8,
        /// Times the belief changed after the first decision (tie-break rounds).
        changes: u32,
    },
    /// As leader, it numbered a formation of `n` robots (or renumbered a broken one).
    Formed {
        /// Robots in the formation, the leader included.
        n: u8,
    },
    /// As leader, it saw the goal for the first time.
    GoalSeen,
    /// As leader, another leader told it where the goal is.
    GoalTold,
    /// As leader, its formation's centre reached the goal.
    Arrived,
    /// Its classifier's robot blobs since the last such note: right and wrong (eq. 17).
    Classified {
        /// Blobs that were robots.
        correct: u32,
        /// Blobs that were not.
        wrong: u32,
    },
}
