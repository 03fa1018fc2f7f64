//! What a viewer draws of a flocking run: which flock each robot belongs to. Flock k is
//! start group k (`robots.start.groups` / `group_sizes`) for the whole run, and flocking
//! writes no notes, so the role is fixed at the start.

use swarmrt_scenario::Config;

use super::params::FlockingParams;
use crate::overlay::{Overlay, RoleDef};

/// One colour per flock; flocks beyond the eighth reuse them (flock k has role k mod 8).
pub const ROLES: &[RoleDef] = &[
    RoleDef {
        name: "flock 0",
        colour: "#1f77b4",
    },
    RoleDef {
        name: "flock 1",
        colour: "#ff7f0e",
    },
    RoleDef {
        name: "flock 2",
        colour: "#2ca02c",
    },
    RoleDef {
        name: "flock 3",
        colour: "#d62728",
    },
    RoleDef {
        name: "flock 4",
        colour: "#9467bd",
    },
    RoleDef {
        name: "flock 5",
        colour: "#8c564b",
    },
    RoleDef {
        name: "flock 6",
        colour: "#e377c2",
    },
    RoleDef {
        name: "flock 7",
        colour: "#17becf",
    },
];

/// Robot `id`'s flock: its start group, as [`super::Flocking`] itself takes it.
fn initial_role(cfg: &Config, _params: &FlockingParams, id: u32) -> Option<u8> {
    Some((cfg.start_group(id) % ROLES.len()) as u8)
}

impl Overlay for super::Flocking {
    const ROLES: &'static [RoleDef] = ROLES;

    fn initial_role(cfg: &Config, params: &FlockingParams, id: u32) -> Option<u8> {
        initial_role(cfg, params, id)
    }
}
