//! `--in-process`: the same world and agent cores, called directly in one process, in the
//! same order as the multi-process shells, so the records come out byte-identical.

use std::path::Path;

use swarmrt_agent::Agent;
use swarmrt_protocol::{Observation, RobotState};
use swarmrt_scenario::Config;
use swarmrt_world::records::Recorder;
use swarmrt_world::{ProcessSignal, World, WorldMetrics};

/// Runs the scenario to the end (or until `interrupt` fires, checked every tick), recording
/// into `dir`; `progress` gets each completed tick. Returns the metrics and whether it was
/// interrupted.
pub fn run(
    cfg: &Config,
    dir: &Path,
    interrupt: &crossbeam_channel::Receiver<()>,
    mut progress: impl FnMut(u64),
) -> anyhow::Result<(WorldMetrics, bool)> {
    let mut world = World::new(cfg, swarmrt_agent::registry::VOCABULARY)
        .map_err(|e| anyhow::anyhow!("{}: {}", e.key, e.message))?;
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
        // Kills and freezes only change the world's state here: there is no process to
        // signal. A restart starts the robot's brain afresh, as a new process would.
        for signal in world.take_signals() {
            if let ProcessSignal::Restart { robot, incarnation } = signal {
                agents[robot as usize] = Agent::fresh(cfg, robot, incarnation);
            }
        }
        world.observe(&mut obs);
        // Only robots whose process would run answer, as in the process shells.
        let commands: Vec<_> = agents
            .iter_mut()
            .zip(&obs)
            .map(|(a, o)| {
                RobotState::from_u8(o.state)
                    .is_some_and(RobotState::expects_command)
                    .then(|| a.step(o))
            })
            .collect();
        world.step(&commands);
        let events = world.drain_events();
        recorder.record(world.tick(), world.robots(), &events)?;
        progress(world.tick());
    }
    Ok((world.metrics(), interrupted))
}
