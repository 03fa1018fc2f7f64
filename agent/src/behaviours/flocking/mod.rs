//! Flocking through clutter (seed 004: Chatton, Gabeff, Petrescu, after Turgut et al. 2008).
//!
//! Every tick a robot broadcasts its id and heading, remembers the flock-mates it heard
//! (`mates.rs`, forgotten after `time_out`), and steers toward the desired heading a(t) of
//! eq. 1 (`desired.rs`): heading alignment with a migratory bias, proximal repulsion from its
//! eight IR sensors (a ring of short lidar rays), and cohesion toward the centre of mass of the
//! mates whose messages it heard, located by range-and-bearing. The wheels follow eq. 10-13
//! (`wheels.rs`). Flock k is start group k (`robots.start.groups`), so two flocks can migrate
//! in opposite directions and ignore each other's messages. Metrics (eq. 14-22) are in
//! `metrics.rs`.

mod desired;
mod mates;
mod messages;
mod metrics;
mod overlay;
mod params;
mod wheels;

pub use desired::V2;
pub use mates::{Mate, Mates};
pub use messages::{BYTE_ANGLES, FlockMsg, decode_byte, encode_byte};
pub use metrics::{FlockTick, flock_ticks};
pub use params::{BYTE_MAX_ROBOTS, Encoding, FlockingParams, HeadingSource};

/// The equations, public for tests and for anyone reusing them.
pub mod equations {
    pub use super::desired::*;
    pub use super::wheels::*;
}

use nalgebra::Rotation2;
use swarmrt_protocol::records::Records;
use swarmrt_protocol::{BROADCAST, Observation};
use swarmrt_scenario::{Config, wrap_angle};

use crate::behaviour::{Act, Behaviour, NoNote, Series};
use crate::inbox::Heard;

/// One robot's flocking state.
pub struct Flocking {
    id: u32,
    params: FlockingParams,
    /// Its flock (start group).
    flock: u8,
    /// Its flock's migration direction, radians.
    migration: f64,
    dt: f64,
    /// 2 pi R: forward speed at full wheel rotation (`robots.max_speed`).
    top: f64,
    max_turn: f64,
    radius: f64,
    sensor_range: f64,
    /// phi_k: each proximity ray's angle from the heading.
    sensor_angles: Vec<f64>,
    time_out_ticks: u64,
    mates: Mates,
    /// Dead-reckoned position (from its own commands) and heading estimate.
    x: f64,
    y: f64,
    theta: f64,
    /// The command it gave last tick (what odometry integrates).
    last: (f64, f64),
}

impl Flocking {
    /// Robot `id`'s behaviour for this scenario.
    pub fn new(cfg: &Config, params: &FlockingParams, id: u32) -> Flocking {
        let flock = cfg.start_group(id);
        let migration = params
            .migration_deg
            .get(flock)
            .or(params.migration_deg.first())
            .copied()
            .unwrap_or(0.0)
            .to_radians();
        let lidar = &cfg.robots.lidar;
        Flocking {
            id,
            params: params.clone(),
            flock: flock as u8,
            migration,
            dt: cfg.scenario.dt,
            top: cfg.robots.max_speed,
            max_turn: cfg.robots.max_turn_rate,
            radius: cfg.robots.radius,
            sensor_range: lidar.range,
            sensor_angles: (0..lidar.rays as usize).map(|k| lidar.ray_angle(k)).collect(),
            time_out_ticks: (params.time_out / cfg.scenario.dt).round() as u64,
            mates: Mates::new(cfg.robots.count as usize),
            x: 0.0,
            y: 0.0,
            theta: cfg.nominal_heading(id),
            last: (0.0, 0.0),
        }
    }

    /// Its current heading estimate, radians.
    pub fn heading(&self) -> f64 {
        self.theta
    }

    /// The flock-mates it remembers.
    pub fn mates(&self) -> &Mates {
        &self.mates
    }

    /// Updates the heading estimate and the dead-reckoned position from last tick's command
    /// (the world turns first, then moves along the new heading).
    fn update_pose(&mut self, obs: &Observation) {
        let (v, omega) = self.last;
        self.theta = match self.params.heading {
            HeadingSource::Compass => obs.theta,
            HeadingSource::Odometry => wrap_angle(self.theta + omega * self.dt),
        };
        self.x += v * self.dt * self.theta.cos();
        self.y += v * self.dt * self.theta.sin();
    }

    /// Remembers the heading (and, if range-and-bearing sees it, the position) of each
    /// flock-mate heard this tick.
    fn listen(&mut self, obs: &Observation, inbox: &[Heard<FlockMsg>]) {
        for h in inbox {
            let (id, flock, heading) = match h.msg {
                FlockMsg::Heading { flock, heading } => (h.src, flock, heading as f64),
                FlockMsg::Byte(b) => {
                    let (id, heading) = decode_byte(b);
                    (id, self.flock, heading)
                }
            };
            if flock != self.flock || id == self.id {
                continue;
            }
            let byte = matches!(h.msg, FlockMsg::Byte(_));
            let seen = obs
                .neighbours()
                .iter()
                .find(|n| if byte { n.id & 7 == id } else { n.id == id });
            let position = seen.map(|n| {
                let a = self.theta + n.bearing;
                V2::new(self.x + n.range * a.cos(), self.y + n.range * a.sin())
            });
            self.mates.heard(
                id,
                Mate {
                    heading,
                    position,
                    heard: obs.tick,
                },
            );
        }
        self.mates.expire(obs.tick, self.time_out_ticks);
    }
}

impl Behaviour for Flocking {
    const KIND: &'static str = "flocking";
    type Params = FlockingParams;
    type Msg = FlockMsg;
    type Note = NoNote;
    const METRICS: &'static [&'static str] = &metrics::NAMES;

    fn new(cfg: &Config, params: &FlockingParams, id: u32) -> Flocking {
        Flocking::new(cfg, params, id)
    }

    fn step(&mut self, obs: &Observation, inbox: &[Heard<FlockMsg>], act: &mut Act<FlockMsg, NoNote>) {
        use equations::*;
        self.update_pose(obs);
        self.listen(obs, inbox);
        let p = &self.params;
        let to_body = Rotation2::new(-self.theta);
        let here = V2::new(self.x, self.y);
        let headings: Vec<f64> = self
            .mates
            .iter()
            .map(|(_, m)| wrap_angle(m.heading - self.theta))
            .collect();
        let positions: Vec<V2> = self
            .mates
            .iter()
            .filter_map(|(_, m)| m.position.map(|q| to_body * (q - here)))
            .collect();
        let h = heading_alignment(p.mb, wrap_angle(self.migration - self.theta), alignment(&headings));
        let levels: Vec<f64> = obs
            .lidar()
            .iter()
            .map(|&d| level(d, self.radius, self.sensor_range))
            .collect();
        let prox = proximal(&levels, &self.sensor_angles);
        let gamma = proximal_weight(p.beta, p.iota, strongest(&levels));
        let c = cohesion(&positions);
        let d = c.norm();
        let delta_w = cohesion_weight(p.delta, p.zeta, d, p.desired_distance);
        let a = desired(p.alpha, h, gamma, prox, delta_w, c);
        let dot_ch = if d > p.desired_distance { h.dot(&(c / d)) } else { 0.0 };
        let u = forward_speed(self.top, a.x, dot_ch);
        let omega = turn_rate(p.kappa, a.y.atan2(a.x), p.wheel_radius, p.axle);
        let (v, omega) = unicycle(u, omega, p.axle, self.top);
        let (v, omega) = (v.clamp(0.0, self.top), omega.clamp(-self.max_turn, self.max_turn));
        act.v = v;
        act.omega = omega;
        act.lidar_on = true;
        act.send(
            BROADCAST,
            match p.encoding {
                Encoding::Full => FlockMsg::Heading {
                    flock: self.flock,
                    heading: self.theta as f32,
                },
                Encoding::Byte => FlockMsg::Byte(encode_byte(self.id, self.theta)),
            },
        );
        self.last = (v, omega);
    }

    fn metrics(cfg: &Config, params: &FlockingParams, run: &Records) -> Vec<(&'static str, serde_json::Value)> {
        metrics::metrics(cfg, params, run)
    }

    fn series(cfg: &Config, params: &FlockingParams, run: &Records) -> Vec<Series> {
        vec![metrics::series(cfg, params, run)]
    }
}

#[cfg(test)]
mod tests;
