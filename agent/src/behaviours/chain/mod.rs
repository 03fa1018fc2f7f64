//! Chain formations that push, pull, rotate around obstacles and veto (seed 003: Birbilis,
//! Aspragathos, "Reactive multi-agent based control of mobile robot chain formations").
//!
//! Robot `i`'s chain neighbours are `i - 1` and `i + 1`. The initiator (`behaviour.initiator`,
//! the head by default) moves on its own: wall following with target seeking by the
//! subsumption layers of Table 2 (`head.rs`). Every other robot is the vetoable slave of the
//! neighbour on the initiator's side, its master (section 3, "Agent interactions"): each
//! tick it applies Appendix A's `Adaptation` to its master's position (`rods.rs`): Pull
//! beyond `rod_max`, Push inside `rod_min`, nothing in between (Resize), on the guiding line,
//! with the connector angle at the master kept in its limits; when its own lidar says the
//! guiding line crosses an obstacle, it rotates the rod by heading for the newest point of
//! its master's trail it can reach in a straight line (Push-Pull-Rotate, Fig. 5), or, with
//! `behaviour.rotate = "shake"`, by Appendix A's random shake of the colliding point.
//!
//! **How a master's motion reaches its slave.** The paper propagates by recursion in one
//! process, all in one step. Here each robot is a process that acts once per tick on what it
//! senses, so a motion travels one robot per tick: the slave sees its master's new position
//! at the next observation (range-and-bearing) and moves then; over the radio it is `1 +
//! radio.delay_ticks` per robot, and loss makes it older still. `behaviour.master_from`
//! chooses (`both` by default: range-and-bearing in view, radio otherwise); the cost along a
//! 450-robot chain is measured in `docs/results/seed003.md`. A Pull aims `lead` (the master's
//! last step) short of `rod_max`, so a steadily pulled rod ends at `rod_max` despite the
//! one-tick lag.
//!
//! **Within one tick, as Appendix A's recursion** (`radio.rounds` > 0): a robot that moves
//! also tells its slaves, within the tick, where it will be after it ([`Chain::react`]); each
//! slave adapts to that point in the next round and passes its own new motion on, so the
//! whole chain answers the initiator's motion of this tick in this tick. A slave whose rod
//! stays in limits does not move and passes nothing on: the recursion stops where the paper's
//! `Adaptation` returns.
//!
//! **Veto** (Fig. 3). A slave that cannot adapt objects: a stationary robot whose master
//! left its rod limits, or a slave that found no collision-free guiding line for
//! `trapped_ticks`. It sends `veto = 1` to its master in its `Link` every tick while it
//! objects. A vetoed master reverses the relationship for the event: it adapts to the slave
//! that vetoed instead of to its own master, and, if that leaves its own master beyond
//! `rod_max`, it passes the veto on with `veto + 1`. A veto that reaches the initiator stops
//! it: it adapts to the vetoing robot, and when the veto has lapsed (`veto_hold` ticks
//! without one) it re-plans, turning `replan_turn_deg` in place towards the side with more
//! room before it resumes wall following (the paper leaves the re-plan to "a planning unit";
//! this is the least a lone head can do).
//!
//! **A robot that dies** leaves range-and-bearing and goes silent: its slave has no master,
//! so it and the robots behind it stay where they are (a chain with a still head), while the
//! part ahead carries on. Metrics are in `metrics.rs`.

mod head;
mod messages;
mod metrics;
mod overlay;
mod params;
mod rods;

pub use head::{Layer, Sides, Target, Wheels, sides, subsume, unicycle};
pub use messages::{ChainNote, Link, VetoWhy};
pub use metrics::{FirstMoves, first_moves};
pub use params::{ChainParams, MasterFrom, Rotate};
pub use rods::{
    P, Reaction, adapt, clamp_angle, connector_angle, line_blocked, rotate_towards,
    segment_collision, shake, steer, to_robot_frame,
};

use rand::Rng as _;
use swarmrt_scenario::rng::{self, Rng};

use std::collections::VecDeque;

use swarmrt_protocol::records::Records;
use swarmrt_protocol::{Observation, RobotState};
use swarmrt_scenario::{Config, LidarConfig};

use crate::behaviour::{Act, Behaviour, Series};
use crate::inbox::Heard;

/// Metres beyond the body a guiding line needs when the full `line_clearance` finds none.
const TOUCH_MARGIN: f64 = 0.02;

/// Where range-and-bearing sees robot `id` this tick, in the world frame.
fn seen(obs: &Observation, id: u32) -> Option<P> {
    obs.neighbours[..obs.neighbours_len as usize]
        .iter()
        .find(|n| n.id == id)
        .map(|n| {
            let a = obs.theta + n.bearing;
            (obs.x + n.range * a.cos(), obs.y + n.range * a.sin())
        })
}

/// What a robot last knew of one chain neighbour.
#[derive(Debug, Clone, Copy, Default)]
struct Known {
    /// Its position from its latest `Link`.
    radio: Option<P>,
    /// Its master's position from that `Link`.
    radio_master: Option<P>,
}

/// A veto heard from a slave, and until when it holds.
#[derive(Debug, Clone, Copy)]
struct VetoIn {
    from: u32,
    depth: u16,
    until: u64,
}

/// One robot's chain state.
pub struct Chain {
    p: ChainParams,
    id: u32,
    /// Its master (towards the initiator); none for the initiator.
    master: Option<u32>,
    /// Its slaves (away from the initiator): one, two for a middle initiator, none at an end.
    slaves: Vec<u32>,
    stationary: bool,
    dt: f64,
    max_speed: f64,
    max_turn_rate: f64,
    radius: f64,
    lidar: LidarConfig,
    /// What it last heard from its master (index 0) and its slaves (1, 2).
    known: [Known; 3],
    /// Its master's position last tick, for `lead`.
    master_prev: Option<P>,
    /// The master's trail, oldest first (Push-Pull-Rotate).
    trail: VecDeque<P>,
    /// This tick's lidar hits in the robot frame (a kept buffer).
    hits: Vec<P>,
    /// Ticks in a row without a collision-free guiding line.
    trapped: u32,
    veto_in: Option<VetoIn>,
    /// The depth it vetoes with this tick (0: none) and last tick's.
    vetoing: u16,
    /// The initiator: a veto reached it and it will turn when the veto lapses.
    replan: Option<f64>,
    /// The initiator: ticks of in-place turning left, and the turn rate.
    turning: (u32, f64),
    /// Draws of Appendix A's shake (`rotate = "shake"`; untouched otherwise).
    rng: Rng,
    /// `radio.rounds` > 0: motions pass along the chain within the tick ([`Chain::react`]).
    rounds: bool,
}

impl Chain {
    fn slot(&self, id: u32) -> Option<usize> {
        if Some(id) == self.master {
            Some(0)
        } else {
            self.slaves.iter().position(|&s| s == id).map(|k| k + 1)
        }
    }

    /// Where chain neighbour `id` is, by `master_from`.
    fn locate(&self, obs: &Observation, id: u32) -> Option<P> {
        let heard = self.slot(id).and_then(|k| self.known[k].radio);
        self.by_master_from(seen(obs, id), heard)
    }

    /// Where the other neighbour of `master` is (the third corner of the connector angle at
    /// the master): range-and-bearing, else what the master said.
    fn third_corner(&self, obs: &Observation, master: u32) -> Option<P> {
        let other = u32::try_from(2 * master as i64 - self.id as i64).ok()?;
        let said = self.slot(master).and_then(|k| self.known[k].radio_master);
        self.by_master_from(seen(obs, other), said)
    }

    fn by_master_from(&self, seen: Option<P>, heard: Option<P>) -> Option<P> {
        match self.p.master_from {
            MasterFrom::Rab => seen,
            MasterFrom::Radio => heard,
            MasterFrom::Both => seen.or(heard),
        }
    }

    /// Fills `self.hits` with the lidar's hits in the robot frame (rays that hit something
    /// before their range); the buffer is kept, so a tick allocates nothing.
    fn sense_hits(&mut self, obs: &Observation) {
        self.hits.clear();
        for k in 0..obs.lidar_len as usize {
            if obs.lidar[k] < self.lidar.range - 1e-9 {
                let a = self.lidar.ray_angle(k);
                self.hits.push((obs.lidar[k] * a.cos(), obs.lidar[k] * a.sin()));
            }
        }
    }

    /// Appendix A's `Adaptation` of this robot to `master` at `m`, with Push-Pull-Rotate:
    /// the target point, or `None` when no collision-free guiding line exists (trapped).
    /// `third` is the connector angle's third corner (the master's other neighbour).
    fn adaptation(&mut self, obs: &Observation, m: P, third: Option<P>, lead: f64) -> Option<P> {
        let pose = (obs.x, obs.y, obs.theta);
        self.sense_hits(obs);
        let hits = &self.hits;
        let clearance = self.radius + self.p.line_clearance;
        let ignore = 2.0 * self.radius + self.p.line_clearance;
        let me = (obs.x, obs.y);
        let m_here = to_robot_frame(pose, m);
        if self.p.rotate == Rotate::Shake && line_blocked(hits, m_here, clearance, ignore) {
            let rng = &mut self.rng;
            let s = shake(
                m_here,
                hits,
                clearance,
                ignore,
                self.p.rod_max,
                self.p.shake_tries,
                || rng.random::<f64>(),
            )?;
            // Back to the world frame; Push or Pull along the new guiding line when the
            // slave can reach that point straight, else the shaken point itself.
            let (c, si) = (pose.2.cos(), pose.2.sin());
            let s = (pose.0 + c * s.0 - si * s.1, pose.1 + si * s.0 + c * s.1);
            let (_, target) = adapt(m, s, self.p.rod_min, self.p.rod_max, lead);
            let clear = !line_blocked(hits, to_robot_frame(pose, target), clearance, 0.0);
            return Some(if clear { target } else { s });
        }
        if line_blocked(hits, m_here, clearance, ignore) {
            // Only the trail ahead of it counts (the points after the one nearest to it): the
            // newest in a straight line with the full clearance, else with a hair more than
            // the body (where the master itself squeezed by), else simply the next one (the
            // master's body passed there, so the slave retraces its path).
            let tight = self.radius + TOUCH_MARGIN;
            let dist = |c: &P| (c.0 - me.0).hypot(c.1 - me.1);
            let nearest = (0..self.trail.len())
                .min_by(|&a, &b| dist(&self.trail[a]).total_cmp(&dist(&self.trail[b])))
                .unwrap_or(0);
            let ahead = || self.trail.range(nearest + 1..).copied();
            return [clearance, tight]
                .into_iter()
                .find_map(|c| rotate_towards(pose, ahead(), hits, c))
                .or_else(|| ahead().next());
        }
        let (_, mut target) = adapt(m, me, self.p.rod_min, self.p.rod_max, lead);
        if let Some(q) = third {
            let clamped = clamp_angle(
                q,
                m,
                target,
                self.p.angle_min_deg.to_radians(),
                self.p.angle_max_deg.to_radians(),
            );
            if !line_blocked(hits, to_robot_frame(pose, clamped), clearance, ignore) {
                target = clamped;
            }
        }
        Some(target)
    }

    /// A vetoed robot's adaptation to the slave `s` that vetoed: back onto the guiding line
    /// at the middle of the rod's range when the rod is out of its limits, so the event ends
    /// (a rod left at exactly `rod_max` would keep a stationary slave objecting for ever).
    fn give_way(&self, s: P, me: P) -> P {
        let mid = (self.p.rod_min + self.p.rod_max) / 2.0;
        match adapt(s, me, self.p.rod_min, self.p.rod_max, 0.0) {
            (Reaction::Resize, _) => me,
            _ => adapt(s, me, mid, mid, 0.0).1,
        }
    }

    /// Where this robot will be after the tick with the motion in `act` (the world's
    /// unicycle step: heading first, then position), from where it senses itself.
    fn next_position(&self, obs: &Observation, act: &Act<Link, ChainNote>) -> [f32; 2] {
        let theta = obs.theta + act.omega * self.dt;
        let d = act.v * self.dt;
        [(obs.x + d * theta.cos()) as f32, (obs.y + d * theta.sin()) as f32]
    }

    /// Passes this robot's motion of the tick on to its slaves, within the tick: where it
    /// will be, and (as the third corner of their connector angle) where `master` is.
    /// A robot that stays where it is passes nothing: its slaves already adapted to where
    /// they see it, so a still chain costs no rounds.
    fn pass_on(&self, obs: &Observation, master: Option<[f32; 2]>, act: &mut Act<Link, ChainNote>) {
        if act.v.abs() < 1e-9 {
            return;
        }
        let [x, y] = self.next_position(obs, act);
        for &s in &self.slaves {
            let third = match self.master {
                Some(_) => master,
                // The initiator: each slave's third corner is the other slave.
                None => self
                    .slaves
                    .iter()
                    .find(|&&o| o != s)
                    .and_then(|&o| self.locate(obs, o))
                    .map(|(x, y)| [x as f32, y as f32]),
            };
            act.send_in_tick(
                s,
                Link {
                    x,
                    y,
                    master: third,
                    veto: 0,
                },
            );
        }
    }

    fn drive(&self, obs: &Observation, target: P, act: &mut Act<Link, ChainNote>) {
        (act.v, act.omega) = steer(
            (obs.x, obs.y, obs.theta),
            target,
            self.dt,
            self.max_speed,
            self.max_turn_rate,
            self.p.turn_gain,
        );
    }

    /// Remembers the master's position on its trail (a new point every `rod_min / 4`).
    fn remember(&mut self, m: P) {
        let far = self
            .trail
            .back()
            .is_none_or(|b| (b.0 - m.0).hypot(b.1 - m.1) >= self.p.rod_min / 4.0);
        if far {
            if self.trail.len() == self.p.trail as usize {
                self.trail.pop_front();
            }
            self.trail.push_back(m);
        }
    }

    /// A slave's tick: the depth it vetoes with (0: none) and why.
    fn follow(
        &mut self,
        obs: &Observation,
        act: &mut Act<Link, ChainNote>,
    ) -> (u16, Option<VetoWhy>) {
        let master = self.master.expect("a slave has a master");
        let m = self.locate(obs, master);
        let lead = match (m, self.master_prev) {
            (Some(a), Some(b)) => (a.0 - b.0).hypot(a.1 - b.1).min(self.max_speed * self.dt),
            _ => 0.0,
        };
        self.master_prev = m;
        if let Some(m) = m {
            self.remember(m);
        }
        let out_of_rod = |at: P, m: P| {
            let d = (at.0 - m.0).hypot(at.1 - m.1);
            d > self.p.rod_max || d < self.p.rod_min
        };
        if self.stationary {
            return match m {
                Some(m) if out_of_rod((obs.x, obs.y), m) => (1, Some(VetoWhy::Stationary)),
                _ => (0, None),
            };
        }
        if let Some(v) = self.veto_in.filter(|v| obs.tick < v.until) {
            // The relationship reversed for this event: adapt to the slave that vetoed.
            let Some(s) = self.locate(obs, v.from) else {
                return (0, None);
            };
            let target = self.give_way(s, (obs.x, obs.y));
            self.drive(obs, target, act);
            return match m {
                Some(m) if out_of_rod(target, m) => {
                    (v.depth.saturating_add(1), Some(VetoWhy::Passed))
                }
                _ => (0, None),
            };
        }
        let Some(m) = m else {
            // No master in sight or heard: it stays (a chain cut here stands still behind).
            return (0, None);
        };
        let third = self.third_corner(obs, master);
        match self.adaptation(obs, m, third, lead) {
            Some(target) => {
                self.trapped = 0;
                self.drive(obs, target, act);
                (0, None)
            }
            None => {
                self.trapped += 1;
                if self.trapped >= self.p.trapped_ticks {
                    (1, Some(VetoWhy::Trapped))
                } else {
                    (0, None)
                }
            }
        }
    }

    /// The initiator's tick: Table 2, unless a veto stopped it.
    fn lead(&mut self, obs: &Observation, act: &mut Act<Link, ChainNote>) {
        let sides = sides(obs, &self.lidar, self.p.side_sector_deg, 1.5 * self.radius);
        if let Some(v) = self.veto_in.filter(|v| obs.tick < v.until) {
            if self.replan.is_none() {
                let turn = self.p.replan_turn_deg.to_radians();
                let turn = if sides.left >= sides.right { turn } else { -turn };
                self.replan = Some(turn);
                act.note(ChainNote::Replan {
                    depth: v.depth,
                    turn_deg: turn.to_degrees() as f32,
                });
            }
            self.turning = (0, 0.0);
            if let Some(s) = self.locate(obs, v.from) {
                let target = self.give_way(s, (obs.x, obs.y));
                self.drive(obs, target, act);
            }
            return;
        }
        if let Some(turn) = self.replan.take() {
            let rate = self.max_turn_rate.min(self.p.speed / self.p.axle).max(1e-6);
            let ticks = (turn.abs() / (rate * self.dt)).round() as u32;
            self.turning = (ticks, rate * turn.signum());
        }
        if self.turning.0 > 0 {
            self.turning.0 -= 1;
            act.omega = self.turning.1;
            return;
        }
        let target = (obs.goal_visible != 0)
            .then_some(Target {
                bearing: obs.goal_bearing,
                reached: obs.reached != 0,
            })
            .filter(|t| !t.reached || self.p.stop_at_target);
        let (_, wheels) = subsume(sides, target, &self.p);
        (act.v, act.omega) = unicycle(wheels, self.p.axle, self.max_turn_rate);
    }
}

impl Behaviour for Chain {
    const KIND: &'static str = "chain";
    type Params = ChainParams;
    type Msg = Link;
    type Note = ChainNote;
    const METRICS: &'static [&'static str] = &metrics::NAMES;

    fn new(cfg: &Config, params: &ChainParams, id: u32) -> Chain {
        let n = cfg.robots.count;
        let c = params.initiator;
        let master = match id.cmp(&c) {
            std::cmp::Ordering::Greater => Some(id - 1),
            std::cmp::Ordering::Less => Some(id + 1),
            std::cmp::Ordering::Equal => None,
        };
        let slaves: Vec<u32> = [id.checked_sub(1), id.checked_add(1)]
            .into_iter()
            .flatten()
            .filter(|&s| s < n && Some(s) != master)
            .collect();
        Chain {
            p: params.clone(),
            id,
            master,
            slaves,
            stationary: params.stationary.contains(&id),
            dt: cfg.scenario.dt,
            max_speed: cfg.robots.max_speed,
            max_turn_rate: cfg.robots.max_turn_rate,
            radius: cfg.robots.radius,
            lidar: cfg.robots.lidar.clone(),
            known: [Known::default(); 3],
            master_prev: None,
            trail: VecDeque::new(),
            hits: Vec::new(),
            trapped: 0,
            veto_in: None,
            vetoing: 0,
            replan: None,
            turning: (0, 0.0),
            rng: rng::stream(cfg.scenario.seed, "chain-shake", id as u64),
            rounds: cfg.radio.rounds > 0,
        }
    }

    fn step(&mut self, obs: &Observation, inbox: &[Heard<Link>], act: &mut Act<Link, ChainNote>) {
        if obs.state != RobotState::Active as u8 {
            return;
        }
        act.lidar_on = true;
        for h in inbox {
            let Some(k) = self.slot(h.src) else { continue };
            let msg = &h.msg;
            let finite = |[x, y]: [f32; 2]| x.is_finite() && y.is_finite();
            if !finite([msg.x, msg.y]) || !msg.master.is_none_or(finite) {
                continue; // a position no robot can be at: not worth following
            }
            self.known[k] = Known {
                radio: Some((msg.x as f64, msg.y as f64)),
                radio_master: msg.master.map(|[x, y]| (x as f64, y as f64)),
            };
            let deeper = self.veto_in.is_none_or(|v| obs.tick >= v.until || msg.veto > v.depth);
            if k > 0 && msg.veto > 0 && deeper {
                self.veto_in = Some(VetoIn {
                    from: h.src,
                    depth: msg.veto,
                    until: obs.tick + self.p.veto_hold as u64,
                });
            } else if k > 0
                && msg.veto > 0
                && let Some(v) = self.veto_in.as_mut().filter(|v| v.from == h.src)
            {
                v.until = obs.tick + self.p.veto_hold as u64;
            }
        }
        let (veto, why) = if self.master.is_some() {
            self.follow(obs, act)
        } else {
            self.lead(obs, act);
            if self.rounds {
                self.pass_on(obs, None, act);
            }
            (0, None)
        };
        if let (Some(master), Some(why)) = (self.master, why)
            && veto > 0
            && self.vetoing == 0
        {
            act.note(ChainNote::Veto {
                master,
                depth: veto,
                why,
            });
        }
        self.vetoing = veto;
        let me = Link {
            x: obs.x as f32,
            y: obs.y as f32,
            master: None,
            veto: 0,
        };
        if let Some(master) = self.master {
            act.send(master, Link { veto, ..me });
            let m = self.locate(obs, master).map(|(x, y)| [x as f32, y as f32]);
            for &s in &self.slaves {
                act.send(s, Link { master: m, ..me });
            }
        } else {
            // The initiator: each slave's third corner is the other slave.
            for &s in &self.slaves {
                let other = self.slaves.iter().find(|&&o| o != s).copied();
                let m = other
                    .and_then(|o| self.locate(obs, o))
                    .map(|(x, y)| [x as f32, y as f32]);
                act.send(s, Link { master: m, ..me });
            }
        }
    }

    /// Appendix A's recursion over the radio (`radio.rounds`): the master's motion of this
    /// tick arrives within the tick as where it will be; the slave adapts to that point
    /// instead of to where it sees its master now, and passes its own new motion on to its
    /// slaves in the next round, so the whole chain moves as one body in one tick. A robot
    /// that is stationary, in a veto event or trapped keeps its decision and passes nothing
    /// on (the chain behind it adapts at the next tick, as without rounds).
    fn react(&mut self, obs: &Observation, round: &[Heard<Link>], act: &mut Act<Link, ChainNote>) {
        let Some(master) = self.master else { return };
        if obs.state != RobotState::Active as u8 || self.stationary {
            return;
        }
        if self.veto_in.is_some_and(|v| obs.tick < v.until) {
            return;
        }
        let finite = |[x, y]: [f32; 2]| x.is_finite() && y.is_finite();
        let Some(link) = round
            .iter()
            .rev()
            .find(|h| h.src == master)
            .map(|h| h.msg)
            .filter(|l| finite([l.x, l.y]) && l.master.is_none_or(finite))
        else {
            return;
        };
        let m = (link.x as f64, link.y as f64);
        let third = link.master.map(|[x, y]| (x as f64, y as f64));
        // Around an obstacle the tick's decision already follows the master's trail (or its
        // shake): that is kept, and only where this robot will be is passed on.
        self.sense_hits(obs);
        let clearance = self.radius + self.p.line_clearance;
        let ignore = 2.0 * self.radius + self.p.line_clearance;
        let m_here = to_robot_frame((obs.x, obs.y, obs.theta), m);
        if !line_blocked(&self.hits, m_here, clearance, ignore) {
            let Some(target) = self.adaptation(obs, m, third, 0.0) else {
                return;
            };
            self.drive(obs, target, act);
        }
        self.pass_on(obs, Some([link.x, link.y]), act);
    }

    fn metrics(cfg: &Config, params: &ChainParams, run: &Records) -> Vec<(&'static str, serde_json::Value)> {
        metrics::metrics(cfg, params, run)
    }

    fn series(cfg: &Config, params: &ChainParams, run: &Records) -> Vec<Series> {
        metrics::series(cfg, params, run)
    }
}

#[cfg(test)]
mod tests;
