//! The world process shell: creates the run's services, waits for every robot's hello, then
//! runs lock-step ticks. It sleeps in an iceoryx2 listener while robots think; commands,
//! and control lines from the orchestrator (relayed by a small thread), wake it.

use std::collections::{BTreeMap, BTreeSet};
use std::io::{BufRead, Write};
use std::path::Path;
use std::time::{Duration, Instant};

use crossbeam_channel::{Receiver, TryRecvError};
use iceoryx2::identifiers::UniquePublisherId;
use iceoryx2::port::listener::{Listener, ListenerWaitError};
use iceoryx2::port::subscriber::Subscriber;
use iceoryx2::prelude::*;
use swarmrt_hosts::HostsFile;
use swarmrt_hosts::wire::{Down, Up, encode_tick};
use swarmrt_hosts::world_side::{Heard, HostTraffic, WorldLink};
use swarmrt_ipc::{self as ipc, IpcError};
use swarmrt_protocol::control::{Control, WorldReport};
use swarmrt_protocol::services::RunServices;
use swarmrt_protocol::{
    Command, CommandKind, Observation, ObservationHeader, PROTOCOL_VERSION, RobotState,
};
use swarmrt_scenario::Config;

use super::timing::{TickPhases, TickTimer, TickTiming};
use swarmrt_world::records::RecordWriter;
use swarmrt_world::{ProcessSignal, World};

/// Longest the world waits for all robots to say hello.
const STARTUP_TIMEOUT: Duration = Duration::from_secs(120);
/// Minimum interval between progress reports on stdout.
const PROGRESS_EVERY: Duration = Duration::from_millis(200);
/// The first ticks are each reported at once, so the orchestrator knows exactly when every
/// process is up and the observation samples have all been used once (`swarm bench swarm`
/// reads memory then).
pub const EARLY_REPORTS: u64 = 32;

/// Numbers only the shell knows (wall-clock dependent, so kept out of the replayable records).
#[derive(Debug, Default, serde::Serialize)]
pub struct ShellStats {
    /// Robot-ticks in which a robot answered after `scenario.deadline_ms`.
    pub late: u64,
    /// Samples from publishers that never said hello as a robot of this run.
    pub unknown_sender: u64,
    /// Extra samples from a robot that had already answered the current tick.
    pub extra_commands: u64,
    /// Hellos that claimed an id already taken, or came from an already bound publisher.
    pub bad_hello: u64,
    /// Wall-clock cost of the ticks and where it went.
    pub timing: TickTiming,
    /// Traffic with each remote host (`--hosts` runs only).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub link: Vec<HostTraffic>,
    /// How the wall clock went (`--realtime` runs only).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub realtime: Option<RealtimeStats>,
}

/// How the world paces its ticks.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Mode {
    /// Each tick waits for every live robot's answer (or its deadline): replayable.
    LockStep,
    /// One tick every `scenario.dt` of wall-clock time, with whatever commands arrived
    /// (DESIGN section 2): for slow foreign controllers and hardware in the loop.
    Realtime,
}

/// What happened against the wall clock in a real-time run (`shell.realtime`).
#[derive(Debug, Default, serde::Serialize)]
pub struct RealtimeStats {
    /// The tick period, `scenario.dt` in milliseconds.
    pub period_ms: f64,
    /// Robot-ticks in which a robot sent nothing new and kept its last command (or stood
    /// still, having sent none yet).
    pub missed: u64,
    /// The robots that missed ticks, with how many.
    pub missed_by_robot: BTreeMap<u32, u64>,
    /// Commands that arrived answering an earlier tick than the current one (applied as the
    /// robot's latest).
    pub stale: u64,
    /// Ticks whose own work (sensing, stepping, recording) overran the period; the clock
    /// then restarts from the late tick rather than rushing to catch up.
    pub overruns: u64,
}

/// Real-time mode's memory of each robot's latest command.
struct Standing {
    last: Vec<Option<Command>>,
    /// True once `last` has been applied: its frames and notes went out, later ticks reuse
    /// only its motion.
    applied: Vec<bool>,
    /// Whether a command arrived in the current tick's window.
    fresh: Vec<bool>,
    /// When each robot's process last sent anything.
    heard_at: Vec<Instant>,
}

impl Standing {
    fn new(n: usize) -> Standing {
        Standing {
            last: vec![None; n],
            applied: vec![false; n],
            fresh: vec![false; n],
            heard_at: vec![Instant::now(); n],
        }
    }

    /// Forgets robot `r`'s command (killed, frozen or restarted: it must not move on it).
    fn forget(&mut self, r: u32) {
        self.last[r as usize] = None;
        self.heard_at[r as usize] = Instant::now();
    }

    /// The command robot `r` acts on at `tick`: its latest, with motion only when it was
    /// applied before. A command naming a later tick is left as is, for the world to refuse.
    fn command(&mut self, r: u32, tick: u64, stats: &mut RealtimeStats) -> Option<Command> {
        let i = r as usize;
        if !std::mem::take(&mut self.fresh[i]) {
            stats.missed += 1;
            *stats.missed_by_robot.entry(r).or_default() += 1;
        }
        let mut c = self.last[i]?;
        if c.tick <= tick {
            c.tick = tick;
        }
        if std::mem::replace(&mut self.applied[i], true) {
            c.outbox_len = 0;
            c.report_len = 0;
        }
        Some(c)
    }
}

/// How long the world waits at the end for every host to say its robots are gone, before it
/// closes its session anyway.
const BYE_TIMEOUT: Duration = Duration::from_secs(8);

/// The remote hosts of a `--hosts` run, as the world's shell sees them.
struct Remote {
    link: WorldLink,
    heard: Receiver<Heard>,
    /// What a host must present to join: [`swarmrt_hosts::link::layout`] of the config.
    layout: u32,
    names: Vec<String>,
    joined: Vec<bool>,
    lost: Vec<bool>,
    /// Remote robots whose current process said hello (bound by their host).
    bound: BTreeSet<u32>,
    byes: usize,
}

impl Remote {
    fn open(run: &RunServices, hosts: &HostsFile, layout: u32) -> Result<Remote, IpcError> {
        let (link, heard) = WorldLink::open(hosts, run.run_id())?;
        let heard = ipc::wake_relay(run, format!("{}-link", run.world_node_name()), heard)?;
        let n = hosts.hosts.len();
        Ok(Remote {
            link,
            heard,
            layout,
            names: hosts.hosts.iter().map(|h| h.name.clone()).collect(),
            joined: vec![false; n],
            lost: vec![false; n],
            bound: BTreeSet::new(),
            byes: 0,
        })
    }

    /// Sends each live host its slots of this tick and which of its robots the world waits for.
    fn send_tick(
        &mut self,
        tick: u64,
        obs: &[Observation],
        waiting: &BTreeSet<u32>,
    ) -> Result<(), IpcError> {
        for i in 0..self.link.len() {
            if self.lost[i] {
                continue;
            }
            let r = self.link.robots(i);
            let expect: Vec<u32> = waiting.range(r.clone()).copied().collect();
            let bytes = encode_tick(tick, &expect, &obs[r.start as usize..r.end as usize]);
            self.link.send_bytes(i, bytes)?;
        }
        Ok(())
    }

    /// Applies what the hosts said. `hello_phase` is true before tick 0, when `waiting` holds
    /// the robots that have not said hello; afterwards it holds those the tick waits for.
    #[allow(clippy::too_many_arguments)]
    fn drain(
        &mut self,
        world: &mut World,
        hello_phase: bool,
        waiting: &mut BTreeSet<u32>,
        reborn: &mut BTreeSet<u32>,
        commands: &mut [Option<Command>],
        stats: &mut ShellStats,
    ) -> Result<(), IpcError> {
        while let Ok(h) = self.heard.try_recv() {
            match h {
                Heard::Malformed { host } => self.link.count_up(host, 0, true),
                Heard::Lost { host } => self.lose(host, world, waiting),
                Heard::Up { host, msg, bytes } => {
                    self.link.count_up(host, bytes, false);
                    match msg {
                        Up::Join { host: name, layout } => {
                            if layout != self.layout || name != self.names[host] {
                                let why = format!(
                                    "host {:?} runs another swarmrt build or config (layout {layout:08x}, the world's {:08x})",
                                    self.names[host], self.layout
                                );
                                self.link.send(host, &Down::Refuse(why.clone()))?;
                                return Err(why.into());
                            }
                            self.joined[host] = true;
                            self.link.send(host, &Down::Welcome)?;
                        }
                        Up::Bye => self.byes += 1,
                        Up::Commands(entries) => {
                            let range = self.link.robots(host);
                            for (robot, c) in entries {
                                if !range.contains(&robot) {
                                    stats.unknown_sender += 1;
                                    continue;
                                }
                                let hello = c.version == PROTOCOL_VERSION
                                    && CommandKind::from_u32(c.kind) == Some(CommandKind::Hello);
                                if !self.bound.contains(&robot) {
                                    let expected = if hello_phase {
                                        waiting.remove(&robot)
                                    } else {
                                        reborn.remove(&robot)
                                    };
                                    if hello && expected {
                                        self.bound.insert(robot);
                                    } else if hello {
                                        stats.bad_hello += 1;
                                    } else {
                                        stats.unknown_sender += 1;
                                    }
                                } else if !hello_phase && waiting.remove(&robot) {
                                    commands[robot as usize] = Some(c);
                                } else {
                                    stats.extra_commands += 1;
                                }
                            }
                        }
                    }
                }
            }
        }
        Ok(())
    }

    /// A host's session is gone: its robots are dead from this tick.
    fn lose(&mut self, host: usize, world: &mut World, waiting: &mut BTreeSet<u32>) {
        if self.lost[host] {
            return;
        }
        self.lost[host] = true;
        let mut robots = Vec::new();
        for r in self.link.robots(host) {
            self.bound.remove(&r);
            waiting.remove(&r);
            if world.robots()[r as usize].state != RobotState::Dead {
                world.mark_dead(r, &format!("host {} lost", self.names[host]));
                robots.push(r);
            }
        }
        tracing::warn!(host = %self.names[host], ?robots, "host lost; its robots are dead");
        report(&WorldReport::HostLost {
            host: self.names[host].clone(),
            robots,
        });
    }

    /// Tells every live host the run is over and waits (bounded) until each has seen its
    /// robots out, so the shutdown is delivered before the session closes.
    fn finish(mut self, tick: u64, stats: &mut ShellStats) {
        let mut expected = 0;
        for i in 0..self.link.len() {
            if !self.lost[i] && self.link.send(i, &Down::Shutdown { tick }).is_ok() {
                expected += usize::from(self.joined[i]);
            }
        }
        let until = Instant::now() + BYE_TIMEOUT;
        while self.byes < expected {
            match self.heard.recv_deadline(until) {
                Ok(Heard::Up { host, msg, bytes }) => {
                    self.link.count_up(host, bytes, false);
                    if msg == Up::Bye {
                        self.byes += 1;
                    }
                }
                Ok(Heard::Lost { host }) if !self.lost[host] => {
                    self.lost[host] = true;
                    expected -= usize::from(self.joined[host]);
                }
                Ok(_) => {}
                Err(_) => break,
            }
        }
        stats.link = self.link.traffic().to_vec();
        self.link.close();
    }
}

/// Sleeps until the command event fires or `timeout` passes. A termination signal arriving
/// during the wait is a request to stop (`Ok(true)`), not a failure; any other interruption
/// (the EINTR Linux returns after SIGSTOP and SIGCONT) is a spurious wake.
fn wait(
    listener: &Listener<ipc::Svc>,
    node: &Node<ipc::Svc>,
    timeout: Duration,
) -> Result<bool, IpcError> {
    match listener.timed_wait(|_| {}, timeout) {
        Ok(_) | Err(ListenerWaitError::InterruptSignal) => Ok(ipc::termination_requested(node)),
        Err(e) => Err(e.into()),
    }
}

fn report(r: &WorldReport) {
    let mut out = std::io::stdout().lock();
    // If the orchestrator is gone there is nobody to tell; the run still finishes its records.
    let _ = out.write_all(r.to_line().as_bytes());
    let _ = out.flush();
}

/// Relays control lines from stdin to the main loop and wakes it through the command event.
fn spawn_control_thread(run: &RunServices) -> Result<Receiver<Control>, IpcError> {
    let (tx, rx) = crossbeam_channel::unbounded();
    std::thread::spawn(move || {
        for line in std::io::stdin().lock().lines() {
            let Ok(line) = line else { break };
            match serde_json::from_str::<Control>(&line) {
                Ok(c) => {
                    if tx.send(c).is_err() {
                        return;
                    }
                }
                Err(e) => tracing::warn!("ignoring control line {line:?}: {e}"),
            }
        }
        // EOF: the orchestrator is gone; finish the records and stop.
        let _ = tx.send(Control::Stop);
    });
    ipc::wake_relay(run, format!("{}-control", run.world_node_name()), rx)
}

/// Runs the world of `run` with `cfg`, writing records into `out_dir`. With `hosts`, the
/// robots it names run on other hosts and are reached over Zenoh; `layout` is what their
/// hosts must present to join.
pub fn run(
    run: &RunServices,
    cfg: &Config,
    out_dir: &Path,
    vocabulary: swarmrt_protocol::Vocabulary,
    hosts: Option<(&HostsFile, u32)>,
    mode: Mode,
) -> Result<(), IpcError> {
    let n = cfg.robots.count as usize;
    let realtime = mode == Mode::Realtime;
    let mut world = World::new(cfg, vocabulary).map_err(|e| format!("{}: {}", e.key, e.message))?;
    let mut recorder = RecordWriter::for_run(out_dir, cfg)?;
    world.set_radio_recording(cfg.scenario.record_radio);

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
    let node = ipc::node(run, &run.world_node_name())?;
    let observers = cfg.ipc.observers as usize;
    let services = ipc::create_services(&node, run, n, cfg.faults.restart.len(), observers)?;
    let ipc::WorldPorts {
        publisher,
        notifier: obs_notifier,
        commands: subscriber,
        listener,
    } = ipc::WorldPorts::open(
        &services.observations,
        &services.observations_event,
        &services.commands,
        &services.commands_event,
        n,
        observers,
    )?;
    let control = spawn_control_thread(run)?;
    let mut remote = match hosts {
        Some((file, layout)) => Some(Remote::open(run, file, layout)?),
        None => None,
    };
    report(&WorldReport::Listening);

    let mut stats = ShellStats::default();
    let started = Instant::now();
    let mut interrupted = false;

    // Phase 1: every robot says hello (or dies) before tick 0.
    // Each robot is bound to the publisher its hello came from: later samples are
    // attributed by origin, never by the id a robot writes into them.
    let mut robot_of: BTreeMap<UniquePublisherId, u32> = BTreeMap::new();
    let mut waiting: BTreeSet<u32> = (0..n as u32).collect();
    while !waiting.is_empty() && !interrupted {
        while let Some(sample) = subscriber.receive()? {
            let origin = sample.origin();
            let c = *sample.payload();
            let hello = c.version == PROTOCOL_VERSION
                && CommandKind::from_u32(c.kind) == Some(CommandKind::Hello);
            if hello && !robot_of.contains_key(&origin) && waiting.remove(&c.robot) {
                robot_of.insert(origin, c.robot);
                tracing::debug!(robot = c.robot, pid = c.pid, "robot ready");
            } else {
                stats.bad_hello += 1;
                tracing::warn!(
                    robot = c.robot,
                    "ignoring a hello that is malformed or claims a taken id"
                );
            }
        }
        if let Some(r) = remote.as_mut() {
            r.drain(
                &mut world,
                true,
                &mut waiting,
                &mut BTreeSet::new(),
                &mut [],
                &mut stats,
            )?;
        }
        interrupted |= drain_control(&control, &node, &mut world, &mut waiting)?;
        if waiting.is_empty() || interrupted {
            break;
        }
        if started.elapsed() > STARTUP_TIMEOUT {
            return Err(format!(
                "{} robots never said hello, e.g. robot {}",
                waiting.len(),
                waiting.first().copied().unwrap_or(0)
            )
            .into());
        }
        interrupted |= wait(&listener, &node, Duration::from_millis(500))?;
    }
    report(&WorldReport::Ready {
        startup_ms: started.elapsed().as_millis() as u64,
    });

    // Phase 2: lock-step ticks.
    let deadline = Duration::from_millis(cfg.scenario.deadline_ms);
    let unresponsive = Duration::from_millis(cfg.scenario.unresponsive_ms);
    let mut obs = vec![Observation::empty(0, 0); n];
    let mut commands: Vec<Option<Command>> = vec![None; n];
    let mut last_progress = Instant::now();
    let mut timer = TickTimer::default();
    // The world times its stages too (wall clock, for `shell.timing` only).
    world.set_stage_timing(true);
    // Robots restarted by the schedule whose fresh process has not said hello yet.
    let mut reborn: BTreeSet<u32> = BTreeSet::new();
    let events = world.drain_events();
    recorder.record(world.tick(), world.robots(), events)?;
    let period = Duration::from_secs_f64(cfg.scenario.dt);
    let mut standing = Standing::new(n);
    let mut rt_stats = RealtimeStats {
        period_ms: period.as_secs_f64() * 1e3,
        ..RealtimeStats::default()
    };
    let mut tick_ends = Instant::now() + period;
    while !interrupted && !world.finished() {
        let mut rejoining: BTreeSet<u32> = BTreeSet::new();
        for signal in world.take_signals() {
            match signal {
                ProcessSignal::Kill(robot) => {
                    standing.forget(robot);
                    robot_of.retain(|_, r| *r != robot);
                    if let Some(r) = remote.as_mut() {
                        r.bound.remove(&robot);
                    }
                    reborn.remove(&robot);
                    report(&WorldReport::Kill { robot });
                }
                ProcessSignal::Freeze(robot) => {
                    standing.forget(robot);
                    report(&WorldReport::Freeze { robot })
                }
                ProcessSignal::Thaw(robot) => {
                    // Its silence while frozen was ordered, not a hang.
                    standing.forget(robot);
                    report(&WorldReport::Thaw { robot })
                }
                ProcessSignal::Restart { robot, incarnation } => {
                    // Samples from the old process are no robot's answer any more.
                    standing.forget(robot);
                    robot_of.retain(|_, r| *r != robot);
                    if let Some(r) = remote.as_mut() {
                        r.bound.remove(&robot);
                    }
                    reborn.insert(robot);
                    report(&WorldReport::Restart { robot, incarnation });
                }
                ProcessSignal::Rejoin(robot) => {
                    rejoining.insert(robot);
                }
            }
        }
        let tick = world.tick();
        // A rejoining robot's fresh process must be bound before its first observation.
        let hello_since = Instant::now();
        while !rejoining.is_empty() {
            let mut none = BTreeSet::new();
            receive(
                &subscriber,
                &mut robot_of,
                &mut reborn,
                &mut none,
                &mut commands,
                &mut stats,
            )?;
            if let Some(r) = remote.as_mut() {
                r.drain(
                    &mut world,
                    false,
                    &mut none,
                    &mut reborn,
                    &mut commands,
                    &mut stats,
                )?;
            }
            interrupted |= drain_control(&control, &node, &mut world, &mut none)?;
            rejoining.retain(|r| {
                reborn.contains(r) && world.robots()[*r as usize].state != RobotState::Dead
            });
            if rejoining.is_empty() || interrupted {
                break;
            }
            if hello_since.elapsed() >= unresponsive {
                for &robot in &rejoining {
                    give_up(
                        &mut world,
                        robot,
                        hello_since.elapsed(),
                        "never said hello after its restart",
                    );
                    reborn.remove(&robot);
                }
                break;
            }
            interrupted |= wait(
                &listener,
                &node,
                unresponsive.saturating_sub(hello_since.elapsed()),
            )?;
        }
        if interrupted {
            break;
        }

        let t0 = Instant::now();
        world.observe(&mut obs);
        let t1 = Instant::now();
        commands.iter_mut().for_each(|c| *c = None);
        let mut waiting: BTreeSet<u32> = world
            .robots()
            .iter()
            .filter(|r| r.state.expects_command())
            .map(|r| r.id)
            .collect();
        let sample = publisher.loan_slice_uninit(n)?;
        let mut sample = sample.write_from_slice(&obs);
        *sample.user_header_mut() = ObservationHeader {
            version: PROTOCOL_VERSION,
            shutdown: 0,
            tick,
        };
        sample.send()?;
        obs_notifier.notify()?;
        if let Some(r) = remote.as_mut() {
            r.send_tick(tick, &obs, &waiting)?;
        }
        let t2 = Instant::now();

        let sent_at = Instant::now();
        let mut late_logged = false;
        if realtime {
            interrupted |= collect_realtime(
                &subscriber,
                &listener,
                &node,
                &control,
                &mut world,
                &mut robot_of,
                &mut reborn,
                &mut standing,
                tick_ends,
                unresponsive,
                &mut stats,
                &mut rt_stats,
            )?;
            for robot in std::mem::take(&mut waiting) {
                if world.robots()[robot as usize].state.expects_command() {
                    commands[robot as usize] = standing.command(robot, tick, &mut rt_stats);
                }
            }
        }
        loop {
            if realtime {
                break;
            }
            receive(
                &subscriber,
                &mut robot_of,
                &mut reborn,
                &mut waiting,
                &mut commands,
                &mut stats,
            )?;
            if let Some(r) = remote.as_mut() {
                r.drain(
                    &mut world,
                    false,
                    &mut waiting,
                    &mut reborn,
                    &mut commands,
                    &mut stats,
                )?;
            }
            interrupted |= drain_control(&control, &node, &mut world, &mut waiting)?;
            if waiting.is_empty() || interrupted {
                break;
            }
            let waited = sent_at.elapsed();
            if waited >= unresponsive {
                for robot in std::mem::take(&mut waiting) {
                    robot_of.retain(|_, r| *r != robot);
                    if let Some(r) = remote.as_mut() {
                        r.bound.remove(&robot);
                    }
                    give_up(&mut world, robot, waited, "no answer");
                }
                break;
            }
            let timeout = if waited < deadline {
                deadline - waited
            } else {
                if !late_logged {
                    late_logged = true;
                    stats.late += waiting.len() as u64;
                    tracing::warn!(tick, late = ?waiting, "robots past the deadline");
                }
                unresponsive - waited
            };
            interrupted |= wait(&listener, &node, timeout)?;
        }
        if interrupted {
            break;
        }
        let t3 = Instant::now();
        world.step(&commands);
        let events = world.drain_events();
        let radio = world.take_radio_rows();
        let t4 = Instant::now();
        recorder.record_tick(world.tick(), world.robots(), events, radio)?;
        let t5 = Instant::now();
        let ns = |a: Instant, b: Instant| (b - a).as_nanos() as u64;
        timer.add(TickPhases {
            observe: ns(t0, t1),
            publish: ns(t1, t2),
            wait: ns(t2, t3),
            step: ns(t3, t4),
            record: ns(t4, t5),
            stages: world.take_stage_times(),
        });
        if world.tick() <= EARLY_REPORTS || last_progress.elapsed() >= PROGRESS_EVERY {
            last_progress = Instant::now();
            report(&WorldReport::Tick { tick: world.tick() });
        }
        tick_ends += period;
        if realtime && Instant::now() > tick_ends {
            rt_stats.overruns += 1;
            tick_ends = Instant::now() + period;
        }
    }
    if realtime {
        stats.realtime = Some(rt_stats);
    }

    // Tell robots the run is over (a header-only sample), then report.
    let sample = publisher.loan_slice_uninit(0)?;
    let mut sample = sample.write_from_slice(&[]);
    *sample.user_header_mut() = ObservationHeader {
        version: PROTOCOL_VERSION,
        shutdown: 1,
        tick: world.tick(),
    };
    sample.send()?;
    obs_notifier.notify()?;
    if let Some(r) = remote.take() {
        r.finish(world.tick(), &mut stats);
    }
    // Deaths marked after the last recorded tick: events only, the tick's rows exist.
    recorder.record_events(world.drain_events())?;
    recorder.finish()?;
    stats.timing = timer.summary();
    let mut metrics = serde_json::to_value(world.metrics())?;
    metrics["shell"] = serde_json::to_value(&stats)?;
    report(&WorldReport::Tick { tick: world.tick() });
    report(&WorldReport::Done {
        interrupted,
        metrics,
    });
    Ok(())
}

/// Receives every queued command sample. The first sample a bound robot sends after the
/// observation is its answer, whatever it says: World::validate refuses a wrong tick, kind, id
/// or version, and the robot stands still this tick instead of the world waiting forever. A
/// hello from a new publisher binds it to a restarted robot awaiting its fresh process.
fn receive(
    subscriber: &Subscriber<ipc::Svc, Command, ()>,
    robot_of: &mut BTreeMap<UniquePublisherId, u32>,
    reborn: &mut BTreeSet<u32>,
    waiting: &mut BTreeSet<u32>,
    commands: &mut [Option<Command>],
    stats: &mut ShellStats,
) -> Result<(), IpcError> {
    while let Some(sample) = subscriber.receive()? {
        let origin = sample.origin();
        let c = *sample.payload();
        drop(sample);
        let Some(&robot) = robot_of.get(&origin) else {
            let hello = c.version == PROTOCOL_VERSION
                && CommandKind::from_u32(c.kind) == Some(CommandKind::Hello);
            if hello && reborn.remove(&c.robot) {
                robot_of.insert(origin, c.robot);
                tracing::debug!(robot = c.robot, pid = c.pid, "restarted robot ready");
                continue;
            }
            stats.unknown_sender += 1;
            if stats.unknown_sender == 1 {
                tracing::warn!(
                    claimed = c.robot,
                    "command from a publisher that is no robot of this run"
                );
            }
            continue;
        };
        if waiting.remove(&robot) {
            commands[robot as usize] = Some(c);
        } else {
            stats.extra_commands += 1;
        }
    }
    Ok(())
}

/// Real-time mode's wait: until `until`, takes every command that arrives as its robot's
/// latest (binding restarted robots' fresh processes as in lock-step), and gives up on a
/// robot that has sent nothing for `unresponsive`. Returns true when the run must stop.
#[allow(clippy::too_many_arguments)]
fn collect_realtime(
    subscriber: &Subscriber<ipc::Svc, Command, ()>,
    listener: &Listener<ipc::Svc>,
    node: &Node<ipc::Svc>,
    control: &Receiver<Control>,
    world: &mut World,
    robot_of: &mut BTreeMap<UniquePublisherId, u32>,
    reborn: &mut BTreeSet<u32>,
    standing: &mut Standing,
    until: Instant,
    unresponsive: Duration,
    stats: &mut ShellStats,
    rt: &mut RealtimeStats,
) -> Result<bool, IpcError> {
    let tick = world.tick();
    loop {
        while let Some(sample) = subscriber.receive()? {
            let origin = sample.origin();
            let c = *sample.payload();
            drop(sample);
            let kind = CommandKind::from_u32(c.kind);
            let Some(&robot) = robot_of.get(&origin) else {
                if c.version == PROTOCOL_VERSION
                    && kind == Some(CommandKind::Hello)
                    && reborn.remove(&c.robot)
                {
                    robot_of.insert(origin, c.robot);
                    standing.forget(c.robot);
                } else {
                    stats.unknown_sender += 1;
                }
                continue;
            };
            let i = robot as usize;
            standing.heard_at[i] = Instant::now();
            if kind == Some(CommandKind::Hello) {
                stats.extra_commands += 1;
                continue;
            }
            if c.tick < tick {
                rt.stale += 1;
            }
            if standing.fresh[i] {
                stats.extra_commands += 1;
            }
            standing.last[i] = Some(c);
            standing.applied[i] = false;
            standing.fresh[i] = true;
        }
        let mut none = BTreeSet::new();
        if drain_control(control, node, world, &mut none)? {
            return Ok(true);
        }
        let now = Instant::now();
        if now < until {
            if wait(listener, node, until - now)? {
                return Ok(true);
            }
            continue;
        }
        // At the tick's end (once per tick, not per wake-up): robots silent for too long.
        let hung: Vec<u32> = world
            .robots()
            .iter()
            .filter(|r| r.state.expects_command())
            .map(|r| r.id)
            .filter(|&r| now.duration_since(standing.heard_at[r as usize]) >= unresponsive)
            .collect();
        for robot in hung {
            robot_of.retain(|_, r| *r != robot);
            let waited = now.duration_since(standing.heard_at[robot as usize]);
            give_up(world, robot, waited, "nothing sent");
            standing.forget(robot);
        }
        return Ok(false);
    }
}

/// Marks a robot that answered nothing for `scenario.unresponsive_ms` dead and asks the
/// orchestrator to kill its process: a hung robot must not hang the run.
fn give_up(world: &mut World, robot: u32, waited: Duration, why: &str) {
    let waited_ms = waited.as_millis() as u64;
    tracing::warn!(
        robot,
        waited_ms,
        "robot unresponsive ({why}); marking it dead"
    );
    world.mark_dead(robot, &format!("unresponsive: {why} for {waited_ms} ms"));
    report(&WorldReport::Unresponsive { robot, waited_ms });
}

/// Applies pending control messages; returns true when the run must stop.
fn drain_control(
    control: &Receiver<Control>,
    node: &Node<ipc::Svc>,
    world: &mut World,
    waiting: &mut BTreeSet<u32>,
) -> Result<bool, IpcError> {
    let mut stop = false;
    loop {
        match control.try_recv() {
            Ok(Control::RobotDied { robot, reason }) => {
                world.mark_dead(robot, &reason);
                waiting.remove(&robot);
                // The orchestrator has reaped it, so iceoryx2 sees its node as dead: drop its
                // ports, returning the observation samples its queue still held.
                let cleaned = node.try_cleanup_dead_nodes();
                tracing::debug!(robot, ?cleaned, "dead robot's node cleaned up");
            }
            Ok(Control::Reaped { robot }) => {
                let cleaned = node.try_cleanup_dead_nodes();
                tracing::debug!(robot, ?cleaned, "faulted robot's old node cleaned up");
            }
            Ok(Control::Stop) => stop = true,
            Err(TryRecvError::Empty) => return Ok(stop),
            Err(TryRecvError::Disconnected) => return Ok(true),
        }
    }
}
