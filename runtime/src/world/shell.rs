//! The world process shell: creates the run's services, waits for every robot's hello, then
//! runs lock-step ticks. It sleeps in an iceoryx2 listener while robots think; commands,
//! and control lines from the orchestrator (relayed by a small thread), wake it.

use std::collections::{BTreeMap, BTreeSet};

use std::io::Write;
use std::time::{Duration, Instant};

use crossbeam_channel::{Receiver, TryRecvError};
use iceoryx2::identifiers::UniquePublisherId;
use iceoryx2::port::listener::{Listener, ListenerWaitError};
use iceoryx2::prelude::*;
use swarmrt_hosts::HostsFile;
use swarmrt_hosts::wire::{Down, Up, encode_tick};
use swarmrt_hosts::world_side::{Heard, HostTraffic, Resends, WorldLink};
use swarmrt_ipc::{self as ipc, IpcError};
use swarmrt_protocol::control::{Control, ProcessFault, WorldReport};
use swarmrt_protocol::services::RunServices;
use swarmrt_protocol::{
    Command, CommandKind, Observation, ObservationHeader, PROTOCOL_VERSION, RobotState,
};

use crate::supervisor::hello::{Bindings, Sample, is_hello};
use swarmrt_scenario::Config;

use super::timing::{TickPhases, TickTimer, TickTiming, thread_cpu_ns};
use swarmrt_world::records::RecordWriter;
use swarmrt_world::{ProcessSignal, World};

/// Where a command came from: a local robot's publisher, or a remote host's robot (its host
/// bound the publisher there).
#[derive(Debug, Clone, PartialEq, Eq, PartialOrd, Ord)]
enum Origin {
    Local(UniquePublisherId),
    Remote(u32),
}

/// Who speaks for which robot, local and remote, and who waits for a hello (before tick 0
/// every robot; later, robots restarted by the schedule until their fresh process says it).
type Hellos = Bindings<Origin>;

/// Applies one classified command sample: a bound robot's first sample after the
/// observation is its answer, whatever it says (World::validate refuses a wrong tick, kind,
/// id or version, and the robot stands still this tick instead of the world waiting for
/// ever); the rest is counted.
fn take(
    sample: Sample,
    c: Command,
    pending: &mut BTreeSet<u32>,
    commands: &mut [Option<Command>],
    stats: &mut ShellStats,
) {
    match sample {
        Sample::Robot(robot) if pending.remove(&robot) => commands[robot as usize] = Some(c),
        Sample::Robot(_) => stats.extra_commands += 1,
        Sample::Hello(robot) => tracing::debug!(robot, pid = c.pid, "robot ready"),
        Sample::BadHello => {
            stats.bad_hello += 1;
            tracing::warn!(
                robot = c.robot,
                "ignoring a hello that claims a taken or foreign id"
            );
        }
        Sample::Unknown => {
            stats.unknown_sender += 1;
            if stats.unknown_sender == 1 {
                tracing::warn!(
                    claimed = c.robot,
                    "command from a publisher that is no robot of this run"
                );
            }
        }
    }
}

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
    /// TLS handshakes refused on the hosts' port (`--hosts` runs only): strangers, or hosts
    /// with the wrong certificate, counted instead of logged one by one.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub tls: Option<swarmrt_hosts::noise::Refusals>,
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
    byes: usize,
    /// When to ask a host whose messages were dropped to send them again.
    resends: Resends,
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
            byes: 0,
            resends: Resends::new(n),
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

    /// Applies what the hosts said: joins, byes, and their robots' commands, bound by the
    /// same rule as local ones (an entry may claim only the robot it is attributed to).
    /// Takes at most what was queued when it started, so a host that floods cannot keep
    /// the world here.
    fn drain(
        &mut self,
        world: &mut World,
        hellos: &mut Hellos,
        pending: &mut BTreeSet<u32>,
        commands: &mut [Option<Command>],
        stats: &mut ShellStats,
    ) -> Result<(), IpcError> {
        for _ in 0..self.heard.len() {
            let Ok(h) = self.heard.try_recv() else {
                break;
            };
            match h {
                Heard::Malformed { host, .. } => self.link.count_up(host, 0, true),
                Heard::Lost { host } => self.lose(host, world, hellos, pending),
                Heard::Up {
                    host, msg, bytes, ..
                } => {
                    self.link.count_up(host, bytes, false);
                    match msg {
                        Up::Join { host: name, layout } => {
                            if layout != self.layout || name != self.names[host] {
                                let why = format!(
                                    "host {:?} runs another swarmrt build or config (layout {layout:08x}, the world's {:08x})",
                                    self.names[host], self.layout
                                );
                                self.link.send(host, &Down::Refuse(why.clone()))?;
                                if !self.joined[host] {
                                    // Before it joined: the run cannot start as configured.
                                    return Err(why.into());
                                }
                                // After: refused and counted; the joined host goes on.
                                self.link.count_bad_join(host);
                                tracing::warn!("refused a second join: {why}");
                                continue;
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
                                let sample =
                                    hellos.accept_claiming(Origin::Remote(robot), &c, |claimed| {
                                        claimed == robot
                                    });
                                take(sample, c, pending, commands, stats);
                            }
                        }
                        Up::Resent {
                            tick,
                            answers,
                            hellos: again,
                        } => {
                            let range = self.link.robots(host);
                            let mut recovered = 0;
                            // Only what the world still waits for: a resend of something that
                            // did arrive is no robot's second answer.
                            for (robot, c) in again {
                                if range.contains(&robot)
                                    && hellos.is_awaiting(robot)
                                    && is_hello(&c)
                                {
                                    let sample =
                                        hellos.accept_claiming(Origin::Remote(robot), &c, |r| {
                                            r == robot
                                        });
                                    take(sample, c, pending, commands, stats);
                                    recovered += 1;
                                }
                            }
                            if tick == world.tick() {
                                for (robot, c) in answers {
                                    if range.contains(&robot)
                                        && pending.contains(&robot)
                                        && hellos.is_bound(robot)
                                    {
                                        let sample = hellos.accept_claiming(
                                            Origin::Remote(robot),
                                            &c,
                                            |_| false,
                                        );
                                        take(sample, c, pending, commands, stats);
                                        recovered += 1;
                                    }
                                }
                            }
                            self.link.count_recovered(host, recovered);
                        }
                    }
                }
            }
        }
        self.ask_resends(world.tick(), hellos, pending)
    }

    /// Asks each host whose messages were dropped while the world waits for some of its
    /// robots to send again what the world has not got ([`Resends`] says when).
    fn ask_resends(
        &mut self,
        tick: u64,
        hellos: &Hellos,
        pending: &BTreeSet<u32>,
    ) -> Result<(), IpcError> {
        let now = Instant::now();
        for i in 0..self.link.len() {
            let range = self.link.robots(i);
            let awaiting = hellos.awaiting_set();
            // A lost host, or one not joined yet, is asked nothing (and owes no wake-up).
            let waiting = !self.lost[i]
                && self.joined[i]
                && (pending.range(range.clone()).next().is_some()
                    || awaiting.range(range.clone()).next().is_some());
            if self.resends.due(i, self.link.dropped(i), waiting, now) {
                let answers: Vec<u32> = pending.range(range.clone()).copied().collect();
                let awaited: Vec<u32> = awaiting.range(range).copied().collect();
                tracing::debug!(host = %self.names[i], tick, ?answers, hellos = ?awaited, "asking for a resend");
                self.link.count_resend(i);
                self.link.send(
                    i,
                    &Down::Resend {
                        tick,
                        answers,
                        hellos: awaited,
                    },
                )?;
            }
        }
        Ok(())
    }

    /// When the world must look again for a resend to ask, though nothing wakes it.
    fn next_look(&self) -> Option<Instant> {
        self.resends.next()
    }

    /// A host's session is gone: its robots are dead from this tick.
    fn lose(
        &mut self,
        host: usize,
        world: &mut World,
        hellos: &mut Hellos,
        pending: &mut BTreeSet<u32>,
    ) {
        if self.lost[host] {
            return;
        }
        self.lost[host] = true;
        let mut robots = Vec::new();
        for r in self.link.robots(host) {
            hellos.forget(r);
            pending.remove(&r);
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
                Ok(Heard::Up {
                    host, msg, bytes, ..
                }) => {
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
        stats.tls = Some(swarmrt_hosts::noise::refused());
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
    let eof = tx.clone();
    ipc::lines::read_json_lines(
        std::io::stdin(),
        "the orchestrator".into(),
        move |c: Control| tx.send(c).is_ok(),
        // EOF: the orchestrator is gone; finish the records and stop.
        move || {
            let _ = eof.send(Control::Stop);
        },
    );
    ipc::wake_relay(run, format!("{}-control", run.world_node_name()), rx)
}

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
    let n = cfg.robots.count as usize;
    let mut world = World::new(cfg, vocabulary).map_err(|e| format!("{}: {}", e.key, e.message))?;
    let mut recorder = RecordWriter::for_run(out_dir, cfg)?;
    world.set_radio_recording(cfg.scenario.record_radio);
    warn_on_fd_limit(n);
    let node = ipc::node(run, &run.world_node_name())?;
    let observers = cfg.ipc.observers as usize;
    let services =
        ipc::create_services(&node, run, 0..n as u32, cfg.faults.restart.len(), observers)?;
    let ports = ipc::WorldPorts::open(&services, n, observers)?;
    if cfg.radio.rounds > 0 && (hosts.is_some() || mode == Mode::Realtime) {
        return Err(
            "radio.rounds needs every robot on this host, in lock-step (no --hosts, no --realtime)"
                .into(),
        );
    }
    let rounds = if cfg.radio.rounds > 0 {
        Some(ipc::rounds::WorldRounds::create(
            &node,
            run,
            n,
            8 + cfg.faults.restart.len() + observers,
        )?)
    } else {
        None
    };
    let control = spawn_control_thread(run)?;
    let remote = match hosts {
        Some((file, layout)) => Some(Remote::open(run, file, layout)?),
        None => None,
    };
    report(&WorldReport::Listening);

    let mut shell = Shell {
        world,
        node: &node,
        ports,
        rounds,
        control,
        remote,
        hellos: Bindings::awaiting(0..n as u32),
        remote_robot: (0..n as u32)
            .map(|r| hosts.is_some_and(|(f, _)| f.host_of(r).is_some()))
            .collect(),
        pending: BTreeSet::new(),
        commands: vec![None; n],
        stats: ShellStats::default(),
        interrupted: false,
        unresponsive: Duration::from_millis(cfg.scenario.unresponsive_ms),
        counting: counting_robots(cfg, n, hosts.map(|(f, _)| f), mode),
    };
    // Phase 1: every robot says hello (or dies) before tick 0.
    let started = Instant::now();
    shell.await_hellos(started)?;
    report(&WorldReport::Ready {
        startup_ms: started.elapsed().as_millis() as u64,
    });
    // Phase 2: ticks, then the end.
    shell.run_ticks(cfg, mode, &mut recorder)?;
    shell.finish(recorder)
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

/// The world process between its phases: the World core and everything that reaches it.
struct Shell<'a> {
    world: World,
    node: &'a Node<ipc::Svc>,
    ports: ipc::WorldPorts,
    /// The propagation rounds' ports (`radio.rounds` > 0).
    rounds: Option<ipc::rounds::WorldRounds>,
    /// Control lines from the orchestrator.
    control: Receiver<Control>,
    /// The remote hosts (`--hosts` runs).
    remote: Option<Remote>,
    /// Who speaks for which robot, and who waits for a hello.
    hellos: Hellos,
    /// Robots of a remote host: no local publisher may claim one.
    remote_robot: Vec<bool>,
    /// The robots whose answer the current tick waits for (none before tick 0).
    pending: BTreeSet<u32>,
    /// The current tick's answers.
    commands: Vec<Option<Command>>,
    stats: ShellStats,
    /// A Stop, a closed stdin or a termination signal: finish the records and stop.
    interrupted: bool,
    /// `scenario.unresponsive_ms`: a robot silent this long is given up.
    unresponsive: Duration,
    /// Per robot, whether it counts its answers on the bell (None: nobody does).
    counting: Option<Vec<bool>>,
}

impl Shell<'_> {
    /// Takes everything that arrived: local command samples, the hosts' messages and the
    /// orchestrator's control lines.
    fn gather(&mut self) -> Result<(), IpcError> {
        receive(
            &self.ports.commands,
            &self.remote_robot,
            &mut self.hellos,
            &mut self.pending,
            &mut self.commands,
            &mut self.stats,
        )?;
        if let Some(r) = self.remote.as_mut() {
            r.drain(
                &mut self.world,
                &mut self.hellos,
                &mut self.pending,
                &mut self.commands,
                &mut self.stats,
            )?;
        }
        self.interrupted |= drain_control(
            &self.control,
            self.node,
            &mut self.world,
            &mut self.hellos,
            &mut self.pending,
        )?;
        Ok(())
    }

    /// Sets the bell's target for the pending robots that count their answers, given the
    /// answer count `base` read before the last gather: the last of them notifies. True when
    /// the count already reached it (an answer came in between): gather again, do not sleep.
    fn expect_answers(&self, base: u64) -> bool {
        let Some(counting) = &self.counting else {
            return false;
        };
        let waiting = self
            .pending
            .iter()
            .filter(|&&r| counting.get(r as usize).copied().unwrap_or(false))
            .count() as u64;
        let bell = &self.ports.bell;
        if waiting == 0 {
            // Only robots that notify every answer are left.
            bell.expect(0);
            return false;
        }
        let target = base + waiting;
        bell.expect(target);
        bell.answers() >= target
    }

    /// Sleeps until a robot, a host or the control thread wakes the world, or `timeout`
    /// (or sooner, when a resend held back must be asked for).
    fn sleep(&mut self, timeout: Duration) -> Result<(), IpcError> {
        let timeout = match self.remote.as_ref().and_then(Remote::next_look) {
            Some(at) => timeout.min(at.saturating_duration_since(Instant::now())),
            None => timeout,
        };
        self.interrupted |= wait(&self.ports.listener, self.node, timeout)?;
        Ok(())
    }

    /// Phase 1: waits until every robot said hello (or died), for [`STARTUP_TIMEOUT`].
    fn await_hellos(&mut self, started: Instant) -> Result<(), IpcError> {
        while !self.hellos.awaiting_set().is_empty() && !self.interrupted {
            self.gather()?;
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

    /// Phase 2: ticks until the scenario ends or the run is stopped.
    fn run_ticks(
        &mut self,
        cfg: &Config,
        mode: Mode,
        recorder: &mut RecordWriter,
    ) -> Result<(), IpcError> {
        let realtime = mode == Mode::Realtime;
        let n = self.commands.len();
        let deadline = Duration::from_millis(cfg.scenario.deadline_ms);
        let mut obs = vec![Observation::empty(0, 0); n];
        let mut last_progress = Instant::now();
        let mut timer = TickTimer::default();
        // The world times its stages too (wall clock, for `shell.timing` only).
        self.world.set_stage_timing(true);
        let events = self.world.drain_events();
        recorder.record(self.world.tick(), self.world.robots(), events)?;
        let period = Duration::from_secs_f64(cfg.scenario.dt);
        let mut standing = Standing::new(n);
        let mut rt_stats = RealtimeStats {
            period_ms: period.as_secs_f64() * 1e3,
            ..RealtimeStats::default()
        };
        let mut tick_ends = Instant::now() + period;
        while !self.interrupted && !self.world.finished() {
            let rejoining = self.apply_signals(&mut standing);
            let tick = self.world.tick();
            self.await_rejoin(rejoining)?;
            if self.interrupted {
                break;
            }
            let t0 = Instant::now();
            self.world.observe(&mut obs);
            let t1 = Instant::now();
            let cpu1 = thread_cpu_ns();
            self.publish(tick, &obs)?;
            let publish_cpu = thread_cpu_ns().saturating_sub(cpu1);
            let t2 = Instant::now();
            if realtime {
                self.collect_realtime(&mut standing, tick_ends, &mut rt_stats)?;
                for robot in std::mem::take(&mut self.pending) {
                    if self.world.robots()[robot as usize].state.expects_command() {
                        self.commands[robot as usize] =
                            standing.command(robot, tick, &mut rt_stats);
                    }
                }
            } else {
                self.collect(tick, deadline)?;
                if !self.interrupted {
                    self.propagate(tick, deadline)?;
                }
            }
            if self.interrupted {
                break;
            }
            // With rounds, `wait` includes them.
            let t3 = Instant::now();
            self.world.step(&self.commands);
            let events = self.world.drain_events();
            let radio = self.world.take_radio_rows();
            let t4 = Instant::now();
            recorder.record_tick(self.world.tick(), self.world.robots(), events, radio)?;
            let t5 = Instant::now();
            let ns = |a: Instant, b: Instant| (b - a).as_nanos() as u64;
            timer.add(TickPhases {
                observe: ns(t0, t1),
                publish: ns(t1, t2),
                wait: ns(t2, t3),
                step: ns(t3, t4),
                record: ns(t4, t5),
                publish_cpu,
                stages: self.world.take_stage_times(),
            });
            if self.world.tick() <= EARLY_REPORTS || last_progress.elapsed() >= PROGRESS_EVERY {
                last_progress = Instant::now();
                report(&WorldReport::Tick {
                    tick: self.world.tick(),
                });
            }
            tick_ends += period;
            if realtime && Instant::now() > tick_ends {
                rt_stats.overruns += 1;
                tick_ends = Instant::now() + period;
            }
        }
        if realtime {
            self.stats.realtime = Some(rt_stats);
        }
        self.stats.timing = timer.summary();
        Ok(())
    }

    /// The schedule's process faults of this tick, passed to the orchestrator (which carries
    /// them out); returns the restarted robots that rejoin now.
    fn apply_signals(&mut self, standing: &mut Standing) -> BTreeSet<u32> {
        let mut rejoining: BTreeSet<u32> = BTreeSet::new();
        for signal in self.world.take_signals() {
            match signal {
                ProcessSignal::Fault(fault) => {
                    let robot = fault.robot();
                    // Its last command is no longer its answer: killed, frozen, thawed (its
                    // silence while frozen was ordered, not a hang) or restarted.
                    standing.forget(robot);
                    match fault {
                        ProcessFault::Kill { .. } => self.hellos.forget(robot),
                        // Samples from the old process are no robot's answer any more.
                        ProcessFault::Restart { .. } => self.hellos.expect_hello(robot),
                        ProcessFault::Freeze { .. } | ProcessFault::Thaw { .. } => {}
                    }
                    report(&WorldReport::Fault(fault));
                }
                ProcessSignal::Rejoin(robot) => {
                    rejoining.insert(robot);
                }
            }
        }
        rejoining
    }

    /// A rejoining robot's fresh process must be bound before its first observation; one
    /// that says no hello for `scenario.unresponsive_ms` is given up.
    fn await_rejoin(&mut self, mut rejoining: BTreeSet<u32>) -> Result<(), IpcError> {
        let hello_since = Instant::now();
        while !rejoining.is_empty() {
            self.pending.clear();
            self.gather()?;
            rejoining.retain(|r| {
                self.hellos.is_awaiting(*r)
                    && self.world.robots()[*r as usize].state != RobotState::Dead
            });
            if rejoining.is_empty() || self.interrupted {
                break;
            }
            if hello_since.elapsed() >= self.unresponsive {
                for &robot in &rejoining {
                    give_up(
                        &mut self.world,
                        robot,
                        hello_since.elapsed(),
                        "never said hello after its restart",
                    );
                    self.hellos.forget(robot);
                }
                break;
            }
            self.sleep(self.unresponsive.saturating_sub(hello_since.elapsed()))?;
        }
        Ok(())
    }

    /// Publishes the tick's observations (locally and to the hosts) and notes which robots
    /// the tick waits for.
    fn publish(&mut self, tick: u64, obs: &[Observation]) -> Result<(), IpcError> {
        self.commands.iter_mut().for_each(|c| *c = None);
        self.pending = self
            .world
            .robots()
            .iter()
            .filter(|r| r.state.expects_command())
            .map(|r| r.id)
            .collect();
        // Before the ring: the tick's last counting robot must see the new target.
        let base = self.ports.bell.answers();
        self.expect_answers(base);
        let sample = self.ports.publisher.loan_slice_uninit(obs.len())?;
        let mut sample = sample.write_from_slice(obs);
        *sample.user_header_mut() = ObservationHeader {
            version: PROTOCOL_VERSION,
            shutdown: 0,
            tick,
        };
        sample.send()?;
        self.ports.wake_robots()?;
        if let Some(rounds) = &self.rounds {
            for &robot in &self.pending {
                rounds.wake(robot)?;
            }
        }
        if let Some(r) = self.remote.as_mut() {
            r.send_tick(tick, obs, &self.pending)?;
        }
        Ok(())
    }

    /// The tick's propagation rounds (`radio.rounds` > 0), as [`swarmrt_harness`]'s
    /// `Lockstep::propagate` runs them: each round is published to the robots woken in it,
    /// their reactions are collected as a tick's answers are (deadline, unresponsive, deaths)
    /// and applied in ascending robot order.
    fn propagate(&mut self, tick: u64, deadline: Duration) -> Result<(), IpcError> {
        let Some(rounds) = self.rounds.take() else {
            return Ok(());
        };
        let mut acts = std::mem::take(&mut self.commands);
        self.commands = vec![None; acts.len()];
        self.world.start_rounds(&acts);
        let result = loop {
            let round = self.world.next_round();
            if round.is_empty() {
                break Ok(());
            }
            self.commands.iter_mut().for_each(|c| *c = None);
            self.pending = round.iter().map(|b| b.robot).collect();
            if let Err(e) = rounds.publish(tick, self.world.round(), &round) {
                break Err(e);
            }
            if let Err(e) = self.collect(tick, deadline) {
                break Err(e);
            }
            for b in &round {
                let answer = self.commands[b.robot as usize];
                self.world.react(b.robot, answer.as_ref(), &mut acts);
            }
            if self.interrupted {
                break Ok(());
            }
        };
        self.commands = acts;
        self.rounds = Some(rounds);
        result
    }

    /// Lock-step: waits until every pending robot answered. Past `deadline` the late ones are
    /// counted; past `scenario.unresponsive_ms` they are given up.
    fn collect(&mut self, tick: u64, deadline: Duration) -> Result<(), IpcError> {
        let sent_at = Instant::now();
        let mut late_logged = false;
        loop {
            let base = self.ports.bell.answers();
            self.gather()?;
            if self.pending.is_empty() || self.interrupted {
                return Ok(());
            }
            let waited = sent_at.elapsed();
            if waited >= self.unresponsive {
                for robot in std::mem::take(&mut self.pending) {
                    self.hellos.forget(robot);
                    give_up(&mut self.world, robot, waited, "no answer");
                }
                return Ok(());
            }
            let timeout = if waited < deadline {
                deadline - waited
            } else {
                if !late_logged {
                    late_logged = true;
                    self.stats.late += self.pending.len() as u64;
                    tracing::warn!(tick, late = ?self.pending, "robots past the deadline");
                }
                self.unresponsive - waited
            };
            if self.expect_answers(base) {
                continue;
            }
            self.sleep(timeout)?;
        }
    }

    /// Real-time: takes whatever arrives until the tick's end (`until`).
    fn collect_realtime(
        &mut self,
        standing: &mut Standing,
        until: Instant,
        rt: &mut RealtimeStats,
    ) -> Result<(), IpcError> {
        self.interrupted |= collect_until(
            &self.ports.commands,
            &self.ports.listener,
            self.node,
            &self.control,
            &mut self.world,
            &self.remote_robot,
            &mut self.hellos,
            standing,
            until,
            self.unresponsive,
            &mut self.stats,
            rt,
        )?;
        Ok(())
    }

    /// Tells robots and hosts the run is over, closes the records and reports them.
    fn finish(mut self, mut recorder: RecordWriter) -> Result<(), IpcError> {
        let tick = self.world.tick();
        // A header-only sample.
        let sample = self.ports.publisher.loan_slice_uninit(0)?;
        let mut sample = sample.write_from_slice(&[]);
        *sample.user_header_mut() = ObservationHeader {
            version: PROTOCOL_VERSION,
            shutdown: 1,
            tick,
        };
        sample.send()?;
        self.ports.wake_robots()?;
        if let Some(r) = self.remote.take() {
            r.finish(tick, &mut self.stats);
        }
        // Deaths marked after the last recorded tick: events only, the tick's rows exist.
        recorder.record_events(self.world.drain_events())?;
        recorder.finish()?;
        let mut metrics = serde_json::to_value(self.world.metrics())?;
        metrics["shell"] = serde_json::to_value(&self.stats)?;
        report(&WorldReport::Tick { tick });
        report(&WorldReport::Done {
            interrupted: self.interrupted,
            metrics,
        });
        Ok(())
    }
}

/// Receives every queued command sample from the robots of this host, bound by their hello
/// ([`take`] says what each is).
fn receive(
    subscriber: &ipc::CommandSubscribers,
    remote_robot: &[bool],
    hellos: &mut Hellos,
    pending: &mut BTreeSet<u32>,
    commands: &mut [Option<Command>],
    stats: &mut ShellStats,
) -> Result<(), IpcError> {
    while let Some(sample) = subscriber.receive()? {
        let origin = Origin::Local(sample.origin());
        let c = *sample.payload();
        drop(sample);
        let local = |r: u32| !remote_robot.get(r as usize).copied().unwrap_or(true);
        let sample = hellos.accept_claiming(origin, &c, local);
        take(sample, c, pending, commands, stats);
    }
    Ok(())
}

/// Real-time mode's wait: until `until`, takes every command that arrives as its robot's
/// latest (binding restarted robots' fresh processes as in lock-step), and gives up on a
/// robot that has sent nothing for `unresponsive`. Returns true when the run must stop.
#[allow(clippy::too_many_arguments)]
fn collect_until(
    subscriber: &ipc::CommandSubscribers,
    listener: &Listener<ipc::Svc>,
    node: &Node<ipc::Svc>,
    control: &Receiver<Control>,
    world: &mut World,
    remote_robot: &[bool],
    hellos: &mut Hellos,
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
            let local = |r: u32| !remote_robot.get(r as usize).copied().unwrap_or(true);
            let robot = match hellos.accept_claiming(Origin::Local(origin), &c, local) {
                Sample::Robot(robot) => robot,
                Sample::Hello(robot) => {
                    standing.forget(robot);
                    continue;
                }
                other => {
                    take(other, c, &mut BTreeSet::new(), &mut [], stats);
                    continue;
                }
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
        if drain_control(control, node, world, hellos, &mut BTreeSet::new())? {
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
            hellos.forget(robot);
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
    hellos: &mut Hellos,
    pending: &mut BTreeSet<u32>,
) -> Result<bool, IpcError> {
    let mut stop = false;
    loop {
        match control.try_recv() {
            Ok(Control::RobotDied { robot, reason }) => {
                world.mark_dead(robot, &reason);
                hellos.forget(robot);
                pending.remove(&robot);
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
