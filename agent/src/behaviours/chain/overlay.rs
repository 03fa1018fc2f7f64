//! What a viewer draws of a chain run: the structure fixed by the parameters (the initiator,
//! the masters along the chain, the slaves at its ends, the stationary robots) and, from its
//! notes, a robot that vetoes; vetoes and the initiator's re-plans as headlines.

use swarmrt_scenario::Config;

use super::messages::{ChainNote, VetoWhy};
use super::params::ChainParams;
use crate::overlay::{Headline, Overlay, RoleDef};

/// The initiator (`behaviour.initiator`): it moves on its own and re-plans after a veto.
pub const INITIATOR: u8 = 0;
/// A slave that is also its slave's master (inside the chain).
pub const MASTER: u8 = 1;
/// A slave at an end of the chain: master of nobody.
pub const SLAVE: u8 = 2;
/// A stationary robot (`behaviour.stationary`): it never moves, and vetoes relocations.
pub const STATIONARY: u8 = 3;
/// It noted a veto of its master. The record has no note for a veto lapsing, so the role
/// holds until the robot's next note (a new veto, or the initiator's re-plan).
pub const VETOING: u8 = 4;

/// Indexed by the constants above.
pub const ROLES: &[RoleDef] = &[
    RoleDef {
        name: "initiator",
        colour: "#d62728",
    },
    RoleDef {
        name: "master",
        colour: "#1f77b4",
    },
    RoleDef {
        name: "end slave",
        colour: "#17becf",
    },
    RoleDef {
        name: "stationary",
        colour: "#8c564b",
    },
    RoleDef {
        name: "vetoing",
        colour: "#ff7f0e",
    },
];

/// The structure of [`super::Chain::new`]: robot `i`'s master is its neighbour towards the
/// initiator, so every robot but the two ends (and the initiator) is a master too.
fn initial_role(cfg: &Config, params: &ChainParams, id: u32) -> Option<u8> {
    let c = params.initiator;
    let role = if id == c {
        INITIATOR
    } else if params.stationary.contains(&id) {
        STATIONARY
    } else {
        // Its slave is its neighbour away from the initiator, if the chain goes on.
        let slave = if id > c {
            id.checked_add(1)
        } else {
            id.checked_sub(1)
        };
        match slave {
            Some(s) if s < cfg.robots.count => MASTER,
            _ => SLAVE,
        }
    };
    Some(role)
}

/// A veto marks the robot vetoing; the initiator's re-plan is its own role again.
fn role_after(note: &ChainNote) -> Option<u8> {
    match note {
        ChainNote::Veto { .. } => Some(VETOING),
        ChainNote::Replan { .. } => Some(INITIATOR),
    }
}

/// A veto names the master it objects to; a re-plan says how far the veto came and the
/// turn it made.
fn headline(note: &ChainNote) -> Option<Headline> {
    Some(match *note {
        ChainNote::Veto { master, depth, why } => {
            let why = match why {
                VetoWhy::Stationary => "stationary, its master left the rod limits",
                VetoWhy::Trapped => "trapped, no free guiding line",
                VetoWhy::Passed => "passing on its slave's veto",
            };
            Headline {
                kind: "veto",
                text: format!("vetoes master {master} ({why}; depth {depth})"),
                others: vec![master],
            }
        }
        ChainNote::Replan { depth, turn_deg } => Headline {
            kind: "replan",
            text: format!(
                "re-plans: a veto came {depth} robot(s) back, turns {:.0} degrees {}",
                turn_deg.abs(),
                if turn_deg >= 0.0 { "left" } else { "right" }
            ),
            others: Vec::new(),
        },
    })
}

impl Overlay for super::Chain {
    const ROLES: &'static [RoleDef] = ROLES;

    fn initial_role(cfg: &Config, params: &ChainParams, id: u32) -> Option<u8> {
        initial_role(cfg, params, id)
    }

    fn role_after(_params: &ChainParams, _id: u32, note: &ChainNote) -> Option<u8> {
        role_after(note)
    }

    fn headline(note: &ChainNote) -> Option<Headline> {
        headline(note)
    }
}
