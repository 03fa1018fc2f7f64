//! What a viewer draws of a grouping run: where each robot is in the paper's layers (alone,
//! clustered, member or leader of a group, a leader that knows the goal, a leader whose
//! formation arrived) from its notes; its group (the quadrant leader it follows) as a
//! consensus lane; leader choices, goal sightings and arrivals as headlines.

use swarmrt_scenario::Config;

use super::messages::GroupNote;
use super::params::GroupingParams;
use crate::overlay::lane::{quadrant_headline, quadrant_lane};
use crate::overlay::{Headline, LaneChange, Overlay, RoleDef};

/// Still gathering (layer 1): nobody within the clustering threshold yet.
pub const ALONE: u8 = 0;
/// Clustered, waiting for the leader choice.
pub const CLUSTERED: u8 = 1;
/// Follows a quadrant leader.
pub const MEMBER: u8 = 2;
/// Leads its group.
pub const LEADER: u8 = 3;
/// A leader that saw the goal or was told where it is.
pub const GOAL_KNOWN: u8 = 4;
/// A leader whose formation's centre reached the goal.
pub const ARRIVED: u8 = 5;

/// Indexed by the constants above.
pub const ROLES: &[RoleDef] = &[
    RoleDef {
        name: "alone",
        colour: "#8c8c8c",
    },
    RoleDef {
        name: "clustered",
        colour: "#17becf",
    },
    RoleDef {
        name: "member",
        colour: "#1f77b4",
    },
    RoleDef {
        name: "leader",
        colour: "#d62728",
    },
    RoleDef {
        name: "leader, goal known",
        colour: "#ff7f0e",
    },
    RoleDef {
        name: "arrived",
        colour: "#2ca02c",
    },
];

/// Every robot starts gathering, alone.
fn initial_role(_cfg: &Config, _params: &GroupingParams, _id: u32) -> Option<u8> {
    Some(ALONE)
}

/// The layer a note says the robot reached; formation and classifier notes change nothing.
fn role_after(note: &GroupNote) -> Option<u8> {
    match *note {
        GroupNote::Clustered => Some(CLUSTERED),
        GroupNote::Leader { leads, .. } => Some(if leads { LEADER } else { MEMBER }),
        GroupNote::GoalSeen | GroupNote::GoalTold => Some(GOAL_KNOWN),
        GroupNote::Arrived => Some(ARRIVED),
        GroupNote::Formed { .. } | GroupNote::Classified { .. } => None,
    }
}

/// A leader declaring itself, finding the goal, hearing of it, and arriving.
fn headline(note: &GroupNote) -> Option<Headline> {
    let (kind, text) = match *note {
        GroupNote::Leader {
            leads: true, score, ..
        } => return Some(quadrant_headline(score)),
        GroupNote::GoalSeen => ("goal_seen", "saw the goal"),
        GroupNote::GoalTold => ("goal_told", "was told where the goal is"),
        GroupNote::Arrived => ("arrived", "its formation reached the goal"),
        _ => return None,
    };
    Some(Headline {
        kind,
        text: text.to_string(),
        others: Vec::new(),
    })
}

/// The group a robot belongs to is its quadrant leader: the same lane as the consensus
/// layer's quadrant note (grouping runs the quadrant core itself and notes the choice).
fn lane(note: &GroupNote) -> Option<LaneChange> {
    match *note {
        GroupNote::Leader { leader, leads, .. } => Some(quadrant_lane(leader, leads)),
        _ => None,
    }
}

impl Overlay for super::Grouping {
    const ROLES: &'static [RoleDef] = ROLES;

    fn initial_role(cfg: &Config, params: &GroupingParams, id: u32) -> Option<u8> {
        initial_role(cfg, params, id)
    }

    fn role_after(_params: &GroupingParams, _id: u32, note: &GroupNote) -> Option<u8> {
        role_after(note)
    }

    fn headline(note: &GroupNote) -> Option<Headline> {
        headline(note)
    }

    fn lane(note: &GroupNote) -> Option<LaneChange> {
        lane(note)
    }
}
