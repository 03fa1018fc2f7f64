//! `swarm fuzz quadrant`: how often the quadrant leader choice (seed 001, section 2.2)
//! leaves exactly one leader in a group of 3 to 9 robots (a measurement, not a test).
//!
//! A trial places one group of `n` robots uniformly at random (seeded) in a disc holding
//! `area_per_robot` square metres per robot, at least 0.4 m apart, with random headings: the
//! paper assumes robots are not all on one line, which random placement makes almost sure.
//! Each robot's range-and-bearing sensor (3 m, as the world's default) sees the others within
//! range, in its own frame. The robots run the real agent (claims over the real radio
//! medium with Bernoulli `loss`) until `decide_tick + settle` ticks; then the trial counts the
//! robots that declare themselves leader.

use rand::Rng as _;
use std::f64::consts::PI;
use swarmrt_agent::consensus::stream;
use swarmrt_protocol::{MAX_NEIGHBOURS, Neighbour};
use swarmrt_scenario::LossModel;
use swarmrt_scenario::consensus::{Algorithm, ConsensusConfig, QuadrantConfig};

use super::{Sim, base_config};

/// Sensing range of the range-and-bearing sensor in the trials (the world's default).
pub const SENSE_RANGE: f64 = 3.0;

/// One trial's result.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Trial {
    /// Robots that declared themselves leader at the end.
    pub leaders: usize,
    /// Every robot saw every other (one group by the paper's sensing).
    pub all_see_all: bool,
    /// The highest score was held by one robot only (no random tie-break needed).
    pub unique_top: bool,
    /// Every robot believes in the same leader.
    pub agree: bool,
    /// The sensing graph is connected: the robots form one group by the paper's sensing, so
    /// exactly one leader is the right answer (a split group rightly has two).
    pub connected: bool,
}

/// Runs trial `seed` for a group of `n` robots.
pub fn trial(n: u32, loss: f64, area_per_robot: f64, seed: u64) -> Trial {
    let mut rng = stream(seed, "quadrant-trial", n as u64);
    let radius = (n as f64 * area_per_robot / PI).sqrt();
    let mut pos: Vec<(f64, f64)> = Vec::new();
    let mut attempts = 0;
    while pos.len() < n as usize {
        attempts += 1;
        let (r, a) = (
            radius * rng.random::<f64>().sqrt(),
            rng.random_range(-PI..PI),
        );
        let p = (r * a.cos(), r * a.sin());
        let clear = pos
            .iter()
            .all(|q| ((p.0 - q.0).powi(2) + (p.1 - q.1).powi(2)).sqrt() >= 0.4);
        if clear || attempts > 100_000 {
            pos.push(p);
        }
    }
    let headings: Vec<f64> = (0..n).map(|_| rng.random_range(-PI..PI)).collect();
    let mut sees: Vec<Vec<Neighbour>> = Vec::new();
    for (i, &p) in pos.iter().enumerate() {
        let mut v: Vec<Neighbour> = pos
            .iter()
            .enumerate()
            .filter(|&(j, _)| j != i)
            .filter_map(|(j, &q)| {
                let d = ((q.0 - p.0).powi(2) + (q.1 - p.1).powi(2)).sqrt();
                (d <= SENSE_RANGE).then(|| Neighbour {
                    id: j as u32,
                    range: d,
                    bearing: wrap((q.1 - p.1).atan2(q.0 - p.0) - headings[i]),
                })
            })
            .collect();
        v.sort_by(|a, b| a.range.total_cmp(&b.range).then(a.id.cmp(&b.id)));
        v.truncate(MAX_NEIGHBOURS);
        sees.push(v);
    }
    let mut cfg = base_config();
    cfg.scenario.seed = seed;
    cfg.robots.count = n;
    cfg.radio.loss_model = LossModel::Bernoulli;
    cfg.radio.loss = loss;
    let quadrant = QuadrantConfig::default();
    cfg.consensus = Some(ConsensusConfig {
        algorithm: Algorithm::Quadrant,
        quadrant,
        ..ConsensusConfig::default()
    });
    let all_see_all = sees.iter().all(|v| v.len() + 1 == n as usize);
    let connected = {
        let mut seen = vec![false; n as usize];
        let mut stack = vec![0usize];
        seen[0] = true;
        while let Some(i) = stack.pop() {
            for nb in &sees[i] {
                if !seen[nb.id as usize] {
                    seen[nb.id as usize] = true;
                    stack.push(nb.id as usize);
                }
            }
        }
        seen.iter().all(|&s| s)
    };
    let scores: Vec<u8> = sees
        .iter()
        .map(|v| swarmrt_agent::consensus::quadrant::score(v))
        .collect();
    let top = scores.iter().copied().max().unwrap_or(0);
    let unique_top = scores.iter().filter(|&&s| s == top).count() == 1;
    let mut sim = Sim::new(&cfg, pos);
    sim.set_senses(headings, sees);
    while sim.tick() < quadrant.decide_tick + 30 {
        sim.step(None);
    }
    let beliefs: Vec<Option<u32>> = (0..n)
        .map(|r| {
            sim.agent(r)
                .and_then(|a| a.consensus())
                .and_then(|c| c.quadrant())
                .and_then(|q| q.leader())
        })
        .collect();
    let leaders = beliefs
        .iter()
        .enumerate()
        .filter(|&(r, b)| *b == Some(r as u32))
        .count();
    Trial {
        leaders,
        all_see_all,
        unique_top,
        agree: beliefs.iter().all(|b| b.is_some() && *b == beliefs[0]),
        connected,
    }
}

fn wrap(a: f64) -> f64 {
    let mut a = a % (2.0 * PI);
    if a <= -PI {
        a += 2.0 * PI;
    } else if a > PI {
        a -= 2.0 * PI;
    }
    a
}
