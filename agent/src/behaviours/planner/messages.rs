//! What a vehicle says over the radio and reports in the record.

use serde::{Deserialize, Serialize};

use crate::consensus::RoutePart;

/// What a vehicle broadcasts.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub enum PlannerMsg {
    /// Every tick: where it is and what it is doing.
    Beacon(Beacon),
    /// One part of the detour it planned on board (`on_leader_loss = "continue"`), sent one
    /// part per tick in turn while it flies the detour, so a peer that lost a frame gets it
    /// again.
    Detour(Detour),
}

/// One part of a detour: a route a vehicle planned for itself on board, outside the log.
/// `part.plan` is the committed plan it replaces (a newer committed plan replaces it in turn).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Detour {
    /// The vehicle's count of its detours (higher is newer).
    pub seq: u32,
    /// The route part, as a log entry carries one.
    pub part: RoutePart,
}

/// A vehicle's beacon, every tick: where it is and what it is doing. The leader plans from
/// these positions; a vehicle that hears another one hovering in its own plan hovers too.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Beacon {
    /// Estimated position `[x, y, z]`, metres.
    pub pos: [f32; 3],
    /// The newest plan it has a route of (0: none yet).
    pub plan: u32,
    /// Holding its position, not flying a route.
    pub hovering: bool,
    /// At its goal, for good.
    pub arrived: bool,
    /// The detour it flies (its count, 0: it flies its committed route or hovers), so a
    /// vehicle that has not yet received the detour knows the committed route is stale.
    pub detour: u32,
}

/// Why a vehicle stopped flying and hovers.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum HoverWhy {
    /// A vehicle went silent (dead, or out of radio contact).
    Lost,
    /// A vehicle of its plan hovers (one stop stops all: the routes were planned together).
    Peer,
    /// Its route committed after the route's start: following it would cut corners in time.
    Late,
    /// A silent or hovering vehicle, or another detour, blocks its route and it found no
    /// detour on board (it tries again after `settle` ticks).
    Blocked,
}

/// What a vehicle reports about itself (`events.jsonl`).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum PlanNote {
    /// The leader planned `vehicle`'s route of plan `plan`: `moves` slots from `start_slot`,
    /// the search's cost and expansions (eq. 3).
    Planned {
        /// Plan number.
        plan: u32,
        /// Vehicle.
        vehicle: u32,
        /// Slot of the first cell.
        start_slot: u32,
        /// Moves (slots) to the goal.
        moves: u32,
        /// Route cost: distance plus potential.
        cost: f32,
        /// States expanded by the search.
        expansions: u32,
    },
    /// The leader found no route for `vehicle` (it hovers and the leader tries again).
    NoRoute {
        /// Plan number.
        plan: u32,
        /// Vehicle.
        vehicle: u32,
    },
    /// This vehicle flies plan `plan`'s route from now on.
    Flying {
        /// Plan number.
        plan: u32,
    },
    /// This vehicle stopped and hovers.
    Hover {
        /// The plan it was flying.
        plan: u32,
        /// Why.
        why: HoverWhy,
    },
    /// This vehicle is at its goal.
    Arrived,
    /// This vehicle planned its own detour on board (`on_leader_loss = "continue"`): `moves`
    /// slots from `start_slot`, its cost and expansions, replacing plan `plan`.
    Detour {
        /// The committed plan it replaces.
        plan: u32,
        /// The vehicle's count of its detours.
        seq: u32,
        /// Slot of the first cell.
        start_slot: u32,
        /// Moves (slots) to the goal.
        moves: u32,
        /// Route cost: distance plus potential.
        cost: f32,
        /// States expanded by the search.
        expansions: u32,
    },
}
