//! The one in-process lock-step loop: the world core and every robot's core, called in the
//! order the process shells call them, so both modes write byte-identical records.

use swarmrt_agent::Agent;
use swarmrt_agent::consensus::raft::{MutantScope, Persistent};
use swarmrt_protocol::{Command, Observation, RobotState};
use swarmrt_scenario::Config;
use swarmrt_world::map::MapError;
use swarmrt_world::world::worker_threads;
use swarmrt_world::{Event, ProcessSignal, World};

/// Robots from which [`Lockstep::think`] splits them over threads: a robot thinks in ~1-2 us
/// (observing takes several times that), so below this a thread costs more than it saves.
pub const PARALLEL_THINK_MIN: usize = 256;

/// A world and its robots, stepped tick by tick.
pub struct Lockstep {
    cfg: Config,
    world: World,
    agents: Vec<Agent>,
    obs: Vec<Observation>,
    commands: Vec<Option<Command>>,
    /// Each robot's stable storage (`consensus.storage`): the persistent Raft state its
    /// process would have written before sending this tick's command.
    stored: Vec<Option<Persistent>>,
    storing: bool,
}

impl Lockstep {
    /// The scenario at tick 0 (its `[behaviour]` resolved, e.g. by
    /// [`crate::config::load_run_config`]).
    pub fn new(cfg: &Config) -> Result<Lockstep, MapError> {
        let world = World::new(cfg, swarmrt_agent::registry::VOCABULARY)?;
        let n = cfg.robots.count as usize;
        Ok(Lockstep {
            cfg: cfg.clone(),
            world,
            agents: (0..n as u32).map(|id| Agent::new(cfg, id)).collect(),
            obs: vec![Observation::empty(0, 0); n],
            commands: Vec::with_capacity(n),
            stored: vec![None; n],
            storing: swarmrt_agent::consensus::stores_state(cfg),
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
        &self.agents
    }

    /// The first phase of a tick: carry out the process faults due (there is no process to
    /// signal: a kill or freeze already changed the world's state; a restart starts the
    /// robot's brain afresh, as a new process would, from its stored state if it keeps one),
    /// then fill every observation.
    pub fn observe(&mut self) {
        for signal in self.world.take_signals() {
            if let ProcessSignal::Restart { robot, incarnation } = signal {
                let r = robot as usize;
                self.agents[r] = match self.stored[r].clone() {
                    Some(state) => Agent::restore(&self.cfg, robot, state, incarnation),
                    None => Agent::fresh(&self.cfg, robot, incarnation),
                };
            }
        }
        self.world.observe(&mut self.obs);
    }

    /// The second phase: every robot whose process would run answers its observation (and,
    /// with storage on, makes its persistent state durable first, as its process does).
    ///
    /// From [`PARALLEL_THINK_MIN`] robots on, the robots are split into contiguous ranges
    /// that think on scoped threads, as [`World::observe`] splits them: each robot's core reads
    /// only its own observation and state, so the commands are the same bytes in any split.
    pub fn think(&mut self) {
        let n = self.agents.len();
        self.commands.clear();
        self.commands.resize(n, None);
        let storing = self.storing;
        let threads = worker_threads(n, PARALLEL_THINK_MIN);
        let think = |agents: &mut [Agent],
                     obs: &[Observation],
                     stored: &mut [Option<Persistent>],
                     commands: &mut [Option<Command>]| {
            for (((a, o), stored), cmd) in agents.iter_mut().zip(obs).zip(stored).zip(commands) {
                if RobotState::from_u8(o.state).is_some_and(RobotState::expects_command) {
                    *cmd = Some(a.step(o));
                    if storing {
                        *stored = a.consensus().and_then(|c| c.persistent());
                    }
                }
            }
        };
        if threads <= 1 {
            think(
                &mut self.agents,
                &self.obs,
                &mut self.stored,
                &mut self.commands,
            );
            return;
        }
        let chunk = n.div_ceil(threads);
        let mutant = MutantScope::current();
        std::thread::scope(|s| {
            let mut parts = self
                .agents
                .chunks_mut(chunk)
                .zip(self.obs.chunks(chunk))
                .zip(self.stored.chunks_mut(chunk))
                .zip(self.commands.chunks_mut(chunk));
            let first = parts.next();
            for (((agents, obs), stored), commands) in parts {
                let think = &think;
                s.spawn(move || {
                    mutant.enter();
                    think(agents, obs, stored, commands)
                });
            }
            if let Some((((agents, obs), stored), commands)) = first {
                think(agents, obs, stored, commands);
            }
        });
    }

    /// The third phase (`radio.rounds` > 0 only): the tick's propagation rounds. Each round
    /// the world routes the frames sent within the tick, and every robot woken with some
    /// reacts, in ascending id as the world process applies them; a no-op without rounds.
    pub fn propagate(&mut self) {
        if !self.world.has_rounds() {
            return;
        }
        self.world.start_rounds(&self.commands);
        loop {
            let round = self.world.next_round();
            if round.is_empty() {
                return;
            }
            for inbox in &round {
                let r = inbox.robot as usize;
                let answer = self.agents[r].react(&self.obs[r], inbox.inbox());
                self.world
                    .react(inbox.robot, Some(&answer), &mut self.commands);
            }
        }
    }

    /// The last phase: the world steps with the answers.
    pub fn advance(&mut self) {
        self.world.step(&self.commands);
    }

    /// One whole tick: [`Lockstep::observe`], [`Lockstep::think`], [`Lockstep::propagate`],
    /// [`Lockstep::advance`].
    pub fn step(&mut self) {
        self.observe();
        self.think();
        self.propagate();
        self.advance();
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
    dir: &std::path::Path,
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
