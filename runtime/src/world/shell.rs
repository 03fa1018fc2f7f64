//! The world process shell: creates the run's services, waits for every robot's hello, then
//! runs the ticks ([`super::ticks`]), and at the end tells robots and hosts and reports the
//! records. It sleeps in an iceoryx2 listener while robots think; commands, the hosts'
//! messages and control lines from the orchestrator wake it.
//!
//! The world core is driven by the one lock-step tick ([`swarmrt_world::lockstep`]) with
//! [`Processes`], the robots as this shell reaches them. Its parts: [`super::answers`]
//! (whose answer a command is), [`super::ticks`] (the tick over processes: faults, publish,
//! rounds; the records), [`super::collect`] (waiting for the answers, in lock-step or by the
//! wall clock), [`super::realtime`] (the wall clock's state), [`super::remote`] (the hosts of
//! a `--hosts` run), [`super::control`] (the orchestrator's lines), [`super::stats`] (what
//! only the shell knows).

use std::time::{Duration, Instant};

use crossbeam_channel::Receiver;
use iceoryx2::prelude::*;
use swarmrt_hosts::HostsFile;
use swarmrt_ipc::{self as ipc, IpcError};
use swarmrt_protocol::Observation;
use swarmrt_protocol::control::{Control, WorldReport};
use swarmrt_protocol::services::RunServices;
use swarmrt_scenario::Config;
use swarmrt_world::World;
use swarmrt_world::records::RecordWriter;

use super::answers::{self, Answers, Hellos};
use super::control::{drain_control, report, spawn_control_thread, wait};
use super::mode::{Mode, refuse_combination};
use super::realtime::Realtime;
use super::remote::Remote;
use super::stats::ShellStats;
use super::timing::{Stamps, TickTimer};
use crate::supervisor::hello::Bindings;

/// Longest the world waits for all robots to say hello.
const STARTUP_TIMEOUT: Duration = Duration::from_secs(120);

/// Runs the world of `run` with `cfg`, writing records into `out_dir`. With `hosts`, the
/// robots it names run on other hosts and are reached over Zenoh; `layout` is what their
/// hosts must present to join.
pub fn run(
    run: &RunServices,
    cfg: &Config,
    out_dir: &swarmrt_scenario::safe_fs::OutDir,
    vocabulary: swarmrt_protocol::Vocabulary,
    hosts: Option<(&HostsFile, u32)>,
    mode: Mode,
) -> Result<(), IpcError> {
    refuse_combination(cfg, mode, hosts.is_some())?;
    let n = cfg.robots.count as usize;
    let mut world = World::new(cfg, vocabulary).map_err(|e| format!("{}: {}", e.key, e.message))?;
    let mut recorder = RecordWriter::for_run(out_dir, cfg)?;
    world.set_radio_recording(cfg.scenario.record_radio);
    warn_on_fd_limit(n);
    let node = ipc::node(run, &run.world_node_name())?;
    let mut robots = Processes::open(run, cfg, &node, hosts, mode)?;
    report(&WorldReport::Listening);
    // Phase 1: every robot says hello (or dies) before tick 0.
    let started = Instant::now();
    robots.await_hellos(&mut world, started)?;
    report(&WorldReport::Ready {
        startup_ms: started.elapsed().as_millis() as u64,
    });
    // Phase 2: ticks, then the end.
    robots.run_ticks(&mut world, &mut recorder)?;
    robots.finish(&mut world, recorder)
}

/// The robots that count their answers on the bell ([`ipc::bell::Bell::answered`]): this
/// host's built-in robots, in lock-step without rounds. Robots in other languages notify
/// every answer, so they are left out of the target; so is everyone in real time and with
/// rounds, where the world takes answers as they come.
fn counting_robots(
    cfg: &Config,
    n: usize,
    hosts: Option<&HostsFile>,
    mode: Mode,
) -> Option<Vec<bool>> {
    if mode == Mode::Realtime || cfg.radio.rounds > 0 {
        return None;
    }
    Some(
        (0..n as u32)
            .map(|r| {
                swarmrt_scenario::program::program_of(cfg, r).is_none()
                    && hosts.is_none_or(|f| f.host_of(r).is_none())
            })
            .collect(),
    )
}

fn warn_on_fd_limit(n: usize) {
    match ipc::raise_fd_limit() {
        Ok(limit) if limit < 8 * n as u64 + 64 => {
            tracing::warn!(
                limit,
                robots = n,
                "open-file limit may be too low for this many robots"
            )
        }
        Ok(_) => {}
        Err(e) => tracing::warn!("cannot raise the open-file limit: {e}"),
    }
}

/// The robots as the world process reaches them: processes of this host over shared memory,
/// and remote hosts' robots behind their link; with everything the ticks need to wait for
/// their answers.
pub(super) struct Processes<'a> {
    pub(super) node: &'a Node<ipc::Svc>,
    pub(super) ports: ipc::WorldPorts,
    /// The propagation rounds' ports (`radio.rounds` > 0).
    pub(super) rounds: Option<ipc::rounds::WorldRounds>,
    /// Control lines from the orchestrator.
    pub(super) control: Receiver<Control>,
    /// The remote hosts (`--hosts` runs).
    pub(super) remote: Option<Remote>,
    /// Who speaks for which robot, and who waits for a hello.
    pub(super) hellos: Hellos,
    /// Robots of a remote host: no local publisher may claim one.
    pub(super) remote_robot: Vec<bool>,
    /// The current tick's answers, and whom the tick still waits for.
    pub(super) answers: Answers,
    pub(super) stats: ShellStats,
    /// A Stop, a closed stdin or a termination signal: finish the records and stop.
    pub(super) interrupted: bool,
    /// `scenario.unresponsive_ms`: a robot silent this long is given up.
    pub(super) unresponsive: Duration,
    /// Per robot, whether it counts its answers on the bell (None: nobody does).
    pub(super) counting: Option<Vec<bool>>,
    /// `scenario.deadline_ms`: an answer later than this is counted late.
    pub(super) deadline: Duration,
    /// The wall clock of a `--realtime` run.
    pub(super) realtime: Option<Realtime>,
    /// The tick's observations, one slot per robot.
    pub(super) obs: Vec<Observation>,
    pub(super) stamps: Stamps,
    pub(super) timer: TickTimer,
}

impl<'a> Processes<'a> {
    /// Creates the run's services and opens the world's ports, the rounds', the control
    /// thread and the hosts' link.
    fn open(
        run: &RunServices,
        cfg: &Config,
        node: &'a Node<ipc::Svc>,
        hosts: Option<(&HostsFile, u32)>,
        mode: Mode,
    ) -> Result<Processes<'a>, IpcError> {
        let n = cfg.robots.count as usize;
        let observers = cfg.ipc.observers as usize;
        let restarts = cfg.faults.restart.len();
        let services = ipc::create_services(node, run, 0..n as u32, restarts, observers)?;
        let ports = ipc::WorldPorts::open(&services, n, observers)?;
        let rounds = if cfg.radio.rounds > 0 {
            let subscribers = 8 + restarts + observers;
            Some(ipc::rounds::WorldRounds::create(node, run, n, subscribers)?)
        } else {
            None
        };
        let control = spawn_control_thread(run)?;
        let remote = match hosts {
            Some((file, layout)) => Some(Remote::open(run, file, layout)?),
            None => None,
        };
        Ok(Processes {
            node,
            ports,
            rounds,
            control,
            remote,
            hellos: Bindings::awaiting(0..n as u32),
            remote_robot: (0..n as u32)
                .map(|r| hosts.is_some_and(|(f, _)| f.host_of(r).is_some()))
                .collect(),
            answers: Answers {
                commands: vec![None; n],
                ..Answers::default()
            },
            stats: ShellStats::default(),
            interrupted: false,
            unresponsive: Duration::from_millis(cfg.scenario.unresponsive_ms),
            counting: counting_robots(cfg, n, hosts.map(|(f, _)| f), mode),
            deadline: Duration::from_millis(cfg.scenario.deadline_ms),
            realtime: (mode == Mode::Realtime).then(|| Realtime::new(n, cfg.scenario.dt)),
            obs: vec![Observation::empty(0, 0); n],
            stamps: Stamps::default(),
            timer: TickTimer::default(),
        })
    }

    /// Takes everything that arrived: local command samples, the hosts' messages and the
    /// orchestrator's control lines.
    pub(super) fn gather(&mut self, world: &mut World) -> Result<(), IpcError> {
        answers::receive(
            &self.ports.commands,
            &self.remote_robot,
            &mut self.hellos,
            &mut self.answers,
            &mut self.stats,
        )?;
        if let Some(r) = self.remote.as_mut() {
            r.drain(world, &mut self.hellos, &mut self.answers, &mut self.stats)?;
        }
        self.interrupted |= drain_control(
            &self.control,
            self.node,
            world,
            &mut self.hellos,
            &mut self.answers.pending,
        )?;
        Ok(())
    }

    /// Sleeps until a robot, a host or the control thread wakes the world, or `timeout`
    /// (or sooner, when a resend held back must be asked for).
    pub(super) fn sleep(&mut self, timeout: Duration) -> Result<(), IpcError> {
        let timeout = match self.remote.as_ref().and_then(Remote::next_look) {
            Some(at) => timeout.min(at.saturating_duration_since(Instant::now())),
            None => timeout,
        };
        self.interrupted |= wait(&self.ports.listener, self.node, timeout)?;
        Ok(())
    }

    /// Phase 1: waits until every robot said hello (or died), for [`STARTUP_TIMEOUT`].
    fn await_hellos(&mut self, world: &mut World, started: Instant) -> Result<(), IpcError> {
        while !self.hellos.awaiting_set().is_empty() && !self.interrupted {
            self.gather(world)?;
            if self.hellos.awaiting_set().is_empty() || self.interrupted {
                break;
            }
            if started.elapsed() > STARTUP_TIMEOUT {
                let waiting = self.hellos.awaiting_set();
                return Err(format!(
                    "{} robots never said hello, e.g. robot {}",
                    waiting.len(),
                    waiting.first().copied().unwrap_or(0)
                )
                .into());
            }
            self.sleep(Duration::from_millis(500))?;
        }
        Ok(())
    }

    /// Tells robots and hosts the run is over, closes the records and reports them.
    fn finish(mut self, world: &mut World, mut recorder: RecordWriter) -> Result<(), IpcError> {
        let tick = world.tick();
        self.ports.publish_shutdown(tick)?;
        if let Some(r) = self.remote.take() {
            r.finish(tick, &mut self.stats);
        }
        // Deaths marked after the last recorded tick: events only, the tick's rows exist.
        recorder.record_events(world.drain_events())?;
        recorder.finish()?;
        let mut metrics = serde_json::to_value(world.metrics())?;
        metrics["shell"] = serde_json::to_value(&self.stats)?;
        report(&WorldReport::Tick { tick });
        report(&WorldReport::Done {
            interrupted: self.interrupted,
            metrics,
        });
        Ok(())
    }
}
