//! The one in-process lock-step loop: the world core and every robot's core, called in the
//! order the process shells call them, so both modes write byte-identical records.

use swarmrt_agent::Agent;
use swarmrt_agent::Step;
use swarmrt_agent::consensus::raft::{MutantScope, Persistent};
use swarmrt_protocol::control::ProcessFault;
use swarmrt_protocol::{Command, Observation, RobotState};
use swarmrt_scenario::Config;
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
        Ok::<(), std::convert::Infallible>(())
    });
    cmd
}

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
    /// Whether the robots answered the last observations already (in [`Lockstep::observe`]).
    answered: bool,
    /// Whether [`Lockstep::observe`] fills `obs` ([`Lockstep::keep_observations`]).
    keep_observations: bool,
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
            answered: false,
            keep_observations: false,
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

    /// Every robot's observation of the current tick, as the last [`Lockstep::observe`]
    /// filled it: only while [`Lockstep::keep_observations`] is on or the scenario has
    /// propagation rounds (otherwise the observations are not kept, and these are older).
    pub fn observations(&self) -> &[Observation] {
        &self.obs
    }

    /// Keeps every robot's observation for [`Lockstep::observations`] (off when built: the
    /// robots answer each observation as it is made, and only the propagation rounds read
    /// them again).
    pub fn keep_observations(&mut self, on: bool) {
        self.keep_observations = on;
    }

    /// The first phase of a tick: carry out the process faults due (there is no process to
    /// signal: a kill or freeze already changed the world's state; a restart starts the
    /// robot's brain afresh, as a new process would, from its stored state if it keeps one),
    /// then fill every observation.
    ///
    /// Each robot also answers its observation here, right after the world filled it and on
    /// the same thread ([`World::observe_then`]), while it is still in cache; the answers
    /// wait for [`Lockstep::think`]. A robot's answer reads only its own observation and
    /// state, which nothing changes between the two phases, so they are the commands
    /// `think` would compute, the same bytes whichever thread computed them.
    pub fn observe(&mut self) {
        for signal in self.world.take_signals() {
            if let ProcessSignal::Fault(ProcessFault::Restart { robot, incarnation }) = signal {
                let r = robot as usize;
                self.agents[r] = match self.stored[r].clone() {
                    Some(state) => Agent::restore(&self.cfg, robot, state, incarnation),
                    None => Agent::fresh(&self.cfg, robot, incarnation),
                };
            }
        }
        let n = self.agents.len();
        self.commands.clear();
        self.commands.resize(n, None);
        // The Raft mutant selection (tests) is carried onto the observing threads.
        let mutant = MutantScope::current();
        let mut robots: Vec<Answering<'_>> = self
            .agents
            .iter_mut()
            .zip(&mut self.stored)
            .zip(&mut self.commands)
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
        if self.keep_observations || self.world.has_rounds() {
            self.world
                .observe_then(&mut self.obs, &mut robots, threads, then);
        } else {
            self.world.observe_each(&mut robots, threads, then);
        }
        self.answered = true;
    }

    /// The second phase: every robot whose process would run answers its observation (and,
    /// with storage on, makes its persistent state durable first, as its process does).
    /// [`Lockstep::observe`] has already had them answer; this computes the answers only when
    /// it has not (from the observations last kept).
    pub fn think(&mut self) {
        if std::mem::take(&mut self.answered) {
            return;
        }
        let n = self.agents.len();
        self.commands.clear();
        self.commands.resize(n, None);
        for (((a, o), stored), cmd) in self
            .agents
            .iter_mut()
            .zip(&self.obs)
            .zip(&mut self.stored)
            .zip(&mut self.commands)
        {
            answer(a, o, stored, cmd);
        }
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
