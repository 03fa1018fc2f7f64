//! Virtual-leader formation with observer lidars and epsilon-greedy (seed 000).
//!
//! Every tick each robot, from its own pose and the formation messages it actually received:
//! 1. estimates the virtual leader (eq. 2-3) and the swarm heading (circular mean of the
//!    headings its neighbours hold, so robots that disagreed converge again);
//! 2. reads the observers' lidar verdicts sent last tick and decides the swarm's turn with
//!    section 5.2's table, then epsilon-greedy (section 5.3) may flip its own turn;
//! 3. picks the observers in the leader frame (eq. 4-5) and turns its lidar on if it is one;
//! 4. steers at constant speed toward its slot in the formation, turning at most the turn
//!    angle per step, and broadcasts its pose, heading, role and lidar verdict.
//!
//! Agreement comes from everyone applying the same rules to the same messages; under loss or
//! delay the inputs differ, and the heading averaging pulls robots that disagreed back together.

pub mod direction;
pub mod messages;
pub mod metrics;
pub mod observers;
mod overlay;
mod params;

use std::collections::BTreeMap;

use serde_json::Value;
use swarmrt_protocol::records::Records;
use swarmrt_protocol::{BROADCAST, Observation};
use swarmrt_scenario::rng::{self, Rng};
use swarmrt_scenario::{Config, LidarConfig, wrap_angle};

use self::direction::{Dir, Seen};
use self::observers::{ObserverRole, Placed};
use crate::behaviour::{Act, Behaviour};
use crate::inbox::Heard;
pub use messages::{FormationMsg, FormationNote, range_from_wire, range_to_wire};
pub use params::FormationParams;

/// The desired formation: each robot's offset from the virtual leader, i.e. its start position
/// relative to the centre of the start layout (section 5.1: the virtual leader starts at the
/// centre of the desired formation). Assumes the start area is free of obstacles.
pub fn offsets(cfg: &Config) -> Vec<(f64, f64)> {
    let starts = cfg.start_positions(|_, _| true).unwrap_or_else(|| {
        let s = &cfg.robots.start;
        vec![(s.x.unwrap_or(0.0), s.y.unwrap_or(0.0)); cfg.robots.count as usize]
    });
    let n = starts.len().max(1) as f64;
    let cx = starts.iter().map(|p| p.0).sum::<f64>() / n;
    let cy = starts.iter().map(|p| p.1).sum::<f64>() / n;
    starts.iter().map(|p| (p.0 - cx, p.1 - cy)).collect()
}

/// What a robot last heard from a neighbour.
#[derive(Debug, Clone, Copy, PartialEq)]
struct LastHeard {
    sent_tick: u64,
    x: f64,
    y: f64,
    theta: f64,
    v: f64,
    psi: f64,
    role: ObserverRole,
    /// The sender's lidar verdict: metres to the nearest obstacle in its cone, if any.
    obstacle: Option<f64>,
}

/// One robot's formation state.
pub struct Formation {
    id: u32,
    p: FormationParams,
    offsets: Vec<(f64, f64)>,
    goal: (f64, f64),
    /// Distance from the goal at which the virtual leader stops.
    arrive: f64,
    dt: f64,
    radius: f64,
    lidar: LidarConfig,
    seed: u64,
    turn: f64,
    /// The swarm heading this robot holds.
    psi: f64,
    previous: Dir,
    heard: BTreeMap<u32, LastHeard>,
    /// This robot's own message of last tick, used like a received one so that every robot
    /// decides from verdicts of the same age.
    own: Option<LastHeard>,
    /// The role this robot's lidar is on for (decided last tick).
    role: ObserverRole,
    stopped: bool,
    epsilon: Rng,
}

impl Formation {
    /// Robot `id`'s formation behaviour.
    pub fn new(cfg: &Config, p: &FormationParams, id: u32) -> Formation {
        let offsets = offsets(cfg);
        let spread = offsets.iter().map(|o| o.0.hypot(o.1)).fold(0.0, f64::max);
        let g = cfg.map.goal;
        Formation {
            id,
            p: *p,
            goal: (g.x, g.y),
            arrive: (g.radius - spread - cfg.robots.radius).max(p.speed * cfg.scenario.dt),
            offsets,
            dt: cfg.scenario.dt,
            radius: cfg.robots.radius,
            lidar: cfg.robots.lidar.clone(),
            seed: cfg.scenario.seed,
            turn: p.turn_deg.to_radians(),
            psi: cfg.start_heading(),
            previous: Dir::Straight,
            heard: BTreeMap::new(),
            own: None,
            role: ObserverRole::None,
            stopped: false,
            epsilon: rng::stream(cfg.scenario.seed, "formation-epsilon", id as u64),
        }
    }

    /// The swarm heading this robot holds.
    pub fn psi(&self) -> f64 {
        self.psi
    }

    /// The role its lidar is on for.
    pub fn role(&self) -> ObserverRole {
        self.role
    }

    fn offset(&self, id: u32) -> (f64, f64) {
        self.offsets.get(id as usize).copied().unwrap_or((0.0, 0.0))
    }

    /// Neighbours heard recently enough to count, with poses extrapolated to `tick`.
    fn alive(&self, tick: u64) -> Vec<(u32, f64, f64, LastHeard)> {
        self.heard
            .iter()
            .filter(|(_, h)| tick.saturating_sub(h.sent_tick) <= self.p.stale_ticks as u64)
            .map(|(&id, h)| {
                let age = tick.saturating_sub(h.sent_tick) as f64 * self.dt;
                let (s, c) = h.theta.sin_cos();
                (id, h.x + h.v * age * c, h.y + h.v * age * s, *h)
            })
            .collect()
    }

    /// The freshest verdict per role among the messages of the last `verdict_ticks` ticks;
    /// several robots claiming one role at the same age are or-ed (the nearest range kept).
    fn verdicts(&self, tick: u64) -> Seen {
        let mut best: [(u64, Option<f64>); 4] = [(0, None); 4];
        let recent = |h: &LastHeard| {
            h.role != ObserverRole::None
                && h.sent_tick < tick
                && tick - h.sent_tick <= self.p.verdict_ticks as u64
        };
        for h in self.heard.values().chain(self.own.iter()) {
            if !recent(h) {
                continue;
            }
            let slot = &mut best[h.role as usize];
            if h.sent_tick + 1 > slot.0 {
                *slot = (h.sent_tick + 1, h.obstacle);
            } else if h.sent_tick + 1 == slot.0 {
                slot.1 = match (slot.1, h.obstacle) {
                    (Some(a), Some(b)) => Some(a.min(b)),
                    (a, b) => a.or(b),
                };
            }
        }
        let [_, middle, left, right] = best.map(|b| b.1);
        Seen {
            middle: middle.is_some(),
            left: left.is_some(),
            right: right.is_some(),
            left_range: left.unwrap_or(f64::INFINITY),
            right_range: right.unwrap_or(f64::INFINITY),
        }
    }

    /// The distance to the nearest obstacle (not a known teammate) this robot's lidar sees in
    /// `role`'s cone within the detect range, if any.
    fn lidar_verdict(
        &self,
        obs: &Observation,
        role: ObserverRole,
        psi: f64,
        mates: &[(f64, f64)],
    ) -> Option<f64> {
        let side = self.p.side_offset_deg.to_radians();
        let centre = psi
            + match role {
                ObserverRole::Left => side,
                ObserverRole::Right => -side,
                _ => 0.0,
            };
        let cone = self.p.cone_deg.to_radians();
        obs.lidar()
            .iter()
            .enumerate()
            .filter(|&(k, &range)| {
                let angle = obs.theta + self.lidar.ray_angle(k);
                if wrap_angle(angle - centre).abs() > cone || range >= self.p.detect_range {
                    return false;
                }
                let hit = (obs.x + range * angle.cos(), obs.y + range * angle.sin());
                // A hit on a teammate is not an obstacle for the swarm.
                !mates
                    .iter()
                    .any(|m| (m.0 - hit.0).hypot(m.1 - hit.1) < 2.0 * self.radius + 0.1)
            })
            .map(|(_, &range)| range)
            .reduce(f64::min)
    }
}

impl Behaviour for Formation {
    const KIND: &'static str = "formation";
    type Params = FormationParams;
    type Msg = FormationMsg;
    type Note = FormationNote;
    const METRICS: &'static [&'static str] = &metrics::NAMES;

    fn new(cfg: &Config, params: &FormationParams, id: u32) -> Formation {
        Formation::new(cfg, params, id)
    }

    fn metrics(
        cfg: &Config,
        _params: &FormationParams,
        run: &Records,
    ) -> Vec<(&'static str, Value)> {
        metrics::metrics(cfg, run)
    }

    fn step(
        &mut self,
        obs: &Observation,
        inbox: &[Heard<FormationMsg>],
        act: &mut Act<FormationMsg, FormationNote>,
    ) {
        let tick = obs.tick;
        for m in inbox {
            {
                let FormationMsg {
                    x,
                    y,
                    theta,
                    v,
                    psi,
                    role,
                    obstacle,
                } = m.msg;
                let newer = self
                    .heard
                    .get(&m.src)
                    .is_none_or(|h| h.sent_tick <= m.sent_tick);
                let sane = [x, y, theta, v, psi].iter().all(|f| f.is_finite());
                if newer && sane && m.src != self.id {
                    self.heard.insert(
                        m.src,
                        LastHeard {
                            sent_tick: m.sent_tick,
                            x,
                            y,
                            theta,
                            v,
                            psi,
                            role: ObserverRole::from_u8(role),
                            obstacle: range_from_wire(obstacle),
                        },
                    );
                }
            }
        }
        let alive = self.alive(tick);

        // 1. Virtual leader (eq. 2-3) over this robot and the neighbours it hears; swarm
        //    heading as the circular mean of the headings they hold.
        let me = (obs.x, obs.y);
        let own_offset = self.offset(self.id);
        let (mut lx, mut ly) = (me.0 - own_offset.0, me.1 - own_offset.1);
        let (mut sin, mut cos) = self.psi.sin_cos();
        for &(id, x, y, h) in &alive {
            let o = self.offset(id);
            lx += x - o.0;
            ly += y - o.1;
            sin += h.psi.sin();
            cos += h.psi.cos();
        }
        let count = (alive.len() + 1) as f64;
        let leader = (lx / count, ly / count);
        self.psi = sin.atan2(cos);

        // 2. The turn from last tick's verdicts, then epsilon-greedy.
        let seen = self.verdicts(tick);
        let to_goal = (self.goal.1 - leader.1).atan2(self.goal.0 - leader.0);
        let target_error = wrap_angle(to_goal - self.psi);
        let (seed, half) = (self.seed, self.turn / 2.0);
        let tie = self.p.gap_tie;
        let dir = direction::decide(seen, self.previous, target_error, half, tie, || {
            // Every robot draws the same coin for the same tick: the side is common knowledge.
            use rand::Rng as _;
            rng::stream(seed, "formation-side", tick).random::<bool>()
        });
        let (dir, flipped) = direction::epsilon_greedy(
            dir,
            seen,
            self.p.epsilon_obstacle,
            self.p.epsilon_clear,
            &mut self.epsilon,
        );
        if flipped {
            act.note(FormationNote::EpsilonFlip);
        }
        if dir != self.previous {
            act.note(FormationNote::Turn { dir: dir as i8 });
        }
        self.previous = dir;
        let psi_before = self.psi;
        self.psi = wrap_angle(self.psi + dir.sign() * self.turn);

        // 3. This tick's lidar verdict (for the role the lidar was on for), then next tick's
        //    observers in the leader frame (eq. 4-5).
        let mates: Vec<(f64, f64)> = alive.iter().map(|a| (a.1, a.2)).collect();
        let obstacle = if self.role == ObserverRole::None {
            None
        } else {
            // Quantised as the radio carries it, so own and heard verdicts agree.
            range_from_wire(range_to_wire(
                self.lidar_verdict(obs, self.role, psi_before, &mates),
            ))
        };
        let verdict_role = self.role;
        let arrived = (leader.0 - self.goal.0).hypot(leader.1 - self.goal.1) <= self.arrive;
        self.stopped |= arrived;
        let placed: Vec<Placed> = std::iter::once((self.id, me.0, me.1))
            .chain(alive.iter().map(|a| (a.0, a.1, a.2)))
            .map(|(id, x, y)| {
                let (x, y) = observers::to_leader_frame(x, y, leader, self.psi);
                Placed { id, x, y }
            })
            .collect();
        let role = if self.stopped {
            ObserverRole::None
        } else {
            observers::select(&placed, self.radius).role_of(self.id)
        };
        if role != self.role {
            act.note(FormationNote::Role { role: role as u8 });
        }
        self.role = role;

        // 4. Steer at constant speed toward the slot, at most the turn angle per step.
        let v = if self.stopped { 0.0 } else { self.p.speed };
        if !self.stopped {
            let (s, c) = self.psi.sin_cos();
            let slot = (
                leader.0 + own_offset.0 + self.p.lookahead * c,
                leader.1 + own_offset.1 + self.p.lookahead * s,
            );
            let want = (slot.1 - me.1).atan2(slot.0 - me.0);
            let err = wrap_angle(want - obs.theta).clamp(-self.turn, self.turn);
            act.v = v;
            act.omega = err / self.dt;
        }
        act.lidar_on = role != ObserverRole::None;
        let msg = LastHeard {
            sent_tick: tick,
            x: me.0,
            y: me.1,
            theta: obs.theta,
            v,
            psi: self.psi,
            role: verdict_role,
            obstacle,
        };
        self.own = Some(msg);
        act.send(
            BROADCAST,
            FormationMsg {
                x: msg.x,
                y: msg.y,
                theta: msg.theta,
                v: msg.v,
                psi: msg.psi,
                role: msg.role as u8,
                obstacle: range_to_wire(msg.obstacle),
            },
        );
    }
}

#[cfg(test)]
mod tests;
