//! The `swarm-host` process: the world's stand-in on a remote host.
//!
//! It creates the run's iceoryx2 services in its own root with today's sizing, joins the world
//! over Zenoh, starts its robots, and then per tick republishes the world's slots for its
//! robots, wakes them, and sends their commands back in one batch once every robot the world
//! waits for has answered (or, past the deadline, as they come). It carries out its robots'
//! faults on the orchestrator's orders, which arrive as lines on its stdin through the
//! launcher; its reports go back on stdout. On every exit path it removes its resources.

use std::collections::{BTreeMap, BTreeSet};
use std::io::{BufRead, Write};
use std::path::PathBuf;
use std::time::{Duration, Instant};

use clap::Parser;
use crossbeam_channel::{Receiver, Sender};
use iceoryx2::identifiers::UniquePublisherId;
use iceoryx2::port::listener::ListenerWaitError;
use iceoryx2::prelude::*;
use serde::Serialize;
use swarmrt_ipc::cleanup;
use swarmrt_ipc::{self as ipc, IpcError};
use swarmrt_protocol::Command;
use swarmrt_protocol::control::{HostControl, HostReport, ProcessFault};
use swarmrt_protocol::services::{RunServices, valid_run_id};
#[cfg(feature = "misbehave")]
use zenoh::Wait;

use crate::inbox;
mod session;

use crate::supervisor::hello::{Bindings, Sample};
use crate::supervisor::launch::{self, Launch, ShellSide};
use crate::supervisor::{Ended, Event, Pid, Supervisor};
use session::HostLink;
use swarmrt_hosts::link;
use swarmrt_hosts::wire::{Down, Up};

/// How long the host repeats its join before giving up on the world.
const JOIN_TIMEOUT: Duration = Duration::from_secs(20);
/// Robots get this long to exit after the shutdown sample, then SIGTERM, then SIGKILL.
const EXIT_GRACE: Duration = Duration::from_secs(3);

/// The `swarm-host` command line (started by `swarm run --hosts` through the host's launcher).
#[derive(Parser, Debug)]
#[command(
    name = "swarm-host",
    version,
    about = "Runs a group of a swarmrt run's robots on this host"
)]
struct Args {
    /// Run id (lower-case hex).
    #[arg(long)]
    run_id: String,
    /// This host's name in hosts.toml.
    #[arg(long, default_value = "host")]
    host: String,
    /// The first robot id this host runs.
    #[arg(long, default_value_t = 0)]
    first: u32,
    /// How many robots this host runs.
    #[arg(long, default_value_t = 0)]
    count: u32,
    /// The world's Zenoh endpoint (`quic/...`, or `tcp/...` for an insecure link).
    #[arg(long, default_value = "")]
    connect: String,
    /// The directory holding the CA (`ca.pem`) and this host's `host-<name>.pem` and
    /// `.key` (what `swarm certs` wrote); needed for a `quic/` endpoint.
    #[arg(long)]
    certs: Option<PathBuf>,
    /// Only remove this run's iceoryx2 resources on this host, then exit.
    #[arg(long)]
    clean: bool,
}

/// What the host counted (`metrics.json` -> `hosts`).
#[derive(Debug, Default, Serialize)]
pub struct HostStats {
    /// The host.
    pub host: String,
    /// Ticks received.
    pub ticks: u64,
    /// Observation slots received: its own robots' only.
    pub slots_received: u64,
    /// Bytes received from the world.
    pub bytes_down: u64,
    /// Bytes sent to the world.
    pub bytes_up: u64,
    /// Command batches sent.
    pub batches_up: u64,
    /// Commands forwarded.
    pub commands_up: u64,
    /// Batches sent before every awaited robot had answered (past `scenario.deadline_ms`).
    pub partial_batches: u64,
    /// Samples from publishers that are no robot of this host.
    pub unknown_sender: u64,
    /// Messages from the world that did not decode.
    pub malformed: u64,
    /// Resends the world asked for (it dropped messages of this host: see `shell.link`).
    pub resends: u64,
    /// Commands sent again in answer to them.
    pub resent: u64,
}

enum Msg {
    Down(Down, usize),
    Malformed,
    WorldLost,
    Control(HostControl),
    ControlEof,
    Exited(Pid, String),
}

fn report(r: &HostReport) {
    let mut out = std::io::stdout().lock();
    let _ = out.write_all(r.to_line().as_bytes());
    let _ = out.flush();
}

/// Entry point of the `swarm-host` binary.
pub fn main() -> std::process::ExitCode {
    let args = Args::parse();
    swarmrt_scenario::process::init_logging();
    if !valid_run_id(&args.run_id) {
        eprintln!("error: invalid run id {:?}", args.run_id);
        return std::process::ExitCode::from(2);
    }
    if args.clean {
        let removed = cleanup::remove_run(&args.run_id);
        tracing::debug!(removed, "run resources removed");
        return std::process::ExitCode::SUCCESS;
    }
    let span = tracing::info_span!("host", host = %args.host);
    let _enter = span.enter();
    if let Err(e) = cleanup::claim(&args.run_id) {
        let why = format!(
            "cannot create the run's iceoryx2 directory (is this host's /dev/shm shared with the world's?): {e}"
        );
        report(&HostReport::Failed { why });
        return std::process::ExitCode::from(1);
    }
    let result = serve(&args);
    let removed = cleanup::remove_run(&args.run_id);
    tracing::debug!(removed, "run resources removed");
    match result {
        Ok(stats) => {
            report(&HostReport::Done {
                stats: serde_json::to_value(&stats).unwrap_or_default(),
            });
            std::process::ExitCode::SUCCESS
        }
        Err(e) => {
            report(&HostReport::Failed { why: e.to_string() });
            std::process::ExitCode::from(1)
        }
    }
}

fn read_config(run: &RunServices) -> Result<(swarmrt_scenario::Config, String, PathBuf), IpcError> {
    let mut line = String::new();
    std::io::stdin().lock().read_line(&mut line)?;
    let Ok(HostControl::Config { toml }) = serde_json::from_str::<HostControl>(&line) else {
        return Err("expected the run's config as the first line on stdin".into());
    };
    let dir = run.ipc_root().join("host");
    std::fs::create_dir_all(dir.join("storage"))?;
    let path = dir.join("config.toml");
    std::fs::write(&path, &toml)?;
    let cfg = swarmrt_scenario::Config::load(&path, &[]).map_err(|e| e.to_string())?;
    Ok((cfg, toml, dir))
}

fn serve(args: &Args) -> Result<HostStats, IpcError> {
    let run = RunServices::new(&args.run_id);
    let (cfg, toml, dir) = read_config(&run)?;
    let robots = robots_of(args, &cfg)?;
    let count = robots.len();
    let agent = agent_beside()?;
    let _ = ipc::raise_fd_limit();
    let node = ipc::node(&run, &format!("swarmrt-{}-host", args.run_id))?;
    let observers = cfg.ipc.observers as usize;
    let restarts = cfg.faults.restart.len();
    let services = ipc::create_services(&node, &run, robots.clone(), restarts, observers)?;
    let ports = ipc::WorldPorts::open(&services, count, observers)?;
    let (raw_tx, raw_rx) = crossbeam_channel::unbounded::<Msg>();
    let rx = ipc::wake_relay(&run, format!("swarmrt-{}-host-relay", args.run_id), raw_rx)?;
    spawn_stdin_reader(raw_tx.clone());
    let link = HostLink::open(args, count, &raw_tx)?;
    let mut stats = HostStats {
        host: args.host.clone(),
        ..HostStats::default()
    };
    let mut send = |msg: &Up, stats: &mut HostStats| link.send(msg, stats);
    join(args, &toml, &rx, &mut |m| send(m, &mut stats))?;
    report(&HostReport::Joined);
    #[cfg(feature = "misbehave")]
    let flood = Flood::from_env(link.session(), &args.run_id, &args.host);

    // `cd <this dir> && iox2 service list` on this host sees the run's local services.
    let ipc_config = dir.join("config/iceoryx2.toml");
    ipc::write_config_file(&run, &ipc_config)?;
    let launch = Launch {
        agent,
        run: run.clone(),
        config: dir.join("config.toml"),
        storage: dir.join("storage"),
        first: args.first,
        cfg: cfg.clone(),
        ipc_config,
        quiet: true,
    };
    let shell = HostShell {
        node: &node,
        tx: raw_tx,
        launch,
    };
    let mut relay = Relay::new(&node, ports, shell, robots.clone(), &cfg);
    for robot in robots {
        relay.on(Event::Launch { robot })?;
    }
    let failure = relay.run(&rx, &mut stats, &mut send)?;
    #[cfg(feature = "misbehave")]
    drop(flood);
    relay.see_out(&rx)?;
    // The world waits for this before it closes its session, so the shutdown was delivered.
    let _ = send(&Up::Bye, &mut stats);
    drop(services);
    drop(node);
    link.close();
    match failure {
        None => Ok(stats),
        Some(f) => Err(f.into()),
    }
}

/// The robots `--first` and `--count` name, refused when they are not robots of this run.
fn robots_of(
    args: &Args,
    cfg: &swarmrt_scenario::Config,
) -> Result<std::ops::Range<u32>, IpcError> {
    let (first, count) = (args.first, args.count);
    if count == 0 || first as u64 + count as u64 > cfg.robots.count as u64 {
        return Err(format!(
            "robots {first}..{} are not robots of this run (robots.count = {})",
            first as u64 + count as u64,
            cfg.robots.count
        )
        .into());
    }
    Ok(first..first + count)
}

/// The `swarm-agent` binary installed beside this one.
fn agent_beside() -> Result<PathBuf, IpcError> {
    Ok(std::env::current_exe()?
        .parent()
        .map(|d| d.join("swarm-agent"))
        .filter(|p| p.exists())
        .ok_or("cannot find swarm-agent beside swarm-host")?)
}

/// Relays the orchestrator's control lines (through the launcher's stdin) to the main loop.
fn spawn_stdin_reader(tx: crossbeam_channel::Sender<Msg>) {
    let eof = tx.clone();
    ipc::lines::read_json_lines(
        std::io::stdin(),
        "the orchestrator".into(),
        move |c: HostControl| tx.send(Msg::Control(c)).is_ok(),
        move || {
            let _ = eof.send(Msg::ControlEof);
        },
    );
}

/// Joins the world: the join is repeated until the world answers (its subscriber may not
/// know us yet), for [`JOIN_TIMEOUT`].
fn join(
    args: &Args,
    toml: &str,
    rx: &Receiver<Msg>,
    send: &mut dyn FnMut(&Up) -> Result<(), IpcError>,
) -> Result<(), IpcError> {
    let join = Up::Join {
        host: args.host.clone(),
        layout: link::layout(toml),
    };
    let since = Instant::now();
    loop {
        send(&join)?;
        let until = Instant::now() + Duration::from_millis(250);
        while let Ok(m) = rx.recv_deadline(until) {
            match m {
                Msg::Down(Down::Welcome, _) => return Ok(()),
                Msg::Down(Down::Refuse(why), _) => {
                    return Err(format!("the world refused this host: {why}").into());
                }
                Msg::ControlEof | Msg::Control(HostControl::Stop) => {
                    return Err("stopped before joining".into());
                }
                _ => {}
            }
        }
        if since.elapsed() > JOIN_TIMEOUT {
            return Err(format!(
                "the world at {} did not answer the join within {} s",
                args.connect,
                JOIN_TIMEOUT.as_secs()
            )
            .into());
        }
    }
}

/// The host between the world and its robots: per tick it republishes the world's slots,
/// wakes the robots and sends their commands back in one batch; it carries out faults.
struct Relay<'a> {
    node: &'a Node<ipc::Svc>,
    ports: ipc::WorldPorts,
    /// How the supervisor's orders are carried out on this host.
    shell: HostShell<'a>,
    sup: Supervisor,
    bindings: Bindings<UniquePublisherId>,
    /// This host's robots.
    robots: std::ops::Range<u32>,
    /// The robots of this host the world waits for in the current tick.
    expect: BTreeSet<u32>,
    /// Commands not sent up yet, each with whether it is a hello that bound its robot.
    batch: Vec<(u32, Command, bool)>,
    /// The world asked for a resend this tick (it is dropping this host's messages): the
    /// rest of the tick goes up as `Resent`, which has places of its own at the world.
    lane: bool,
    /// The tick of the slots last received.
    tick: u64,
    /// Each robot's first command since those slots (its answer), kept for a resend.
    answered: BTreeMap<u32, Command>,
    /// Each robot's last hello, kept for a resend until the robot is killed or restarted.
    hellos: BTreeMap<u32, Command>,
    /// When the current tick's slots were published.
    tick_at: Instant,
    /// Send each answer as it comes: a hello arrived, or the tick is past its deadline.
    flush_each: bool,
    /// `scenario.deadline_ms`.
    deadline: Duration,
}

/// Sends a message up to the world, counting its bytes.
type SendUp<'s> = dyn FnMut(&Up, &mut HostStats) -> Result<(), IpcError> + 's;

impl<'a> Relay<'a> {
    /// Nothing relayed yet: every robot of `robots` waits for its hello.
    fn new(
        node: &'a Node<ipc::Svc>,
        ports: ipc::WorldPorts,
        shell: HostShell<'a>,
        robots: std::ops::Range<u32>,
        cfg: &swarmrt_scenario::Config,
    ) -> Relay<'a> {
        Relay {
            node,
            ports,
            shell,
            sup: Supervisor::new(),
            bindings: Bindings::awaiting(robots.clone()),
            robots,
            expect: BTreeSet::new(),
            batch: Vec::new(),
            lane: false,
            tick: 0,
            answered: BTreeMap::new(),
            hellos: BTreeMap::new(),
            tick_at: Instant::now(),
            flush_each: false,
            deadline: Duration::from_millis(cfg.scenario.deadline_ms),
        }
    }

    /// Tells the robots the run is over (a header-only sample), then sees them out:
    /// EXIT_GRACE to exit on it, then SIGTERM, then SIGKILL.
    fn see_out(mut self, rx: &Receiver<Msg>) -> Result<(), IpcError> {
        self.ports.publish_shutdown(0)?;
        launch::see_out(
            &mut self.sup,
            rx,
            (EXIT_GRACE, EXIT_GRACE),
            &mut self.shell,
            |_, m| {
                let Msg::Exited(pid, how) = m else {
                    return None;
                };
                Some(Event::Reaped { pid, how })
            },
        );
        Ok(())
    }
}

impl Relay<'_> {
    /// Relays until the world's shutdown, a Stop, or a failure (returned as its reason).
    fn run(
        &mut self,
        rx: &Receiver<Msg>,
        stats: &mut HostStats,
        send: &mut SendUp,
    ) -> Result<Option<String>, IpcError> {
        loop {
            self.forward_commands(stats, send)?;
            for m in rx.try_iter() {
                if let Some(end) = self.handle(m, stats, send)? {
                    return Ok(end);
                }
            }
            let timeout = if !self.expect.is_empty() && !self.flush_each {
                let waited = self.tick_at.elapsed();
                if waited >= self.deadline {
                    // Past the deadline: send what came, then each answer as it comes.
                    self.flush_each = true;
                    continue;
                }
                self.deadline - waited
            } else {
                Duration::from_millis(500)
            };
            match self.ports.listener.timed_wait(|_| {}, timeout) {
                Ok(_) | Err(ListenerWaitError::InterruptSignal) => {
                    if ipc::termination_requested(self.node) {
                        return Ok(Some("terminated by a signal".into()));
                    }
                }
                Err(e) => return Err(e.into()),
            }
        }
    }

    /// The robots' commands, attributed by publisher as the world does on one host, sent up
    /// once every awaited robot answered (or each as it comes, see `flush_each`).
    fn forward_commands(
        &mut self,
        stats: &mut HostStats,
        send: &mut SendUp,
    ) -> Result<(), IpcError> {
        let origin = |publisher| publisher;
        inbox::receive(
            &self.ports.commands,
            &mut self.bindings,
            origin,
            |_| true,
            |what, c| match what {
                Sample::Robot(robot) => {
                    self.expect.remove(&robot);
                    self.answered.entry(robot).or_insert(c);
                    self.batch.push((robot, c, false));
                }
                Sample::Hello(robot) => {
                    self.hellos.insert(robot, c);
                    self.batch.push((robot, c, true));
                    self.flush_each = true;
                }
                Sample::BadHello | Sample::Unknown => stats.unknown_sender += 1,
            },
        )?;
        if !self.batch.is_empty() && (self.expect.is_empty() || self.flush_each) {
            if !self.expect.is_empty() {
                stats.partial_batches += 1;
            }
            stats.batches_up += 1;
            stats.commands_up += self.batch.len() as u64;
            let batch = std::mem::take(&mut self.batch);
            let msg = if self.lane {
                let (hellos, answers): (Vec<_>, Vec<_>) = batch.into_iter().partition(|e| e.2);
                let strip = |v: Vec<(u32, Command, bool)>| v.into_iter().map(|(r, c, _)| (r, c));
                Up::Resent {
                    tick: self.tick,
                    answers: strip(answers).collect(),
                    hellos: strip(hellos).collect(),
                }
            } else {
                Up::Commands(batch.into_iter().map(|(r, c, _)| (r, c)).collect())
            };
            send(&msg, stats)?;
        }
        Ok(())
    }

    /// One message; `Some(end)` ends the run (`end` is the failure, if any).
    fn handle(
        &mut self,
        m: Msg,
        stats: &mut HostStats,
        send: &mut SendUp,
    ) -> Result<Option<Option<String>>, IpcError> {
        match m {
            Msg::Down(
                Down::Tick {
                    tick,
                    expect,
                    slots,
                },
                bytes,
            ) => {
                stats.ticks += 1;
                stats.slots_received += slots.len() as u64;
                stats.bytes_down += bytes as u64;
                if slots.len() != self.robots.len() {
                    stats.malformed += 1;
                    return Ok(None);
                }
                self.ports.publish(tick, &slots)?;
                self.expect = expect
                    .into_iter()
                    .filter(|r| self.robots.contains(r))
                    .collect();
                self.tick = tick;
                self.answered.clear();
                self.lane = false;
                self.tick_at = Instant::now();
                self.flush_each = false;
            }
            Msg::Down(
                Down::Resend {
                    tick,
                    answers,
                    hellos,
                },
                bytes,
            ) => {
                stats.bytes_down += bytes as u64;
                stats.resends += 1;
                self.resend(tick, &answers, &hellos, stats, send)?;
            }
            Msg::Down(Down::Shutdown { .. }, bytes) => {
                stats.bytes_down += bytes as u64;
                return Ok(Some(None));
            }
            Msg::Down(_, _) => {}
            Msg::Malformed => stats.malformed += 1,
            Msg::WorldLost => {
                return Ok(Some(Some(
                    "lost the world (its session ended or the link was cut)".into(),
                )));
            }
            Msg::Control(HostControl::Stop) => return Ok(Some(None)),
            Msg::Control(c) => self.order(c)?,
            Msg::ControlEof => {
                return Ok(Some(Some("the orchestrator is gone (stdin closed)".into())));
            }
            Msg::Exited(pid, how) => self.on(Event::Reaped { pid, how })?,
        }
        Ok(None)
    }

    /// The world did not get some of what this host sent (messages of it were dropped):
    /// sends again what it holds of what was asked. Answers only for the tick it holds.
    fn resend(
        &mut self,
        tick: u64,
        answers: &[u32],
        hellos: &[u32],
        stats: &mut HostStats,
        send: &mut SendUp,
    ) -> Result<(), IpcError> {
        let held = |map: &BTreeMap<u32, Command>, ids: &[u32]| -> Vec<(u32, Command)> {
            ids.iter()
                .filter_map(|r| map.get(r).map(|c| (*r, *c)))
                .collect()
        };
        let answers = if tick == self.tick {
            // The world is dropping what this host sends: the rest of the tick takes the lane
            // the world keeps for resends.
            self.lane = true;
            held(&self.answered, answers)
        } else {
            Vec::new()
        };
        let hellos = held(&self.hellos, hellos);
        if answers.is_empty() && hellos.is_empty() {
            // Nothing sent yet of what was asked: it goes up when it comes.
            return Ok(());
        }
        stats.resent += (answers.len() + hellos.len()) as u64;
        send(
            &Up::Resent {
                tick,
                answers,
                hellos,
            },
            stats,
        )
    }

    /// A fault the orchestrator ordered for one of this host's robots. A killed robot's
    /// hello is no longer resent, nor is its publisher bound; a restarted one waits for the
    /// fresh process's hello.
    fn order(&mut self, c: HostControl) -> std::io::Result<()> {
        let HostControl::Fault(fault) = c else {
            return Ok(());
        };
        let robot = fault.robot();
        match fault {
            ProcessFault::Kill { .. } => {
                self.hellos.remove(&robot);
                self.bindings.forget(robot);
            }
            ProcessFault::Restart { .. } => {
                self.hellos.remove(&robot);
                self.bindings.expect_hello(robot);
            }
            ProcessFault::Freeze { .. } | ProcessFault::Thaw { .. } => {}
        }
        self.on(Event::Fault(fault))
    }

    /// Tells the supervisor `event` and carries out its orders; a robot that cannot be
    /// started fails the host.
    fn on(&mut self, event: Event) -> std::io::Result<()> {
        launch::handle(&mut self.sup, event, &mut self.shell)
    }
}

/// This host's side of the supervisor's orders: robots start with reapers reporting on the
/// main loop's channel, and each start and end is reported to the orchestrator.
struct HostShell<'a> {
    node: &'a Node<ipc::Svc>,
    /// Where the robots' reapers report.
    tx: Sender<Msg>,
    launch: Launch,
}

impl ShellSide for HostShell<'_> {
    type Error = std::io::Error;

    fn spawn(&mut self, robot: u32, incarnation: u32) -> std::io::Result<Pid> {
        let tx = self.tx.clone();
        launch::spawn(&self.launch, robot, incarnation, move |pid, how| {
            let _ = tx.send(Msg::Exited(pid, how));
        })
    }

    fn started(&mut self, robot: u32, incarnation: u32, pid: Pid) {
        report(&HostReport::Started {
            robot,
            incarnation,
            pid,
        });
    }

    fn not_started(&mut self, _: u32, _: u32, e: std::io::Error) -> std::io::Result<()> {
        Err(e)
    }

    fn ended(&mut self, e: Ended) {
        // Its ports go, returning the observation samples it held.
        let _ = self.node.try_cleanup_dead_nodes();
        report(&HostReport::Exited {
            robot: e.robot,
            pid: e.pid,
            how: e.how,
            ordered: e.ordered,
        });
    }
}

/// Test hook (feature `misbehave`, test builds only): `SWARMRT_TEST_HOST_FLOOD=<host>`
/// makes host `<host>` flood the world with valid empty batches on its own up key, from a
/// thread of its own, from its join to its end: the attack of a host holding a valid
/// certificate (issue 48, `tests/tests/e2e/multihost.rs`).
#[cfg(feature = "misbehave")]
pub const FLOOD_ENV: &str = "SWARMRT_TEST_HOST_FLOOD";

/// The flooding thread of [`FLOOD_ENV`]; stopped when dropped.
#[cfg(feature = "misbehave")]
struct Flood {
    stop: std::sync::Arc<std::sync::atomic::AtomicBool>,
    thread: Option<std::thread::JoinHandle<u64>>,
}

#[cfg(feature = "misbehave")]
impl Flood {
    fn from_env(session: &zenoh::Session, run_id: &str, host: &str) -> Option<Flood> {
        use std::sync::atomic::{AtomicBool, Ordering};
        if std::env::var(FLOOD_ENV).ok()? != host {
            return None;
        }
        // Not express: Zenoh batches the small messages, as fast as the link goes.
        let up = session
            .declare_publisher(link::up_key(run_id, host))
            .congestion_control(zenoh::qos::CongestionControl::Block)
            .wait()
            .ok()?;
        let stop = std::sync::Arc::new(AtomicBool::new(false));
        let flag = stop.clone();
        let empty = Up::Commands(Vec::new()).encode();
        let thread = std::thread::spawn(move || {
            let mut sent = 0u64;
            while !flag.load(Ordering::Relaxed) && up.put(empty.clone()).wait().is_ok() {
                sent += 1;
            }
            sent
        });
        Some(Flood {
            stop,
            thread: Some(thread),
        })
    }
}

#[cfg(feature = "misbehave")]
impl Drop for Flood {
    fn drop(&mut self) {
        self.stop.store(true, std::sync::atomic::Ordering::Relaxed);
        if let Some(sent) = self.thread.take().and_then(|t| t.join().ok()) {
            tracing::debug!(sent, "flood stopped");
        }
    }
}
