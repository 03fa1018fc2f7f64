//! Collision-free routes for a UAV swarm (seed 002: Marchenko & Ponomarenko 2024): the Raft
//! leader plans every vehicle's route with the time-dependent A* of `swarmrt_planner`
//! (eq. 1-3) and commits the routes to the replicated log; a vehicle flies only a committed
//! route, following its smoothed trajectory on time.
//!
//! The paper assumes the leader is chosen and messages arrive without delay. Over a lossy
//! radio with processes that die, this behaviour adds (each choice is in docs/results/
//! seed002.md):
//! - **Hover first, then re-plan.** A vehicle that stops flying its route hovers where it is:
//!   when another vehicle goes silent for `lost_after` ticks (dead, frozen, out of range),
//!   when a vehicle of its own plan hovers (routes were planned together, so one stop stops
//!   all), or when its route committed after its start (`Late`). Every vehicle beacons its
//!   position and state each tick.
//! - **The leader plans once everyone hovers.** When every live vehicle that has not arrived
//!   has been hovering for `settle` ticks, and has already seen its newest route (so it is
//!   not simply waiting for a commit), the leader plans them all from their hover cells,
//!   `lead_time` seconds ahead, around the parked vehicles (arrived ones at their goals, lost
//!   ones where they were last heard), and proposes the routes, one part per tick.
//! - **Autonomy when the plan breaks** (`on_leader_loss = "continue"`, the default, the
//!   paper's): a vehicle flies its committed route on through a silent vehicle or a lost
//!   leader and detours on board only when its route is blocked ([`autonomy`]). With
//!   `"hover"` it hovers as described above and waits for a leader's plan.
//! - **Plans belong to a term.** A plan's number is `term << 12 | count`; a vehicle takes a
//!   route only of the term it is in, so the routes of a leader that died before they
//!   committed can never be flown after a new leader took over.

mod autonomy;
mod messages;
mod overlay;
mod params;
pub mod scene;
pub mod metrics;

use std::collections::{BTreeMap, VecDeque};

use swarmrt_planner::{
    Grid, Job, PlanParams, Planner as Search, Reservations, Route, Trajectory, plan_all,
};
use swarmrt_protocol::{BROADCAST, Observation};
use swarmrt_scenario::Config;

use crate::behaviour::{Act, Behaviour};
use crate::consensus::{Decision, Leadership, ROUTE_PART_MOVES, RoutePart};
use crate::inbox::Heard;
use autonomy::RouteKind;
pub use messages::{Beacon, Detour, HoverWhy, PlanNote, PlannerMsg};
pub use params::{OnLeaderLoss, PlannerParams};

/// Bits of a plan number that count plans within one term.
const PLAN_COUNT_BITS: u32 = 12;

/// What a vehicle is doing.
#[derive(Debug, Clone)]
enum Mode {
    /// Holding `at` since tick `since`.
    Hover { at: [f64; 3], since: u64 },
    /// Following `traj`, the smoothed `route` (committed or a detour), until `end` seconds.
    Fly {
        traj: Trajectory,
        end: f64,
        route: Route,
        kind: RouteKind,
    },
    /// At the goal for good, holding `at`.
    Arrived { at: [f64; 3] },
}

/// The last beacon of a vehicle and when it came.
#[derive(Debug, Clone, Copy)]
struct Peer {
    heard: u64,
    beacon: Option<Beacon>,
    /// Tick since which its beacons say "hovering" without a break.
    hover_since: Option<u64>,
    lost: bool,
}

/// One vehicle's planner behaviour.
pub struct Planner {
    id: u32,
    p: PlannerParams,
    pp: PlanParams,
    grid: Grid,
    dt: f64,
    max_speed: f64,
    max_vz: f64,
    goals: Vec<[f64; 3]>,
    starts: Vec<[f64; 3]>,
    mode: Mode,
    /// Newest plan of which this vehicle has seen its own route (0: none).
    plan: u32,
    /// Parts of routes being committed: (plan, vehicle) -> parts.
    parts: BTreeMap<(u32, u32), Vec<Option<RoutePart>>>,
    /// Every vehicle's newest complete route: vehicle -> (plan, route).
    routes: BTreeMap<u32, (u32, Route)>,
    peers: Vec<Peer>,
    lead: Option<Leadership>,
    /// As leader: decisions still to propose (front first), with the note each one carries.
    queue: VecDeque<(Decision, Option<PlanNote>)>,
    /// Proposals handed to the consensus layer last tick.
    in_flight: usize,
    /// Notes of proposals the log took, to report this tick.
    due: Vec<PlanNote>,
    /// As leader: the plan being committed, until all its parts are applied here.
    awaiting: Option<(u32, usize)>,
    /// Plans made in the current term.
    count: u32,
    last_tick: Option<u64>,
    pos: [f64; 3],
    /// Other vehicles' newest complete detours: vehicle -> (seq, plan it replaces, route).
    detours: BTreeMap<u32, (u32, u32, Route)>,
    /// Parts of detours being received: (vehicle, seq) -> parts.
    detour_parts: BTreeMap<(u32, u32), Vec<Option<RoutePart>>>,
    /// This vehicle's own newest detour, as parts to announce, and its count.
    mine: Vec<RoutePart>,
    seq: u32,
    /// The part of `mine` to announce next.
    cursor: usize,
    /// Continue mode: when a hovering vehicle tries to detour again.
    retry_at: Option<u64>,
    /// The on-board search, its buffers kept between detours.
    search: Search,
}

impl Planner {
    fn plan_term(plan: u32) -> u64 {
        (plan >> PLAN_COUNT_BITS) as u64
    }

    fn now(&self, tick: u64) -> f64 {
        tick as f64 * self.dt
    }

    fn continues(&self) -> bool {
        self.p.on_leader_loss == OnLeaderLoss::Continue
    }

    fn hover(&mut self, tick: u64, why: Option<HoverWhy>, act: &mut Act<PlannerMsg, PlanNote>) {
        if matches!(self.mode, Mode::Fly { .. }) {
            self.mode = Mode::Hover {
                at: self.pos,
                since: tick,
            };
            if let Some(why) = why {
                act.note(PlanNote::Hover {
                    plan: self.plan,
                    why,
                });
            }
        }
    }

    /// Collects a committed route part; a route with all its parts becomes the vehicle's
    /// newest route.
    fn collect(&mut self, part: RoutePart) {
        if part.parts == 0 || part.part >= part.parts {
            return;
        }
        let key = (part.plan, part.vehicle);
        let slots = self
            .parts
            .entry(key)
            .or_insert_with(|| vec![None; part.parts as usize]);
        if slots.len() != part.parts as usize {
            return;
        }
        slots[part.part as usize] = Some(part);
        if slots.iter().any(Option::is_none) {
            return;
        }
        let Some(slots) = self.parts.remove(&key) else {
            return;
        };
        let Some(route) = autonomy::route_of_parts(&slots) else {
            return;
        };
        let newer = self
            .routes
            .get(&part.vehicle)
            .is_none_or(|(plan, _)| *plan < part.plan);
        if newer {
            self.routes.insert(part.vehicle, (part.plan, route));
        }
        if let Some((plan, left)) = &mut self.awaiting
            && *plan == part.plan
        {
            *left = left.saturating_sub(1);
            if *left == 0 {
                self.awaiting = None;
            }
        }
    }

    /// Takes this vehicle's newest route if it is newer than what it flies, of the current
    /// term, and not already late.
    fn take_route(&mut self, tick: u64, act: &mut Act<PlannerMsg, PlanNote>) {
        // Checked before the clone: this runs every tick and is almost always a no-op.
        let plan = match self.routes.get(&self.id) {
            Some((plan, _)) if *plan > self.plan => *plan,
            _ => return,
        };
        if matches!(self.mode, Mode::Arrived { .. }) {
            return;
        }
        let route = self.routes[&self.id].1.clone();
        self.plan = plan;
        let term = self.lead.map_or(0, |l| l.term);
        let slot = self.p.slot();
        let start = route.start_slot as f64 * slot;
        if Self::plan_term(plan) != term {
            // A dead leader's plan: its vehicles hover until the current leader plans.
            return;
        }
        if self.now(tick) > start + slot {
            act.note(PlanNote::Hover {
                plan,
                why: HoverWhy::Late,
            });
            if self.continues() {
                // Autonomous mode: plan from here on board, now.
                self.hover(tick, None, act);
                self.retry_at = Some(tick);
            }
            return;
        }
        let at = match self.mode {
            Mode::Hover { at, .. } => at,
            _ => self.pos,
        };
        let traj = Trajectory::new(&self.grid, &route, slot, Some(at), self.p.n_points as usize);
        let end = route.end_slot() as f64 * slot;
        self.mode = Mode::Fly {
            traj,
            end,
            route,
            kind: RouteKind::Committed(plan),
        };
        self.retry_at = None;
        act.note(PlanNote::Flying { plan });
    }

    /// Velocity toward `target` moving at `feed`, within the limits.
    fn steer(&self, target: [f64; 3], feed: [f64; 3]) -> [f64; 3] {
        let k = self.p.gain;
        let mut v = [0.0; 3];
        for a in 0..3 {
            v[a] = feed[a] + k * (target[a] - self.pos[a]);
        }
        let h = v[0].hypot(v[1]);
        if h > self.max_speed {
            v[0] *= self.max_speed / h;
            v[1] *= self.max_speed / h;
        }
        v[2] = v[2].clamp(-self.max_vz, self.max_vz);
        v
    }

    /// As leader: plans every live vehicle that has not arrived, once they all hover.
    fn lead_plan(&mut self, tick: u64, act: &mut Act<PlannerMsg, PlanNote>) {
        let Some(lead) = self.lead.filter(|l| l.is_leader) else {
            self.queue.clear();
            self.awaiting = None;
            return;
        };
        if !self.queue.is_empty() || self.awaiting.is_some() {
            return;
        }
        let mut settle = self.p.settle as u64;
        if self.continues() && self.plan != 0 {
            // In flight every vehicle re-plans itself on board each `settle` ticks: the
            // leader steps in only for vehicles that stayed stuck four times as long.
            settle *= 4;
        }
        let me = self.id as usize;
        let mut jobs_at: Vec<(u32, [f64; 3])> = Vec::new();
        let mut parked: Vec<(u32, [f64; 3])> = Vec::new();
        let mut someone_hovers = false;
        for (v, peer) in self.peers.iter().enumerate() {
            let (pos, hovering, arrived, plan, since) = if v == me {
                let (hovering, arrived, since) = match self.mode {
                    Mode::Hover { since, .. } => (true, false, Some(since)),
                    Mode::Fly { .. } => (false, false, None),
                    Mode::Arrived { .. } => (false, true, None),
                };
                (self.pos, hovering, arrived, self.plan, since)
            } else {
                let heard = peer.beacon.map(|b| [b.pos[0] as f64, b.pos[1] as f64, b.pos[2] as f64]);
                if peer.lost {
                    parked.push((v as u32, heard.unwrap_or(self.starts[v])));
                    continue;
                }
                let (Some(b), Some(pos)) = (peer.beacon, heard) else {
                    return; // not heard yet: wait
                };
                (pos, b.hovering, b.arrived, b.plan, peer.hover_since)
            };
            if arrived {
                parked.push((v as u32, pos));
                continue;
            }
            let newest = self.routes.get(&(v as u32)).map_or(0, |(p, _)| *p);
            let settled = since.is_some_and(|s| tick >= s + settle);
            if !hovering || !settled || plan < newest {
                return;
            }
            someone_hovers = true;
            jobs_at.push((v as u32, pos));
        }
        if !someone_hovers {
            return;
        }
        if Self::plan_term(self.plan_base(lead.term)) != lead.term {
            return; // the term no longer fits a plan number
        }
        self.count += 1;
        let plan = self.plan_base(lead.term) | self.count;
        let slot = self.p.slot();
        let start_slot = ((self.now(tick) + self.p.lead_time) / slot).ceil() as u32;
        let mut fixed = match Reservations::new(&self.grid, &self.pp) {
            Ok(r) => r,
            Err(_) => return,
        };
        for &(v, pos) in &parked {
            fixed.add_dead(v, self.grid.nearest_cell(pos));
        }
        let jobs: Vec<Job> = jobs_at
            .iter()
            .map(|&(v, pos)| Job {
                vehicle: v,
                start: self.grid.nearest_cell(pos),
                goal: self.grid.nearest_cell(self.goals[v as usize]),
                start_slot,
            })
            .collect();
        let mut parts_total = 0;
        for (job, route) in jobs.iter().zip(plan_all(&self.grid, &jobs, fixed, &self.pp)) {
            let route = match route {
                Ok(r) => r,
                Err(_) => {
                    act.note(PlanNote::NoRoute {
                        plan,
                        vehicle: job.vehicle,
                    });
                    continue;
                }
            };
            let parts = split(plan, job.vehicle, &route);
            parts_total += parts.len();
            let note = PlanNote::Planned {
                plan,
                vehicle: job.vehicle,
                start_slot: route.start_slot,
                moves: route.cells.len().saturating_sub(1) as u32,
                cost: route.cost as f32,
                expansions: route.expansions.min(u32::MAX as u64) as u32,
            };
            for (k, part) in parts.into_iter().enumerate() {
                let note = (k == 0).then_some(note);
                self.queue.push_back((Decision::Route(part), note));
            }
        }
        if parts_total > 0 {
            self.awaiting = Some((plan, parts_total));
        }
    }

    fn plan_base(&self, term: u64) -> u32 {
        (term.min(u32::MAX as u64 >> PLAN_COUNT_BITS) as u32) << PLAN_COUNT_BITS
    }
}

/// Splits a route into parts of at most [`ROUTE_PART_MOVES`] moves, each with its own start
/// cell and slot, so each fits one log entry in one radio frame.
pub fn split(plan: u32, vehicle: u32, route: &Route) -> Vec<RoutePart> {
    let moves = route.moves();
    let chunks: Vec<&[u8]> = if moves.is_empty() {
        vec![&[][..]]
    } else {
        moves.chunks(ROUTE_PART_MOVES).collect()
    };
    let parts = chunks.len().min(u8::MAX as usize) as u8;
    chunks
        .iter()
        .take(parts as usize)
        .enumerate()
        .map(|(k, chunk)| {
            let at = k * ROUTE_PART_MOVES;
            let c = route.cells[at];
            let mut m = [0u8; ROUTE_PART_MOVES];
            m[..chunk.len()].copy_from_slice(chunk);
            RoutePart {
                plan,
                vehicle,
                part: k as u8,
                parts,
                start_slot: route.start_slot + at as u32,
                start: [c.i, c.j, c.k],
                len: chunk.len() as u8,
                moves: m,
            }
        })
        .collect()
}

impl Behaviour for Planner {
    const KIND: &'static str = "planner";
    type Params = PlannerParams;
    type Msg = PlannerMsg;
    type Note = PlanNote;
    const METRICS: &'static [&'static str] = metrics::NAMES;

    fn new(cfg: &Config, params: &PlannerParams, id: u32) -> Planner {
        let grid = scene::grid(cfg, params).unwrap_or_else(|e| {
            panic!("`[behaviour]` was validated, yet the planner grid failed: {e}")
        });
        let n = cfg.robots.count as usize;
        let goals = (0..n as u32)
            .map(|v| scene::start_and_goal(cfg, v).map_or([0.0; 3], |(_, g)| g))
            .collect();
        let starts: Vec<[f64; 3]> = (0..n as u32)
            .map(|v| scene::start_and_goal(cfg, v).map_or([0.0; 3], |(s, _)| s))
            .collect();
        let start = starts[id as usize];
        Planner {
            id,
            p: *params,
            pp: scene::params(params),
            grid,
            dt: cfg.scenario.dt,
            max_speed: cfg.robots.max_speed,
            max_vz: cfg.robots.aerial.map_or(0.0, |a| a.max_vertical_speed),
            goals,
            starts,
            mode: Mode::Hover { at: start, since: 0 },
            plan: 0,
            parts: BTreeMap::new(),
            routes: BTreeMap::new(),
            peers: vec![
                Peer {
                    heard: 0,
                    beacon: None,
                    hover_since: None,
                    lost: false,
                };
                n
            ],
            lead: None,
            queue: VecDeque::new(),
            in_flight: 0,
            due: Vec::new(),
            awaiting: None,
            count: 0,
            last_tick: None,
            pos: start,
            detours: BTreeMap::new(),
            detour_parts: BTreeMap::new(),
            mine: Vec::new(),
            seq: 0,
            cursor: 0,
            retry_at: None,
            search: Search::new(),
        }
    }

    fn apply(&mut self, decision: &Decision) {
        if let Decision::Route(part) = decision {
            self.collect(*part);
        }
    }

    fn lead(&mut self, leadership: &Leadership) {
        if self.lead.is_some_and(|l| l.term != leadership.term) {
            self.count = 0;
        }
        // What the consensus layer appended of last tick's proposals leaves the queue.
        let done = leadership.appended.min(self.in_flight);
        let taken: Vec<PlanNote> = self.queue.drain(..done).filter_map(|(_, n)| n).collect();
        self.due.extend(taken);
        self.in_flight = 0;
        self.lead = Some(*leadership);
    }

    fn step(
        &mut self,
        obs: &Observation,
        inbox: &[Heard<PlannerMsg>],
        act: &mut Act<PlannerMsg, PlanNote>,
    ) {
        let tick = obs.tick;
        self.pos = [obs.x, obs.y, obs.z];
        if self.last_tick.is_none() {
            // A first observation: hover where the vehicle is (a restarted process finds its
            // UAV mid-air, not at its start).
            self.mode = Mode::Hover {
                at: self.pos,
                since: tick,
            };
        }
        // A gap in ticks: this process was frozen and its route ran on without it.
        if self.last_tick.is_some_and(|t| tick > t + 1) {
            self.hover(tick, Some(HoverWhy::Late), act);
            if self.continues() && self.plan != 0 {
                self.retry_at = Some(tick);
            }
        }
        self.last_tick = Some(tick);
        // Continue mode: whether something that can block this vehicle's route changed.
        let mut recheck = false;
        for h in inbox {
            let Some(peer) = self.peers.get_mut(h.src as usize) else {
                continue;
            };
            peer.heard = tick;
            if peer.lost {
                peer.lost = false;
                recheck = true;
            }
            match h.msg {
                PlannerMsg::Beacon(b) => {
                    peer.hover_since = match (b.hovering, peer.hover_since) {
                        (true, Some(s)) => Some(s),
                        (true, None) => Some(tick),
                        (false, _) => None,
                    };
                    peer.beacon = Some(b);
                }
                PlannerMsg::Detour(d) => recheck |= self.collect_detour(h.src, d),
            }
        }
        let lost_after = self.p.lost_after as u64;
        let mut newly_lost = false;
        let mut peer_hovers = false;
        for (v, peer) in self.peers.iter_mut().enumerate() {
            if v == self.id as usize {
                continue;
            }
            if !peer.lost && tick > peer.heard + lost_after {
                peer.lost = true;
                peer.hover_since = None;
                newly_lost = true;
            }
            // A vehicle that has hovered `settle` ticks is an obstacle from now on.
            if peer.hover_since.is_some_and(|s| tick == s + self.p.settle as u64) {
                recheck = true;
            }
            if let Some(b) = peer.beacon
                && !peer.lost
                && b.hovering
                && !b.arrived
                && b.plan == self.plan
                && self.plan != 0
                && peer.heard == tick
            {
                peer_hovers = true;
            }
        }
        if self.continues() {
            // The routes were planned together: fly on, and check the route against what
            // changed (a new committed route is checked too: it may be older than a detour).
            let before = self.plan;
            self.take_route(tick, act);
            recheck |= newly_lost || self.plan != before;
            self.autonomy(tick, recheck, act);
        } else {
            if newly_lost {
                self.hover(tick, Some(HoverWhy::Lost), act);
            } else if peer_hovers {
                self.hover(tick, Some(HoverWhy::Peer), act);
            }
            self.take_route(tick, act);
        }

        let t = self.now(tick);
        act.velocity = match &self.mode {
            Mode::Hover { at, .. } => self.steer(*at, [0.0; 3]),
            Mode::Arrived { at } => self.steer(*at, [0.0; 3]),
            Mode::Fly { traj, end, .. } => {
                let (target, feed) = (traj.position(t), traj.velocity(t));
                let goal = self.goals[self.id as usize];
                let off = (0..3).map(|a| (goal[a] - self.pos[a]).powi(2)).sum::<f64>().sqrt();
                if t >= *end && off < 0.5 * self.p.cell {
                    self.mode = Mode::Arrived { at: goal };
                    act.note(PlanNote::Arrived);
                }
                self.steer(target, feed)
            }
        };

        self.lead_plan(tick, act);
        // One route part per tick: its Propose note is the largest a robot writes.
        for n in self.due.drain(..) {
            act.note(n);
        }
        if let Some((d, _)) = self.queue.front() {
            act.propose(*d);
            self.in_flight = 1;
        }

        let (hovering, arrived) = match self.mode {
            Mode::Hover { .. } => (true, false),
            Mode::Fly { .. } => (false, false),
            Mode::Arrived { .. } => (false, true),
        };
        act.send(
            BROADCAST,
            PlannerMsg::Beacon(Beacon {
                pos: [self.pos[0] as f32, self.pos[1] as f32, self.pos[2] as f32],
                plan: self.plan,
                hovering,
                arrived,
                detour: match self.mode {
                    Mode::Fly {
                        kind: RouteKind::Detour(_),
                        ..
                    } => self.seq,
                    _ => 0,
                },
            }),
        );
        self.announce(act);
    }

    fn metrics(
        cfg: &Config,
        params: &PlannerParams,
        run: &swarmrt_protocol::records::Records,
    ) -> Vec<(&'static str, serde_json::Value)> {
        metrics::metrics(cfg, params, run)
    }
}

#[cfg(test)]
mod tests;
