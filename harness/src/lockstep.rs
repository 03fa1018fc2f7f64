//! The in-process lock-step: the world core and every robot's core in this process, driven by
//! the one lock-step tick the world process drives too ([`swarmrt_world::lockstep::tick`]),
//! with [`InProcess`] as its robots, so both modes write byte-identical records.

use std::convert::Infallible;

use swarmrt_agent::Agent;
use swarmrt_agent::Step;
use swarmrt_agent::consensus::raft::{MutantScope, Persistent};
use swarmrt_protocol::control::ProcessFault;
use swarmrt_protocol::{Command, Observation, RobotState, RoundInbox};
use swarmrt_scenario::Config;
use swarmrt_world::lockstep::{self, Robots};
use swarmrt_world::map::MapError;
use swarmrt_world::world::{PARALLEL_OBSERVE_MIN, worker_threads};
use swarmrt_world::{Event, ProcessSignal, World};

/// One robot's part of an answer: its core, its stable storage and its command slot.
type Answering<'a> = (
    &'a mut Agent,
    &'a mut Option<Persistent>,
    &'a mut Option<Command>,
);

/// Robot `o.robot` answers its observation, if its process would run: its command, and with
/// storage on, the change of persistent state its process would have written first.
fn answer(
    agent: &mut Agent,
    o: &Observation,
    stored: &mut Option<Persistent>,
    command: &mut Option<Command>,
) {
    if RobotState::from_u8(o.state).is_some_and(RobotState::expects_command) {
        *command = Some(store_then_send(agent.step(o), stored));
    }
}

/// The command of `step` once its change is applied to the robot's stored state (the first
/// change applies to the empty state), as its process would make it durable first.
fn store_then_send(step: Step, stored: &mut Option<Persistent>) -> Command {
    let Ok(cmd) = step.persist_then(|change| {
        stored.get_or_insert_default().apply(&change);
        Ok::<(), Infallible>(())
    });
    cmd
}

/// The robots of an in-process run: every robot's core, answering in this process.
pub struct InProcess {
    cfg: Config,
    agents: Vec<Agent>,
    obs: Vec<Observation>,
    /// Each robot's stable storage (`consensus.storage`): the persistent Raft state its
    /// process would have written before sending this tick's command.
    stored: Vec<Option<Persistent>>,
    /// Whether [`Robots::answer`] keeps the observations ([`Lockstep::keep_observations`]).
    keep_observations: bool,
}

impl Robots for InProcess {
    type Error = Infallible;

    /// There is no process to signal: a kill or freeze already changed the world's state; a
    /// restart starts the robot's brain afresh, as a new process would, from its stored
    /// state if it keeps one.
    fn carry_out(&mut self, _: &mut World, signals: Vec<ProcessSignal>) -> Result<(), Infallible> {
        for signal in signals {
            if let ProcessSignal::Fault(ProcessFault::Restart { robot, incarnation }) = signal {
                let r = robot as usize;
                self.agents[r] = match self.stored[r].clone() {
                    Some(state) => Agent::restore(&self.cfg, robot, state, incarnation),
                    None => Agent::fresh(&self.cfg, robot, incarnation),
                };
            }
        }
        Ok(())
    }

    /// Each robot answers its observation right after the world filled it and on the same
    /// thread ([`World::observe_each`]), while it is still in cache. A robot's answer reads
    /// only its own observation and state, so the commands are the same bytes whichever
    /// thread computed them.
    fn answer(
        &mut self,
        world: &mut World,
        commands: &mut Vec<Option<Command>>,
    ) -> Result<(), Infallible> {
        let n = self.agents.len();
        commands.clear();
        commands.resize(n, None);
        // The Raft mutant selection (tests) is carried onto the observing threads.
        let mutant = MutantScope::current();
        let mut robots: Vec<Answering<'_>> = self
            .agents
            .iter_mut()
            .zip(&mut self.stored)
            .zip(commands.iter_mut())
            .map(|((agent, stored), command)| (agent, stored, command))
            .collect();
        let threads = worker_threads(n, PARALLEL_OBSERVE_MIN);
        let then = |_: usize, o: &Observation, robot: &mut Answering<'_>| {
            mutant.enter();
            let (agent, stored, command) = robot;
            answer(agent, o, stored, command);
        };
        // The propagation rounds read the observations again (reactions); otherwise nothing
        // does, and each thread fills one of its own robot after robot.
        if self.keep_observations || world.has_rounds() {
            world.observe_then(&mut self.obs, &mut robots, threads, then);
        } else {
            world.observe_each(&mut robots, threads, then);
        }
        Ok(())
    }

    fn react(
        &mut self,
        _: &mut World,
        round: &[RoundInbox],
        reactions: &mut [Option<Command>],
    ) -> Result<(), Infallible> {
        for inbox in round {
            let r = inbox.robot as usize;
            reactions[r] = Some(self.agents[r].react(&self.obs[r], inbox.inbox()));
        }
        Ok(())
    }
}

/// A world and its robots' cores, stepped tick by tick.
pub struct Lockstep {
    world: World,
    robots: InProcess,
    commands: Vec<Option<Command>>,
}

impl Lockstep {
    /// The scenario at tick 0 (its `[behaviour]` resolved, e.g. by
    /// [`crate::config::load_run_config`]).
    pub fn new(cfg: &Config) -> Result<Lockstep, MapError> {
        let world = World::new(cfg, swarmrt_agent::registry::VOCABULARY)?;
        let n = cfg.robots.count as usize;
        Ok(Lockstep {
            world,
            robots: InProcess {
                cfg: cfg.clone(),
                agents: (0..n as u32).map(|id| Agent::new(cfg, id)).collect(),
                obs: vec![Observation::empty(0, 0); n],
                stored: vec![None; n],
                keep_observations: false,
            },
            commands: Vec::with_capacity(n),
        })
    }

    /// The world.
    pub fn world(&self) -> &World {
        &self.world
    }

    /// The world, for events and faults injected from outside.
    pub fn world_mut(&mut self) -> &mut World {
        &mut self.world
    }

    /// The robots' cores.
    pub fn agents(&self) -> &[Agent] {
        &self.robots.agents
    }

    /// Every robot's observation of the current tick, as the last tick filled it: only while
    /// [`Lockstep::keep_observations`] is on or the scenario has propagation rounds
    /// (otherwise the observations are not kept, and these are older).
    pub fn observations(&self) -> &[Observation] {
        &self.robots.obs
    }

    /// Keeps every robot's observation for [`Lockstep::observations`] (off when built: the
    /// robots answer each observation as it is made, and only the propagation rounds read
    /// them again).
    pub fn keep_observations(&mut self, on: bool) {
        self.robots.keep_observations = on;
    }

    /// One whole tick ([`lockstep::tick`]): faults, every robot's answer, the propagation
    /// rounds, the world's step.
    pub fn step(&mut self) {
        let Ok(_) = lockstep::tick(&mut self.world, &mut self.robots, &mut self.commands);
    }

    /// The first phases of [`Lockstep::step`] alone, for a benchmark that times them: the
    /// faults carried out and every robot's answer ([`Robots::answer`]).
    pub fn observe(&mut self) {
        let signals = self.world.take_signals();
        let Ok(()) = self.robots.carry_out(&mut self.world, signals);
        let Ok(()) = self.robots.answer(&mut self.world, &mut self.commands);
    }

    /// The propagation rounds of [`Lockstep::step`] alone (a no-op without rounds).
    pub fn propagate(&mut self) {
        let Ok(()) = lockstep::propagate(&mut self.world, &mut self.robots, &mut self.commands);
    }

    /// The last phase of [`Lockstep::step`] alone: the world steps with the answers.
    pub fn advance(&mut self) {
        self.world.step(&self.commands);
    }

    /// The events since the last call, in the order they happened.
    pub fn drain_events(&mut self) -> Vec<Event> {
        self.world.drain_events()
    }
}

/// Runs the scenario to the end (or until `stop` says so, asked every tick), recording
/// `trajectory.csv` and `events.jsonl` (and `radio.csv` with `scenario.record_radio`) into
/// `dir` as the world process does; `progress` gets each completed tick.
/// Returns the world's metrics and whether it was stopped early.
pub fn run_recorded(
    cfg: &Config,
    dir: &swarmrt_scenario::safe_fs::OutDir,
    mut stop: impl FnMut() -> bool,
    mut progress: impl FnMut(u64),
) -> std::io::Result<(swarmrt_world::WorldMetrics, bool)> {
    let mut run = Lockstep::new(cfg)
        .map_err(|e| std::io::Error::other(format!("key `{}`: {}", e.key, e.message)))?;
    let mut recorder = swarmrt_world::records::Recorder::for_run(dir, cfg)?;
    run.world.set_radio_recording(cfg.scenario.record_radio);
    let events = run.drain_events();
    recorder.record(run.world.tick(), run.world.robots(), &events)?;
    let mut stopped = false;
    while !run.world.finished() {
        if stop() {
            stopped = true;
            break;
        }
        run.step();
        let events = run.drain_events();
        let radio = run.world.take_radio_rows();
        recorder.record_tick(run.world.tick(), run.world.robots(), &events, &radio)?;
        progress(run.world.tick());
    }
    Ok((run.world.metrics(), stopped))
}
