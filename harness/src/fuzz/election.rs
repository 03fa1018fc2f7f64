//! `swarm fuzz election`: how long the first election and a re-election after the leader
//! crashes take, in ticks, over seeds (a measurement, not a test).
//!
//! Each run is the in-process [`Sim`]: robots on a 0.7 m grid, all within radio range, the
//! radio and consensus timing of `configs/raft_election.toml` (delay 2 ticks, capacity 4,
//! beacons every 5 ticks, election timeout 20..40, heartbeat 4) except robot count and loss.
//! The first leader is the first `leader` state note; `leader_wait` ticks after it, the
//! leader of that moment crashes, and the re-election time runs from the crash to the next
//! leader's note (the checker's `reelection_ticks`).

use swarmrt_scenario::LossModel;

use super::{Sim, base_config, grid};

/// One run's result.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ElectionRun {
    /// Tick of the first leader.
    pub first_leader: Option<u64>,
    /// Ticks from the leader's crash to the next leader.
    pub reelection: Option<u64>,
}

/// Ticks a run waits for a leader before giving up.
pub const GIVE_UP: u64 = 5000;

/// Runs one measurement with `n` robots, Bernoulli `loss` and run seed `seed`.
pub fn measure(n: u32, loss: f64, seed: u64, leader_wait: u64) -> ElectionRun {
    let mut cfg = base_config();
    cfg.scenario.seed = seed;
    cfg.robots.count = n;
    cfg.radio.loss_model = LossModel::Bernoulli;
    cfg.radio.loss = loss;
    cfg.radio.delay_ticks = 2;
    cfg.radio.capacity = 4;
    let mut sim = Sim::new(&cfg, grid(n as usize, 0.7));
    while sim.checker().first_leader_tick().is_none() && sim.tick() < GIVE_UP {
        sim.step(None);
    }
    let first_leader = sim.checker().first_leader_tick();
    let mut reelection = None;
    if first_leader.is_some() {
        for _ in 0..leader_wait {
            sim.step(None);
        }
        if let Some(l) = sim.leader() {
            sim.crash(l);
            let until = sim.tick() + GIVE_UP;
            while sim.checker().reelection_ticks().is_empty() && sim.tick() < until {
                sim.step(None);
            }
            reelection = sim.checker().reelection_ticks().first().copied();
        }
    }
    assert!(
        sim.checker().violations().is_empty(),
        "seed {seed}: {:?}",
        sim.checker().violations()
    );
    ElectionRun {
        first_leader,
        reelection,
    }
}

/// The median of `v` (the lower middle for an even count); `None` when empty.
pub fn median(v: &mut [u64]) -> Option<u64> {
    if v.is_empty() {
        return None;
    }
    v.sort_unstable();
    Some(v[(v.len() - 1) / 2])
}
