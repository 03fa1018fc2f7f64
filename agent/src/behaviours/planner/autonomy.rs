//! Seed 002's autonomous mode (`on_leader_loss = "continue"`): after eq. 3 the paper builds
//! the route and the motion command on the vehicle, "which allows switching to autonomous
//! mode if communication with the leader is lost". Here:
//! - a UAV keeps flying its committed route when a vehicle falls silent or the leader is
//!   gone: the routes were planned together and stay conflict-free;
//! - it deviates only when its route is blocked from now on: by a silent vehicle where it
//!   was last heard (it may have died there), by a vehicle that hovers for `settle` ticks, or
//!   by another vehicle's detour that it must give way to (see [`Planner::gives_way`]);
//! - it then plans a detour on board with the same time-dependent A* and potential (eq. 1-3)
//!   against every other vehicle's known route, flies it, and announces it over the radio one
//!   part per tick; the others treat it as occupied. A newer committed plan (a leader back)
//!   replaces a detour.

use swarmrt_planner::{Cell, Job, Reservations, Route, Trajectory};
use swarmrt_protocol::BROADCAST;

use super::messages::{Detour, PlannerMsg};
use super::{HoverWhy, Mode, PlanNote, Planner, split};
use crate::behaviour::Act;
use crate::consensus::{ROUTE_PART_MOVES, RoutePart};

/// What another vehicle is known to fly.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum RouteKind {
    /// Committed to the log in plan `plan`.
    Committed(u32),
    /// Its own detour replacing plan `plan`.
    Detour(u32),
}

impl Planner {
    /// The slot that holds time `t`.
    fn slot_at(&self, t: f64) -> i64 {
        (t / self.p.slot() + 1e-9).floor() as i64
    }

    /// What vehicle `v` flies as far as this vehicle knows: the detour its beacon names once
    /// received, else its newest committed route; `None` while its detour is on the way (the
    /// committed route is stale then) or it has no route.
    pub(super) fn route_of(&self, v: u32) -> Option<(RouteKind, &Route)> {
        let flies = self.peers[v as usize].beacon.map_or(0, |b| b.detour);
        match self.detours.get(&v) {
            Some((seq, base, r)) if flies > 0 && *seq >= flies => {
                return Some((RouteKind::Detour(*base), r));
            }
            _ if flies > 0 => return None,
            _ => {}
        }
        self.routes
            .get(&v)
            .map(|(plan, r)| (RouteKind::Committed(*plan), r))
    }

    /// Whether this vehicle, flying a route of kind `mine`, must give way to `v` flying one
    /// of kind `theirs` when the two meet: routes of one committed plan were planned together
    /// and never meet; a detour gives way to a committed route (it was planned against it,
    /// so it must be stale); of two detours the higher id gives way; of two committed plans
    /// the older one.
    fn gives_way(&self, mine: RouteKind, v: u32, theirs: RouteKind) -> bool {
        match (mine, theirs) {
            (RouteKind::Committed(a), RouteKind::Committed(b)) => a < b,
            (RouteKind::Committed(_), RouteKind::Detour(_)) => false,
            (RouteKind::Detour(_), RouteKind::Committed(_)) => true,
            (RouteKind::Detour(_), RouteKind::Detour(_)) => self.id > v,
        }
    }

    /// The cell where vehicle `v` was last heard (its start if never).
    fn last_cell(&self, v: usize) -> Cell {
        let pos = self.peers[v]
            .beacon
            .map(|b| [b.pos[0] as f64, b.pos[1] as f64, b.pos[2] as f64])
            .unwrap_or(self.starts[v]);
        self.grid.nearest_cell(pos)
    }

    /// Whether vehicle `v` hovers short of its goal and has done so for `settle` ticks: it
    /// no longer follows a route, so it is an obstacle where it is. A vehicle that has never
    /// flown, or whose newer committed route is on its way, is waiting for that route, not
    /// stuck.
    fn stuck(&self, v: usize, tick: u64) -> bool {
        let peer = &self.peers[v];
        let newest = self.routes.get(&(v as u32)).map_or(0, |(p, _)| *p);
        !peer.lost
            && peer
                .beacon
                .is_some_and(|b| b.hovering && !b.arrived && b.plan != 0 && b.plan >= newest)
            && peer
                .hover_since
                .is_some_and(|s| tick >= s + self.p.settle as u64)
    }

    /// Whether the route this vehicle flies is blocked from the current slot on: by a silent
    /// vehicle where it was last heard, by a stuck or arrived one where it is, or by a route
    /// it must give way to.
    pub(super) fn blocked(&self, tick: u64) -> bool {
        let Mode::Fly { route, kind, .. } = &self.mode else {
            return false;
        };
        let Ok(mut res) = Reservations::new(&self.grid, &self.pp) else {
            return false;
        };
        for v in 0..self.peers.len() {
            if v == self.id as usize {
                continue;
            }
            let arrived = self.peers[v].beacon.is_some_and(|b| b.arrived);
            if self.peers[v].lost || self.stuck(v, tick) || arrived {
                // An arrived vehicle is parked at its goal whatever route it flew there.
                res.add_dead(v as u32, self.last_cell(v));
            }
            if arrived {
                continue;
            }
            if let Some((theirs, r)) = self.route_of(v as u32)
                && self.gives_way(*kind, v as u32, theirs)
            {
                res.add_route(v as u32, r);
            }
        }
        let from = self.slot_at(self.now(tick)).max(i64::from(route.start_slot));
        let to = i64::from(route.end_slot()) + i64::from(res.pad());
        (from..=to).any(|s| res.occupied_cell(&self.grid, route.cell_at(s), s, self.id))
    }

    /// Plans a detour on board from where this vehicle is, against every other vehicle's
    /// known route (a silent one also where it was last heard, a stuck or route-less one
    /// where it is), and flies it. `false` when no route exists now.
    pub(super) fn detour(&mut self, tick: u64, act: &mut Act<PlannerMsg, PlanNote>) -> bool {
        let Ok(mut res) = Reservations::new(&self.grid, &self.pp) else {
            return false;
        };
        for v in 0..self.peers.len() {
            if v == self.id as usize {
                continue;
            }
            let peer = &self.peers[v];
            let arrived = peer.beacon.is_some_and(|b| b.arrived);
            let route = self.route_of(v as u32).map(|(_, r)| r);
            if peer.lost {
                if let Some(r) = route {
                    res.add_route(v as u32, r);
                }
                res.add_dead(v as u32, self.last_cell(v));
            } else if arrived || self.stuck(v, tick) || route.is_none() {
                res.add_dead(v as u32, self.last_cell(v));
            } else if let Some(r) = route {
                res.add_route(v as u32, r);
            }
        }
        let job = Job {
            vehicle: self.id,
            start: self.grid.nearest_cell(self.pos),
            goal: self.grid.nearest_cell(self.goals[self.id as usize]),
            start_slot: (self.slot_at(self.now(tick)) + 1).max(0) as u32,
        };
        let Ok(route) = self.search.plan(&self.grid, &res, &job, &self.pp) else {
            return false;
        };
        self.seq += 1;
        act.note(PlanNote::Detour {
            plan: self.plan,
            seq: self.seq,
            start_slot: route.start_slot,
            moves: route.cells.len().saturating_sub(1) as u32,
            cost: route.cost as f32,
            expansions: route.expansions.min(u32::MAX as u64) as u32,
        });
        self.mine = split(self.plan, self.id, &route);
        self.cursor = 0;
        let slot = self.p.slot();
        let traj = Trajectory::new(
            &self.grid,
            &route,
            slot,
            Some(self.pos),
            self.p.n_points as usize,
        );
        let end = route.end_slot() as f64 * slot;
        self.mode = Mode::Fly {
            traj,
            end,
            route,
            kind: RouteKind::Detour(self.plan),
        };
        true
    }

    /// Continue mode's turn, after the beacons and routes of this tick are in: a flying
    /// vehicle whose route is blocked detours (or hovers, `Blocked`, and retries after
    /// `settle` ticks); a hovering one that has flown before retries when due.
    pub(super) fn autonomy(&mut self, tick: u64, recheck: bool, act: &mut Act<PlannerMsg, PlanNote>) {
        let retry = self.p.settle.max(1) as u64;
        let flying = matches!(self.mode, Mode::Fly { .. });
        if flying && recheck && self.blocked(tick) {
            if !self.detour(tick, act) {
                self.hover(tick, Some(HoverWhy::Blocked), act);
                self.retry_at = Some(tick + retry);
            }
        } else if !flying && self.retry_at.is_some_and(|t| tick >= t) {
            // Hovering (an arrived vehicle never has a retry due).
            self.retry_at = (!self.detour(tick, act)).then_some(tick + retry);
        }
    }

    /// Sends the next part of this vehicle's detour, in turn, while it flies it.
    pub(super) fn announce(&mut self, act: &mut Act<PlannerMsg, PlanNote>) {
        let flying_detour = matches!(
            self.mode,
            Mode::Fly {
                kind: RouteKind::Detour(_),
                ..
            }
        );
        if !flying_detour || self.mine.is_empty() {
            return;
        }
        let part = self.mine[self.cursor % self.mine.len()];
        self.cursor = (self.cursor + 1) % self.mine.len();
        act.send(
            BROADCAST,
            PlannerMsg::Detour(Detour {
                seq: self.seq,
                part,
            }),
        );
    }

    /// Collects a part of vehicle `src`'s detour; `true` when it completed a newer detour.
    pub(super) fn collect_detour(&mut self, src: u32, d: Detour) -> bool {
        let part = d.part;
        if part.vehicle != src || part.parts == 0 || part.part >= part.parts {
            return false;
        }
        if self.detours.get(&src).is_some_and(|(seq, _, _)| *seq >= d.seq) {
            return false;
        }
        // Older detours of this vehicle are of no use any more.
        self.detour_parts
            .retain(|&(v, seq), _| v != src || seq >= d.seq);
        let slots = self
            .detour_parts
            .entry((src, d.seq))
            .or_insert_with(|| vec![None; part.parts as usize]);
        if slots.len() != part.parts as usize {
            return false;
        }
        slots[part.part as usize] = Some(part);
        if slots.iter().any(Option::is_none) {
            return false;
        }
        let Some(slots) = self.detour_parts.remove(&(src, d.seq)) else {
            return false;
        };
        let Some(route) = route_of_parts(&slots) else {
            return false;
        };
        self.detours.insert(src, (d.seq, part.plan, route));
        true
    }
}

/// The route that complete `parts` describe (`None` when they do not form one).
pub(super) fn route_of_parts(parts: &[Option<RoutePart>]) -> Option<Route> {
    let first = parts.first().copied().flatten()?;
    let start = Cell {
        i: first.start[0],
        j: first.start[1],
        k: first.start[2],
    };
    let moves: Vec<u8> = parts
        .iter()
        .flatten()
        .flat_map(|p| p.moves[..(p.len as usize).min(ROUTE_PART_MOVES)].iter().copied())
        .collect();
    Route::from_moves(start, first.start_slot, &moves).ok()
}
