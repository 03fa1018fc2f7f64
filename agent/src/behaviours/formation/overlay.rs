//! What a viewer draws of a formation run: the observer each robot believes it is (its lidar
//! is on only then; the front observer leads the formation) from its `role` notes, and the
//! turns and epsilon-greedy flips as headlines.

use swarmrt_scenario::Config;

use super::messages::FormationNote;
use super::observers::ObserverRole;
use super::params::FormationParams;
use crate::overlay::{Headline, Overlay, RoleDef};

/// Indexed by the note's `role` (0 none, 1 middle, 2 left, 3 right), so the note is the role.
pub const ROLES: &[RoleDef] = &[
    RoleDef {
        name: "lidar off",
        colour: "#8c8c8c",
    },
    RoleDef {
        name: "front observer (leads)",
        colour: "#d62728",
    },
    RoleDef {
        name: "left observer",
        colour: "#1f77b4",
    },
    RoleDef {
        name: "right observer",
        colour: "#2ca02c",
    },
];

/// Every robot starts without a role (its lidar off) and notes the role it first takes.
fn initial_role(_cfg: &Config, _params: &FormationParams, _id: u32) -> Option<u8> {
    Some(ObserverRole::None as u8)
}

/// The `role` note is the new role; an unknown value reads as none, as on the wire.
fn role_after(note: &FormationNote) -> Option<u8> {
    match *note {
        FormationNote::Role { role } => Some(ObserverRole::from_u8(role) as u8),
        _ => None,
    }
}

/// A change of the swarm turn this robot decided, and each epsilon-greedy flip (section
/// 5.3): the moments the formation's direction changes.
fn headline(note: &FormationNote) -> Option<Headline> {
    let (kind, text) = match *note {
        FormationNote::EpsilonFlip => (
            "epsilon_flip",
            "epsilon-greedy flipped its turn".to_string(),
        ),
        FormationNote::Turn { dir } => {
            let to = match dir.signum() {
                1 => "left",
                -1 => "right",
                _ => "straight on",
            };
            ("turn", format!("turns the swarm {to}"))
        }
        FormationNote::Role { .. } => return None,
    };
    Some(Headline {
        kind,
        text,
        others: Vec::new(),
    })
}

impl Overlay for super::Formation {
    const ROLES: &'static [RoleDef] = ROLES;

    fn initial_role(cfg: &Config, params: &FormationParams, id: u32) -> Option<u8> {
        initial_role(cfg, params, id)
    }

    fn role_after(_params: &FormationParams, _id: u32, note: &FormationNote) -> Option<u8> {
        role_after(note)
    }

    fn headline(note: &FormationNote) -> Option<Headline> {
        headline(note)
    }
}
