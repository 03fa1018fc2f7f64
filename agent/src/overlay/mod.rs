//! What a viewer draws of a run besides the robots' poses and states: each behaviour's
//! **roles** (a robot's colour, e.g. a chain's initiator or a planner's vehicle in flight),
//! its **headlines** (the notable notes on the event timeline) and the consensus layer's
//! **lanes** (Raft role, term and commit, or the quadrant leader a robot follows).
//!
//! Each behaviour declares its own by implementing [`Overlay`] in
//! `behaviours/<name>/overlay.rs` (its `mod.rs` only says `mod overlay;`);
//! [`crate::registry::Plugin`] offers it with the note as it is recorded in `events.jsonl`,
//! so a viewer needs no behaviour's types. Everything here is read after the run from the
//! records: nothing of it runs in a robot, and no record changes because of it.

pub mod lane;

use serde::Serialize;
use swarmrt_scenario::Config;

use crate::behaviour::Behaviour;

/// What a viewer draws of a behaviour, beside the robots' poses and states. Every item has a
/// default (no roles, no headlines), so a behaviour without an overlay says `impl Overlay for
/// X {}`; the registry requires the impl, so a new behaviour cannot forget it.
pub trait Overlay: Behaviour {
    /// The roles its robots are coloured by; a role is an index into this list.
    const ROLES: &'static [RoleDef] = &[];

    /// Robot `id`'s role at the start of the run.
    fn initial_role(_cfg: &Config, _params: &Self::Params, _id: u32) -> Option<u8> {
        None
    }

    /// Robot `id`'s role after it reported `note`; `None`: unchanged.
    fn role_after(_params: &Self::Params, _id: u32, _note: &Self::Note) -> Option<u8> {
        None
    }

    /// `note` as a headline of the event timeline, when it is notable.
    fn headline(_note: &Self::Note) -> Option<Headline> {
        None
    }

    /// How `note` changes the reporter's consensus lane, for a behaviour that runs a
    /// consensus core itself (grouping's quadrant leader choice); the consensus layer's own
    /// notes are [`lane`]'s.
    fn lane(_note: &Self::Note) -> Option<LaneChange> {
        None
    }
}

/// One role a behaviour colours its robots by.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub struct RoleDef {
    /// Its name in the legend, e.g. `"initiator"`.
    pub name: &'static str,
    /// A CSS colour (`"#rrggbb"`) readable on a white background.
    pub colour: &'static str,
}

/// A notable note for the event timeline.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct Headline {
    /// What happened, one word: `"veto"`, `"replan"`, `"epsilon_flip"`, `"elected"`, ...
    pub kind: &'static str,
    /// A short sentence about the robot that reported it ("vetoes master 4 (stationary)").
    pub text: String,
    /// The other robots involved (a veto's master, a planned vehicle), besides the reporter.
    pub others: Vec<u32>,
}

/// How a robot's consensus lane changes with one note; `None` fields stay as they were.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize)]
pub struct LaneChange {
    /// Raft role (`"follower"`, `"pre_candidate"`, `"candidate"`, `"leader"`); for the
    /// quadrant leader choice `"leader"` (it leads its group) or `"follower"`.
    pub role: Option<&'static str>,
    /// Raft term.
    pub term: Option<u64>,
    /// Raft commit index.
    pub commit: Option<u64>,
    /// Quadrant leader choice: the leader of the group this robot belongs to (itself when it
    /// leads), i.e. the group's id.
    pub leader: Option<u32>,
}
