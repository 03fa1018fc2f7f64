//! `--in-process`: the same world and agent cores, called directly in one process, in the
//! same order as the multi-process shells, so the records come out byte-identical.

use std::path::Path;

use swarmrt_agent::Agent;
use swarmrt_protocol::Observation;
use swarmrt_protocol::config::Config;
use swarmrt_world::records::Recorder;
use swarmrt_world::{World, WorldMetrics};

/// Runs the scenario to the end (or until `interrupt` fires, checked every tick), recording
/// into `dir`; `progress` gets each completed tick. Returns the metrics and whether it was
/// interrupted.
pub fn run(
    cfg: &Config,
    dir: &Path,
    interrupt: &crossbeam_channel::Receiver<()>,
    mut progress: impl FnMut(u64),
) -> anyhow::Result<(WorldMetrics, bool)> {
    let mut world = World::new(cfg).map_err(|e| anyhow::anyhow!("{}: {}", e.key, e.message))?;
    let n = cfg.robots.count as usize;
    let mut agents: Vec<Agent> = (0..n as u32).map(|id| Agent::new(cfg, id)).collect();
    let mut recorder = Recorder::create(dir)?;
    let mut obs = vec![Observation::empty(0, 0); n];
    let events = world.drain_events();
    recorder.record(world.tick(), world.robots(), &events)?;
    let mut interrupted = false;
    while !world.finished() {
        if interrupt.try_recv().is_ok() {
            interrupted = true;
            break;
        }
        // A scheduled kill only marks the robot dead here: there is no process to signal.
        world.take_kills();
        world.observe(&mut obs);
        let commands: Vec<_> = agents
            .iter_mut()
            .zip(&obs)
            .map(|(a, o)| Some(a.step(o)))
            .collect();
        world.step(&commands);
        let events = world.drain_events();
        recorder.record(world.tick(), world.robots(), &events)?;
        progress(world.tick());
    }
    Ok((world.metrics(), interrupted))
}
