//! Grouping, quadrant leaders, circle formation and exploration (seed 001: Güzel et al. 2018).
//!
//! A robot goes through the paper's layers (Fig. 1), all timed by the shared tick:
//! 1. **Grouping** (`force.rs`, eq. 3-6) until `grouping_time`: it moves along the resultant
//!    gravitational pull of the robots it senses (by default with the range finder and the
//!    shape classifier of `classify.rs`) and stops once its closest neighbour is within the
//!    clustering threshold. A robot nobody senses stays where it is and later moves alone.
//! 2. **Leader choice** for `decide_time`, standing still: the quadrant rule of
//!    `consensus/quadrant.rs` over the range-and-bearing sensor (it needs ids to settle ties
//!    over the radio), the best claim relayed through the group.
//! 3. **Circle formation** (`circle.rs`, eq. 8-11): members tell their leader where they stand;
//!    the leader numbers them (FRN) and broadcasts the COG, radius, c_diff and order every
//!    `recheck` seconds; each robot, the leader included, drives to its slot with the
//!    potential field. The formation's COG moves at `group_speed` toward the target; when a
//!    manoeuvre shifts the measured COG, the leader re-anchors it there (the global
//!    avoidance of Fig. 7-9), and renumbers when the pattern broke.
//! 4. **Goal and exploration** (`explore.rs`, eq. 12-13): the leader's goal sensor (a camera
//!    cone) finds the goal; until then leaders read each other's COGs from their formation
//!    messages and search random points in their own sector. A leader that sees the goal tells
//!    the others (`share_goal`).
//!
//! Metrics (t_s, d_m, ΔΩ of eq. 16, p_v of eq. 17, groups and leaders) are in `metrics.rs`.

mod circle;
mod classify;
mod explore;
mod force;
mod map;
mod messages;
pub mod metrics;
mod overlay;
mod params;

pub use messages::{GroupMsg, GroupNote, MAX_GROUP};
pub use metrics::{RobotRun, delta_omega, robot_runs};
pub use params::{GroupingParams, LeaderNav, Sense};

/// The equations, public for tests and for anyone reusing them.
pub mod equations {
    pub use super::circle::*;
    pub use super::classify::*;
    pub use super::explore::*;
    pub use super::force::*;
}

use std::collections::BTreeMap;

use rand::Rng as _;
use swarmrt_protocol::records::Records;
use swarmrt_protocol::{BROADCAST, Observation};
use swarmrt_scenario::{Config, wrap_angle};

use crate::behaviour::{Act, Behaviour};
use crate::consensus::quadrant::Quadrant;
use crate::consensus::{Notes, Rng, stream};
use crate::inbox::Heard;
use classify::Classifier;
use force::V2;
use map::LidarMap;

/// Seconds between a robot's classifier notes.
const CLASSIFIER_NOTE_PERIOD: f64 = 10.0;
/// Seconds a member's position report, or another leader's COG, stays valid.
const REPORT_LIFETIME: f64 = 5.0;
/// A formation whose worst member is this many radii from its slot is broken: renumber.
const BROKEN: f64 = 1.5;
/// The measured COG this many radii from the moving one shifts it (Fig. 8).
const SHIFT: f64 = 0.3;
/// The group starts moving once every member is within this many radii of its slot ...
const FORMED: f64 = 0.3;
/// ... or after this many seconds of forming, whichever comes first.
const FORMING_LIMIT: f64 = 20.0;
/// Seconds without progress after which a leader detours, and how long the detour holds.
const STALL: f64 = 8.0;
/// Metres a detour goes sideways.
const DETOUR: f64 = 4.0;
/// Largest angle between a detour and the goal direction, radians (100°).
const MAX_TURN_AWAY: f64 = 1.745;
/// Detours after which a leader follows its wall the other way.
const FLIP_AFTER: u32 = 10;
/// Half-width of the sector ahead whose clearance limits the speed, radians (30°).
const AHEAD: f64 = 0.524;
/// Metres of the clearance ahead kept free of the body ...
const CLEARANCE_MARGIN: f64 = 0.05;
/// ... and seconds in which the rest must suffice to stop.
const STOP_TIME: f64 = 0.4;
/// Below this speed (m/s) of the wanted motion a robot stands still.
const SETTLED: f64 = 0.03;
/// Seconds a search position is pursued before a new one is drawn.
const SEARCH_LIMIT: f64 = 60.0;
/// Side of a cell of the leader's lidar map, metres.
const MAP_CELL: f64 = 0.25;
/// Metres of the map path ahead of the formation's centre that it heads for.
const LOOKAHEAD: f64 = 1.5;
/// Metres a circle's robots keep from walls beyond their slot (the map path's clearance).
const WALL_MARGIN: f64 = 0.2;
/// Ticks between a robot's checks of the way to its slot through its map.
const WAY_EVERY: u64 = 5;
/// Metres a way to the slot must be longer than the straight line to count as round a wall.
const DETOUR_SLACK: f64 = 0.5;
/// A lidar hit this close to a robot the range-and-bearing sensor reports is that robot.
const ROBOT_MARGIN: f64 = 0.15;

/// A formation as the leader sent it.
#[derive(Debug, Clone, PartialEq)]
struct Form {
    cog: V2,
    vel: V2,
    radius: f64,
    c_diff: f64,
    stamp: u64,
    members: Vec<u32>,
}

impl Form {
    /// The COG at tick `t`.
    fn cog_at(&self, t: u64, dt: f64) -> V2 {
        self.cog + self.vel * (t.saturating_sub(self.stamp) as f64 * dt)
    }

    /// Robot `id`'s slot at tick `t`, if it is in the formation.
    fn slot_of(&self, id: u32, t: u64, dt: f64) -> Option<V2> {
        let frn = self.members.iter().position(|&m| m == id)?;
        Some(circle::slot(
            self.cog_at(t, dt),
            self.radius,
            self.members.len(),
            frn,
            self.c_diff,
        ))
    }
}

/// One robot's grouping state.
pub struct Grouping {
    id: u32,
    p: GroupingParams,
    dt: f64,
    max_speed: f64,
    max_turn: f64,
    bounds: [f64; 4],
    classifier: Classifier,
    angles: Vec<f64>,
    cyclic: bool,
    rb_range: f64,
    group_end: u64,
    decide_tick: u64,
    recheck: u64,
    quad: Quadrant,
    quad_notes: Notes,
    clustered: bool,
    correct: u32,
    wrong: u32,
    noted_leader: Option<u32>,
    /// Leader: members' reported positions (tick, position).
    joins: BTreeMap<u32, (u64, V2)>,
    /// Leader: the formation it sends; member: the last one its leader sent.
    form: Option<Form>,
    /// Leader: tick its current formation was first numbered, and whether it has formed.
    forming_since: u64,
    formed: bool,
    /// Leader: the goal, once seen or told.
    goal: Option<V2>,
    goal_seen: bool,
    goal_told: bool,
    /// Leader: the search position and the tick it was drawn.
    search: Option<(V2, u64)>,
    /// Leader: other leaders' COGs (tick heard, COG).
    cogs: BTreeMap<u32, (u64, V2)>,
    arrived: bool,
    /// Leader: the closest the COG came to its target and when (stall detection).
    progress: (f64, u64),
    /// Leader: a sideways detour point and until when it holds.
    detour: Option<(V2, u64)>,
    /// Leader: the side its detours turn to (+1 left of the goal direction, -1 right).
    side: f64,
    /// Leader: detours since the way to the goal was last clear.
    detours: u32,
    /// Rays of the last scan that hit a robot (by the classifier).
    robot_rays: Vec<bool>,
    /// Leader: its last lidar scan, (world-frame angle, range) per ray.
    scan: Vec<(f64, f64)>,
    /// With `leader_nav = "map"`: the walls its range finder has seen.
    map: Option<LidarMap>,
    /// With a map: the point on its way round a wall to its slot, when a wall is between.
    waypoint: Option<V2>,
    /// Robot radius, metres.
    body: f64,
    /// The turn rate it commanded last tick (for `turn_accel`).
    omega: f64,
    rng: Rng,
}

impl Grouping {
    /// Robot `id`'s behaviour for this scenario.
    pub fn new(cfg: &Config, p: &GroupingParams, id: u32) -> Grouping {
        let dt = cfg.scenario.dt;
        let ticks = |s: f64| (s / dt).round() as u64;
        let lidar = &cfg.robots.lidar;
        let angles: Vec<f64> = (0..lidar.rays as usize).map(|k| lidar.ray_angle(k)).collect();
        let group_end = ticks(p.grouping_time);
        let decide_tick = group_end + ticks(p.decide_time).max(1);
        let seed = cfg.scenario.seed;
        Grouping {
            id,
            p: p.clone(),
            dt,
            max_speed: cfg.robots.max_speed,
            max_turn: cfg.robots.max_turn_rate,
            bounds: cfg.map.bounds,
            classifier: Classifier {
                radius: cfg.robots.radius,
                range: lidar.range,
                tolerance: cfg.robots.radius * 0.25 + 3.0 * cfg.robots.noise.lidar,
            },
            cyclic: lidar.angles_deg.is_empty() && lidar.fov_deg >= 360.0,
            angles,
            rb_range: cfg.robots.range_bearing.range,
            group_end,
            decide_tick,
            recheck: ticks(p.recheck).max(1),
            quad: Quadrant::new(
                id,
                p.claim_period,
                decide_tick,
                stream(seed, "grouping_draw", id as u64).random(),
            ),
            quad_notes: Notes::new(usize::MAX),
            clustered: false,
            correct: 0,
            wrong: 0,
            noted_leader: None,
            joins: BTreeMap::new(),
            form: None,
            forming_since: 0,
            formed: false,
            goal: None,
            goal_seen: false,
            goal_told: false,
            search: None,
            cogs: BTreeMap::new(),
            arrived: false,
            progress: (f64::INFINITY, 0),
            detour: None,
            side: if id.is_multiple_of(2) { 1.0 } else { -1.0 },
            scan: Vec::new(),
            map: None,
            waypoint: None,
            body: cfg.robots.radius,
            robot_rays: Vec::new(),
            detours: 0,
            omega: 0.0,
            rng: stream(seed, "grouping_search", id as u64),
        }
    }

    /// The leader this robot believes in, once decided.
    pub fn leader(&self) -> Option<u32> {
        self.quad.leader()
    }

    /// Drives toward the world-frame velocity `want` (m/s) plus the repulsion of the lidar
    /// hits: eq. 11's force, turned into a unicycle command.
    fn drive(&mut self, obs: &Observation, want: V2, act: &mut Act<GroupMsg, GroupNote>) {
        let theta = obs.theta;
        let (c, s) = (theta.cos(), theta.sin());
        let hits: Vec<V2> = obs
            .lidar()
            .iter()
            .zip(&self.angles)
            .filter(|&(&d, _)| d < self.classifier.range - 1e-9)
            .map(|(&d, &a)| V2::new(a.cos(), a.sin()) * d)
            .collect();
        let mut want = want;
        if want.norm() > self.max_speed {
            want *= self.max_speed / want.norm();
        }
        // In the robot frame: rotate `want` by -theta.
        let want_body = V2::new(c * want.x + s * want.y, -s * want.x + c * want.y);
        let rep = circle::repulsion_swirl(self.p.k_rep, self.p.rep_range, &hits, want_body);
        let rep = V2::new(c * rep.x - s * rep.y, s * rep.x + c * rep.y);
        let f = want + rep;
        let (v, omega) = if f.norm() < SETTLED {
            (0.0, 0.0)
        } else {
            let err = wrap_angle(f.y.atan2(f.x) - theta);
            (
                // Backing off is allowed (slowly): a robot pushed from behind must yield.
                (f.norm() * err.cos()).clamp(-0.5 * self.max_speed, self.max_speed),
                (self.p.k_turn * err).clamp(-self.max_turn, self.max_turn),
            )
        };
        let step = self.p.turn_accel * self.dt;
        act.omega = omega.clamp(self.omega - step, self.omega + step);
        // A turn rate that cannot change at once needs room: never faster than stopping
        // within the clearance ahead allows.
        let ahead = obs
            .lidar()
            .iter()
            .zip(&self.angles)
            .filter(|&(_, &a)| a.abs() <= AHEAD)
            .map(|(&d, _)| d - self.classifier.radius - CLEARANCE_MARGIN)
            .fold(f64::INFINITY, f64::min);
        act.v = v.min(ahead.max(0.0) / STOP_TIME);
        self.omega = act.omega;
    }

    /// The robots the grouping force sees, relative to this robot in the world frame.
    fn sensed(&mut self, obs: &Observation) -> Vec<V2> {
        let theta = obs.theta;
        let rot = |v: V2| V2::new(theta.cos() * v.x - theta.sin() * v.y, theta.sin() * v.x + theta.cos() * v.y);
        let truth: Vec<V2> = obs
            .neighbours()
            .iter()
            .map(|n| V2::new(n.bearing.cos(), n.bearing.sin()) * n.range)
            .collect();
        if obs.lidar().is_empty() {
            return match self.p.sense {
                Sense::RangeBearing => truth.into_iter().map(rot).collect(),
                Sense::Lidar => Vec::new(),
            };
        }
        let blobs = self.classifier.blobs(obs.lidar(), &self.angles, self.cyclic);
        self.robot_rays = vec![false; obs.lidar().len()];
        for b in blobs.iter().filter(|b| b.robot) {
            for &k in &b.rays {
                self.robot_rays[k] = true;
            }
        }
        let judged = self.rb_range.min(self.classifier.range);
        let (right, wrong) =
            classify::matches(&blobs, &truth, judged, 2.0 * self.classifier.radius);
        self.correct += right;
        self.wrong += wrong;
        match self.p.sense {
            Sense::RangeBearing => truth.into_iter().map(rot).collect(),
            Sense::Lidar => blobs.iter().filter(|b| b.robot).map(|b| rot(b.centre)).collect(),
        }
    }

    /// Layer 1: move along the resultant pull until clustered.
    fn group(&mut self, obs: &Observation, sensed: &[V2], act: &mut Act<GroupMsg, GroupNote>) {
        if !self.clustered && force::clustered(sensed, self.p.cluster_distance) {
            self.clustered = true;
            act.note(GroupNote::Clustered);
        }
        if self.clustered || sensed.is_empty() {
            return;
        }
        let f = force::resultant(sensed, self.p.gravity, self.p.force_cap);
        if f.norm() < 1e-9 {
            return;
        }
        let speed = self.max_speed * (f.norm() / self.p.force_cap).min(1.0);
        self.drive(obs, f / f.norm() * speed, act);
    }

    /// Layer 3 for a leader: keep the formation, navigate, explore.
    fn lead(&mut self, obs: &Observation, act: &mut Act<GroupMsg, GroupNote>) {
        let t = obs.tick;
        let me = V2::new(obs.x, obs.y);
        let life = (REPORT_LIFETIME / self.dt) as u64;
        self.joins.retain(|_, (at, _)| t.saturating_sub(*at) <= life);
        self.cogs.retain(|_, (at, _)| t.saturating_sub(*at) <= life);
        // Members where the range-and-bearing sensor sees them, else where they said.
        let seen: BTreeMap<u32, V2> = obs
            .neighbours()
            .iter()
            .map(|n| {
                let a = obs.theta + n.bearing;
                (n.id, me + V2::new(a.cos(), a.sin()) * n.range)
            })
            .collect();
        let members: Vec<(u32, V2)> = self
            .joins
            .iter()
            .take(MAX_GROUP - 1)
            .map(|(&id, &(_, p))| (id, seen.get(&id).copied().unwrap_or(p)))
            .collect();
        // The scan without the robots the classifier recognised: members are not walls.
        let range = self.classifier.range;
        self.scan = obs
            .lidar()
            .iter()
            .zip(&self.angles)
            .enumerate()
            .map(|(k, (&d, &a))| {
                let robot = self.robot_rays.get(k).copied().unwrap_or(false);
                (obs.theta + a, if robot { range } else { d })
            })
            .collect();
        if obs.goal_visible != 0 {
            let a = obs.theta + obs.goal_bearing;
            self.goal = Some(me + V2::new(a.cos(), a.sin()) * obs.goal_range);
            if !self.goal_seen {
                act.note(GroupNote::GoalSeen);
            }
            self.goal_seen = true;
        }
        // The first numbering waits one recheck period for the members' reports.
        let due = t >= self.decide_tick + self.recheck
            && (t - self.decide_tick).is_multiple_of(self.recheck);
        if due {
            self.recheck_form(t, me, &members, act);
            if let Some(f) = &self.form {
                act.send(BROADCAST, form_msg(f));
            }
            if due
                && self.p.share_goal
                && self.goal_seen
                && let Some(g) = self.goal
            {
                act.send(
                    BROADCAST,
                    GroupMsg::Goal {
                        x: g.x as f32,
                        y: g.y as f32,
                    },
                );
            }
        }
        self.follow_slot(obs, act);
    }

    /// The leader's check of the pattern: number, shift, steer.
    fn recheck_form(
        &mut self,
        t: u64,
        me: V2,
        members: &[(u32, V2)],
        act: &mut Act<GroupMsg, GroupNote>,
    ) {
        let mut all: Vec<V2> = members.iter().map(|m| m.1).collect();
        all.push(me);
        let measured = circle::cog(&all);
        let ids: Vec<u32> = {
            let mut v: Vec<u32> = members.iter().map(|m| m.0).collect();
            v.push(self.id);
            v.sort_unstable();
            v
        };
        let r = self.p.radius;
        // Where a new numbering centres the circle: with a map, off any wall it has seen.
        let anchor = match &mut self.map {
            Some(map) if self.p.leader_nav == LeaderNav::Map => {
                map.roomy(measured, r + self.body + WALL_MARGIN, r)
            }
            _ => measured,
        };
        let mut lag = 0.0;
        let mut form = match self.form.take() {
            Some(f) => {
                let mut known = f.members.clone();
                known.sort_unstable();
                let cog = f.cog_at(t, self.dt);
                let n = f.members.len();
                let placed: Vec<(usize, V2)> = f
                    .members
                    .iter()
                    .enumerate()
                    .filter_map(|(k, id)| {
                        if *id == self.id {
                            Some((k, me))
                        } else {
                            members.iter().find(|m| m.0 == *id).map(|m| (k, m.1))
                        }
                    })
                    .collect();
                let worst = circle::worst_error(&placed, cog, r, n, f.c_diff);
                lag = worst;
                if known != ids || (self.formed && worst > BROKEN * r) {
                    None
                } else {
                    if !self.formed
                        && (worst < FORMED * r
                            || (t - self.forming_since) as f64 * self.dt > FORMING_LIMIT)
                    {
                        self.formed = true;
                    }
                    // The COG shift of Fig. 8: across the direction of travel only, so a
                    // member held up behind an obstacle moves the circle aside, not back.
                    let mut shift = measured - cog;
                    if f.vel.norm() > 1e-9 {
                        let along = f.vel / f.vel.norm();
                        shift -= along * shift.dot(&along);
                    }
                    let cog = if shift.norm() > SHIFT * r { cog + shift } else { cog };
                    Some(Form {
                        cog,
                        stamp: t,
                        ..f
                    })
                }
            }
            None => None,
        }
        .unwrap_or_else(|| {
            let order = circle::frn_order((self.id, me), members, measured);
            // Only the first numbering waits for the circle; a renumbered group keeps going.
            self.forming_since = t;
            act.note(GroupNote::Formed {
                n: order.len() as u8,
            });
            Form {
                cog: anchor,
                vel: V2::zeros(),
                radius: r,
                c_diff: circle::c_diff(me, anchor),
                stamp: t,
                members: order,
            }
        });
        form.vel = V2::zeros();
        if self.formed && !self.arrived {
            let target = match self.goal {
                Some(g) if self.p.leader_nav == LeaderNav::Map => Some(self.route(form.cog, g)),
                Some(g) => Some(self.unstick(t, measured, g)),
                None => {
                    let p = self.search_point(t, form.cog);
                    self.stalled_search(t, measured, p)
                }
            };
            if let Some(target) = target {
                let to = target - form.cog;
                if self.goal.is_some() && to.norm() <= self.p.arrive {
                    self.arrived = true;
                    act.note(GroupNote::Arrived);
                } else if to.norm() > 1e-6 {
                    // Slow down over the last metre so the centre does not overshoot.
                    let mut speed = self.p.group_speed * to.norm().min(1.0);
                    if self.p.leader_nav == LeaderNav::Map {
                        // Through a maze the centre waits for a lagging robot, which would
                        // otherwise cut a corner of the wall toward its slot.
                        speed *= (1.0 - (lag - FORMED * r) / ((BROKEN - FORMED) * r)).clamp(0.0, 1.0);
                    }
                    form.vel = to / to.norm() * speed;
                }
            }
        }
        self.form = Some(form);
    }

    /// Marks the walls of this scan in the robot's map: hits of rays the classifier did not
    /// take for a robot, and not where the range-and-bearing sensor reports one.
    fn map_scan(&mut self, obs: &Observation) {
        let me = V2::new(obs.x, obs.y);
        let seen: Vec<V2> = obs
            .neighbours()
            .iter()
            .map(|n| {
                let a = obs.theta + n.bearing;
                me + V2::new(a.cos(), a.sin()) * n.range
            })
            .collect();
        let range = self.classifier.range;
        let near = self.body + ROBOT_MARGIN;
        let map = self
            .map
            .get_or_insert_with(|| LidarMap::new(self.bounds, MAP_CELL));
        for (k, (&d, &a)) in obs.lidar().iter().zip(&self.angles).enumerate() {
            if d >= range - 1e-9 || self.robot_rays.get(k).copied().unwrap_or(false) {
                continue;
            }
            let a = obs.theta + a;
            let p = me + V2::new(a.cos(), a.sin()) * d;
            if seen.iter().all(|r| (r - p).norm() > near) {
                map.hit(p);
            }
        }
    }

    /// Where the centre heads with `leader_nav = "map"`: `LOOKAHEAD` metres along the cheapest
    /// path to `goal` through the leader's map, with room for the circle's robots where the
    /// way allows; straight for the goal while no way is known (a map that closes it).
    fn route(&mut self, cog: V2, goal: V2) -> V2 {
        let Some(map) = &mut self.map else { return goal };
        let need = self.p.radius + self.body + WALL_MARGIN;
        match map.route(cog, goal, need, self.body + 0.05) {
            Some(path) => map::ahead(&path, LOOKAHEAD),
            None => goal,
        }
    }

    /// Global avoidance for a stalled group (our addition, a bug algorithm at the group's
    /// scale): when the measured COG has not come 0.3 m closer to `goal` for `STALL` seconds
    /// (a wall across the way, where the potential field of eq. 10-11 has its local minimum),
    /// the leader steers the circle along free lidar directions, always turning to the same
    /// side of the goal direction, `DETOUR` metres at a time, until its lidar sees the way to
    /// the goal clear.
    fn unstick(&mut self, t: u64, cog: V2, goal: V2) -> V2 {
        let stall = (STALL / self.dt) as u64;
        let to = goal - cog;
        let goal_dir = to.y.atan2(to.x);
        if let Some((p, until)) = self.detour {
            if self.clear_towards(goal_dir, to.norm()) {
                self.detour = None;
                self.detours = 0;
                self.progress = (to.norm(), t);
                return goal;
            }
            if t < until && (p - cog).norm() > self.p.radius {
                return p;
            }
            return self.next_detour(t, cog, goal_dir, stall);
        }
        let d = to.norm();
        if d < self.progress.0 - 0.3 {
            self.progress = (d, t);
        } else if t - self.progress.1 > stall && d > 1e-6 {
            return self.next_detour(t, cog, goal_dir, stall);
        }
        goal
    }

    /// The next detour point: the free direction nearest the goal's on this leader's side.
    fn next_detour(&mut self, t: u64, cog: V2, goal_dir: f64, stall: u64) -> V2 {
        // A wall followed for `FLIP_AFTER` detours without the way clearing is a dead end
        // (it meets the arena's edge): follow it the other way.
        self.detours += 1;
        if self.detours.is_multiple_of(FLIP_AFTER) {
            self.side = -self.side;
        }
        let pick = |side: f64| {
            self.scan
                .iter()
                .enumerate()
                .filter(|&(k, _)| self.free(k))
                .map(|(_, &(a, _))| (wrap_angle(a - goal_dir), a))
                // Along the wall or toward the goal, never back: a side with no such free
                // direction is a dead end (a corner with the arena's edge).
                .filter(|&(off, _)| off * side >= -0.05 && off.abs() <= MAX_TURN_AWAY)
                .min_by(|x, y| x.0.abs().total_cmp(&y.0.abs()))
                .map(|(_, a)| a)
        };
        let (first, other) = (pick(self.side), pick(-self.side));
        let dir = match (first, other) {
            (Some(a), _) => a,
            (None, Some(a)) => {
                self.side = -self.side;
                a
            }
            (None, None) => goal_dir + std::f64::consts::PI,
        };
        let p = cog + V2::new(dir.cos(), dir.sin()) * DETOUR;
        self.detour = Some((p, t + stall));
        p
    }

    /// Ray `k` of the leader's last scan and its two neighbours read nothing.
    fn free(&self, k: usize) -> bool {
        let n = self.scan.len();
        [k + n - 1, k, k + 1]
            .iter()
            .all(|&j| self.scan[j % n].1 >= self.classifier.range - 1e-6)
    }

    /// The leader's lidar sees nothing within `dist` (or its range) across a 40° wedge
    /// toward `dir`, members aside.
    fn clear_towards(&self, dir: f64, dist: f64) -> bool {
        let reach = dist.min(self.classifier.range) - 0.1;
        let wedge = 20f64.to_radians();
        let rays: Vec<&(f64, f64)> = self
            .scan
            .iter()
            .filter(|(a, _)| wrap_angle(a - dir).abs() <= wedge)
            .collect();
        !rays.is_empty() && rays.iter().all(|&&(_, r)| r >= reach)
    }

    /// A search position the group cannot get closer to (behind a wall) is dropped: the next
    /// recheck draws another.
    fn stalled_search(&mut self, t: u64, cog: V2, p: Option<V2>) -> Option<V2> {
        let target = p?;
        let d = (target - cog).norm();
        if d < self.progress.0 - 0.3 {
            self.progress = (d, t);
        } else if t - self.progress.1 > (STALL / self.dt) as u64 {
            self.search = None;
            self.progress = (f64::INFINITY, t);
        }
        Some(target)
    }

    /// Eq. 12-13: the current search position, drawn anew when reached or stale.
    fn search_point(&mut self, t: u64, cog: V2) -> Option<V2> {
        let limit = (SEARCH_LIMIT / self.dt) as u64;
        if let Some((p, at)) = self.search
            && (p - cog).norm() > self.p.radius
            && t - at < limit
        {
            return Some(p);
        }
        let others: Vec<V2> = self.cogs.values().map(|c| c.1).collect();
        let sector = explore::sector(cog, &others);
        let margin = self.p.radius + 0.5;
        let [x0, y0, x1, y1] = self.bounds;
        let mut p = cog;
        for _ in 0..16 {
            let (ua, ur): (f64, f64) = (self.rng.random(), self.rng.random());
            p = sector.point(self.p.search_radius, ua, ur);
            if p.x > x0 + margin && p.x < x1 - margin && p.y > y0 + margin && p.y < y1 - margin {
                break;
            }
        }
        p.x = p.x.clamp(x0 + margin, (x1 - margin).max(x0 + margin));
        p.y = p.y.clamp(y0 + margin, (y1 - margin).max(y0 + margin));
        self.search = Some((p, t));
        self.progress = (f64::INFINITY, t);
        Some(p)
    }

    /// Drive to this robot's slot of the formation it knows, with its leader's velocity.
    fn follow_slot(&mut self, obs: &Observation, act: &mut Act<GroupMsg, GroupNote>) {
        let Some(f) = &self.form else { return };
        let Some(slot) = f.slot_of(self.id, obs.tick, self.dt) else {
            return;
        };
        let me = V2::new(obs.x, obs.y);
        if let Some(map) = &mut self.map
            && (obs.tick + self.id as u64).is_multiple_of(WAY_EVERY)
        {
            // A slot behind a wall (the circle turned round its end) is reached round it.
            let (body, need) = (self.body + 0.05, self.body + WALL_MARGIN);
            self.waypoint = if map.straight(me, slot, body, need) {
                None
            } else {
                map.route(me, slot, need, body)
                    .filter(|path| length(path) > (slot - me).norm() + DETOUR_SLACK)
                    .map(|path| map::ahead(&path, 1.0))
            };
        }
        let want = match self.waypoint {
            Some(w) if (w - me).norm() > 0.1 => (w - me) / (w - me).norm() * self.p.group_speed,
            _ => f.vel + circle::attraction(self.p.k_att, me, slot),
        };
        self.drive(obs, want, act);
    }
}

/// A path's length, metres.
fn length(path: &[V2]) -> f64 {
    path.windows(2).map(|w| (w[1] - w[0]).norm()).sum()
}

fn form_msg(f: &Form) -> GroupMsg {
    GroupMsg::Form {
        x: f.cog.x as f32,
        y: f.cog.y as f32,
        vx: f.vel.x as f32,
        vy: f.vel.y as f32,
        radius: f.radius as f32,
        c_diff: f.c_diff as f32,
        stamp: f.stamp,
        members: f.members.clone(),
    }
}

impl Behaviour for Grouping {
    const KIND: &'static str = "grouping";
    type Params = GroupingParams;
    type Msg = GroupMsg;
    type Note = GroupNote;
    const METRICS: &'static [&'static str] = &metrics::NAMES;

    fn new(cfg: &Config, params: &GroupingParams, id: u32) -> Grouping {
        Grouping::new(cfg, params, id)
    }

    fn step(
        &mut self,
        obs: &Observation,
        inbox: &[Heard<GroupMsg>],
        act: &mut Act<GroupMsg, GroupNote>,
    ) {
        let t = obs.tick;
        act.lidar_on = true;
        let sensed = self.sensed(obs);
        if self.p.leader_nav == LeaderNav::Map {
            self.map_scan(obs);
        }
        let note_every = (CLASSIFIER_NOTE_PERIOD / self.dt).round().max(1.0) as u64;
        if t > 0 && t.is_multiple_of(note_every) && self.correct + self.wrong > 0 {
            act.note(GroupNote::Classified {
                correct: self.correct,
                wrong: self.wrong,
            });
            (self.correct, self.wrong) = (0, 0);
        }
        let leader = self.quad.leader();
        for h in inbox {
            match &h.msg {
                GroupMsg::Quad(m) => self.quad.step(h.src, m),
                GroupMsg::Join { leader: l, x, y } if *l == self.id => {
                    self.joins.insert(h.src, (t, V2::new(*x as f64, *y as f64)));
                }
                GroupMsg::Form {
                    x,
                    y,
                    vx,
                    vy,
                    radius,
                    c_diff,
                    stamp,
                    members,
                } => {
                    let f = Form {
                        cog: V2::new(*x as f64, *y as f64),
                        vel: V2::new(*vx as f64, *vy as f64),
                        radius: *radius as f64,
                        c_diff: *c_diff as f64,
                        stamp: *stamp,
                        members: members.clone(),
                    };
                    if leader == Some(self.id) {
                        self.cogs.insert(h.src, (t, f.cog_at(t, self.dt)));
                    } else if leader == Some(h.src) {
                        self.form = Some(f);
                    }
                }
                GroupMsg::Goal { x, y } if leader == Some(self.id) && self.goal.is_none() => {
                    self.goal = Some(V2::new(*x as f64, *y as f64));
                    self.goal_told = true;
                    act.note(GroupNote::GoalTold);
                }
                _ => {}
            }
        }
        if t < self.group_end {
            self.group(obs, &sensed, act);
            return;
        }
        // Layer 2: the quadrant choice, on what the robot senses once grouping is over; the
        // score is frozen at the decision so a moving group keeps its leader.
        if t < self.decide_tick {
            self.quad.observe(obs.neighbours());
        }
        self.quad.tick(t, &mut self.quad_notes);
        self.quad_notes.take();
        for (dst, m) in self.quad.ready(2) {
            act.send(dst, GroupMsg::Quad(m));
        }
        let Some(leader) = self.quad.leader() else {
            return;
        };
        if self.noted_leader != Some(leader) {
            self.noted_leader = Some(leader);
            act.note(GroupNote::Leader {
                leader,
                leads: leader == self.id,
                score: self.quad.score(),
                changes: self.quad.changes(),
            });
            if leader != self.id {
                self.form = None;
            }
        }
        if leader == self.id {
            self.lead(obs, act);
        } else {
            let due = (t + self.id as u64 - self.decide_tick).is_multiple_of(self.recheck);
            if due {
                act.send(
                    BROADCAST,
                    GroupMsg::Join {
                        leader,
                        x: obs.x as f32,
                        y: obs.y as f32,
                    },
                );
            }
            self.follow_slot(obs, act);
        }
    }

    fn metrics(cfg: &Config, params: &GroupingParams, run: &Records) -> Vec<(&'static str, serde_json::Value)> {
        metrics::metrics(cfg, params, run)
    }
}

#[cfg(test)]
mod tests;
