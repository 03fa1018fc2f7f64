//! The consensus layer's part of a viewer's overlay: how a robot's
//! consensus lane (Raft role, term, commit; or the quadrant leader it follows) changes with
//! each of its notes, and which notes are headlines (an election won, a group leader
//! declared). Pure functions of one note, read after the run.

use serde::Deserialize;
use serde_json::Value;

use super::{Headline, LaneChange};
use crate::consensus::{ConsensusNote, Role};

/// The name of a Raft role in lanes: `follower`, `pre_candidate`, `candidate`, `leader` (as
/// the role is spelled in `events.jsonl`).
pub fn role_name(role: Role) -> &'static str {
    match role {
        Role::Follower => "follower",
        Role::PreCandidate => "pre_candidate",
        Role::Candidate => "candidate",
        Role::Leader => "leader",
    }
}

/// The consensus note of a recorded note (`{"consensus":{...}}`, the `note` field of an
/// `events.jsonl` line); `None` for a behaviour's note or anything else.
pub fn from_json(note: &Value) -> Option<ConsensusNote> {
    ConsensusNote::deserialize(note.as_object()?.get("consensus")?).ok()
}

/// How `note` changes its robot's lane: `Boot` restarts it as a follower at the stored term
/// and commit, `State` sets role and term, `Commit` the commit index, `Quadrant` the group
/// leader (and whether the robot leads). Other notes leave the lane as it was.
pub fn lane_change(note: &ConsensusNote) -> Option<LaneChange> {
    let change = match *note {
        ConsensusNote::Boot { term, commit, .. } => LaneChange {
            role: Some(role_name(Role::Follower)),
            term: Some(term),
            commit: Some(commit),
            leader: None,
        },
        ConsensusNote::State { term, role, .. } => LaneChange {
            role: Some(role_name(role)),
            term: Some(term),
            ..LaneChange::default()
        },
        ConsensusNote::Commit { index } => LaneChange {
            commit: Some(index),
            ..LaneChange::default()
        },
        ConsensusNote::Quadrant { leader, leads, .. } => quadrant_lane(leader, leads),
        _ => return None,
    };
    Some(change)
}

/// The lane of a robot that chose `leader` as its group's quadrant leader (shared by the
/// consensus layer's `Quadrant` note and grouping's `Leader` note).
pub fn quadrant_lane(leader: u32, leads: bool) -> LaneChange {
    LaneChange {
        role: Some(if leads { "leader" } else { "follower" }),
        leader: Some(leader),
        ..LaneChange::default()
    }
}

/// The headline of a quadrant leader that declared itself (score: most group members it saw
/// in one quadrant).
pub fn quadrant_headline(score: u8) -> Headline {
    Headline {
        kind: "leader",
        text: format!("leads its group (quadrant score {score})"),
        others: Vec::new(),
    }
}

/// The notable consensus notes: a robot that became Raft leader of a term (`"elected"`), a
/// robot that declared itself quadrant leader (`"leader"`), a log truncated by a new leader
/// (`"truncate"`).
pub fn headline(note: &ConsensusNote) -> Option<Headline> {
    match *note {
        ConsensusNote::State {
            term,
            role: Role::Leader,
            ..
        } => Some(Headline {
            kind: "elected",
            text: format!("leader of term {term}"),
            others: Vec::new(),
        }),
        ConsensusNote::Quadrant {
            leads: true, score, ..
        } => Some(quadrant_headline(score)),
        ConsensusNote::Truncate { index } => Some(Headline {
            kind: "truncate",
            text: format!("log truncated from index {index} (conflict with the leader)"),
            others: Vec::new(),
        }),
        _ => None,
    }
}
