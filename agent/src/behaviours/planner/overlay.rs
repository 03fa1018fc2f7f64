//! What a viewer draws of a planner run: each vehicle hovering, in flight, arrived, or left
//! without a route, from its own notes; the leader's plans, failed searches, hovers and
//! arrivals as headlines (the planned vehicle among the robots involved).

use swarmrt_scenario::Config;

use super::PLAN_COUNT_BITS;
use super::messages::{HoverWhy, PlanNote};
use super::params::PlannerParams;
use crate::overlay::{Headline, Overlay, RoleDef};

/// Holding its position (every vehicle starts so, until its first route commits).
pub const HOVERING: u8 = 0;
/// Flying a committed route.
pub const IN_FLIGHT: u8 = 1;
/// At its goal for good.
pub const ARRIVED: u8 = 2;
/// The leader planning its own route found none (it hovers until the next plan).
pub const NO_ROUTE: u8 = 3;

/// Indexed by the constants above.
pub const ROLES: &[RoleDef] = &[
    RoleDef {
        name: "hovering",
        colour: "#ff7f0e",
    },
    RoleDef {
        name: "in flight",
        colour: "#1f77b4",
    },
    RoleDef {
        name: "arrived",
        colour: "#2ca02c",
    },
    RoleDef {
        name: "no route",
        colour: "#d62728",
    },
];

/// Every vehicle hovers at its start until a route of its term commits.
fn initial_role(_cfg: &Config, _params: &PlannerParams, _id: u32) -> Option<u8> {
    Some(HOVERING)
}

/// `Flying`, `Hover` and `Arrived` are the vehicle's own mode. `NoRoute` and `Planned` are
/// the leader's notes about `vehicle`: they change the reporter's role only when it is that
/// vehicle (no route: it hovers, flagged; planned: it still hovers until `Flying`).
fn role_after(id: u32, note: &PlanNote) -> Option<u8> {
    match *note {
        PlanNote::Flying { .. } => Some(IN_FLIGHT),
        PlanNote::Hover { .. } => Some(HOVERING),
        PlanNote::Arrived => Some(ARRIVED),
        PlanNote::NoRoute { vehicle, .. } if vehicle == id => Some(NO_ROUTE),
        PlanNote::Detour { .. } => Some(IN_FLIGHT),
        PlanNote::NoRoute { .. } | PlanNote::Planned { .. } => None,
    }
}

/// A plan number as `count of term` (plans are `term << 12 | count`).
fn plan_name(plan: u32) -> String {
    format!(
        "plan {} of term {}",
        plan & ((1 << PLAN_COUNT_BITS) - 1),
        plan >> PLAN_COUNT_BITS
    )
}

/// The leader's (re-)plans and failed searches, with the vehicle involved; a vehicle's hover
/// (why it stopped) and arrival. `Flying` is left to the role.
fn headline(note: &PlanNote) -> Option<Headline> {
    let (kind, text, others) = match *note {
        PlanNote::Planned {
            plan,
            vehicle,
            moves,
            ..
        } => (
            "replan",
            format!(
                "planned vehicle {vehicle}: {moves} moves ({})",
                plan_name(plan)
            ),
            vec![vehicle],
        ),
        PlanNote::NoRoute { plan, vehicle } => (
            "no_route",
            format!("no route for vehicle {vehicle} ({})", plan_name(plan)),
            vec![vehicle],
        ),
        PlanNote::Hover { plan, why } => {
            let why = match why {
                HoverWhy::Lost => "a vehicle went silent",
                HoverWhy::Peer => "a vehicle of its plan hovers",
                HoverWhy::Late => "its route committed too late",
                HoverWhy::Blocked => "its route is blocked and no detour exists yet",
            };
            (
                "hover",
                format!("hovers: {why} ({})", plan_name(plan)),
                Vec::new(),
            )
        }
        PlanNote::Arrived => ("arrived", "at its goal".to_string(), Vec::new()),
        PlanNote::Detour {
            plan, seq, moves, ..
        } => (
            "detour",
            format!(
                "detour {seq} planned on board: {moves} moves (replaces {})",
                plan_name(plan)
            ),
            Vec::new(),
        ),
        PlanNote::Flying { .. } => return None,
    };
    Some(Headline { kind, text, others })
}

impl Overlay for super::Planner {
    const ROLES: &'static [RoleDef] = ROLES;

    fn initial_role(cfg: &Config, params: &PlannerParams, id: u32) -> Option<u8> {
        initial_role(cfg, params, id)
    }

    fn role_after(_params: &PlannerParams, id: u32, note: &PlanNote) -> Option<u8> {
        role_after(id, note)
    }

    fn headline(note: &PlanNote) -> Option<Headline> {
        headline(note)
    }
}
