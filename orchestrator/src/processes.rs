//! Multi-process mode: spawn the world and one process per robot, watch them, tell the world
//! when a robot dies, stop everything cleanly on completion, Ctrl-C or a crashed child, and
//! remove the run's iceoryx2 resources on every path.
//!
//! Threads feed one channel the main loop sleeps on: the world's stdout reader (reports), one
//! small reaper per child (`waitpid` on exactly that child, so iceoryx2 never sees zombies)
//! and the Ctrl-C relay. No polling.

use std::collections::BTreeMap;
use std::io::Write;
use std::path::Path;
use std::process::{ChildStdin, ChildStdout, Stdio};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};
use swarmrt_scenario::safe_fs::OutDir;

use anyhow::{Context, bail};
use crossbeam_channel::{Receiver, Sender};
use swarmrt_protocol::control::{Control, HostControl, HostReport, ProcessFault, WorldReport};
use swarmrt_protocol::services::RunServices;
use swarmrt_scenario::Config;

use crate::hosts::{HostMsg, Remotes, RunHosts};
use swarmrt_ipc::cleanup;
use swarmrt_runtime::supervisor::launch::{self, Launch};
use swarmrt_runtime::supervisor::{Order, Pid, Reaped, Supervisor};
pub use swarmrt_scenario::process::{child_command, describe, signal_all};

/// How long robots get to exit on the world's shutdown sample before they are sent SIGTERM
/// (a robot that subscribed after that sample never sees it). The wait ends as soon as all
/// have gone, so only a robot that missed the sample pays it: 10 s leaves a loaded 2-core
/// machine room (a thawed robot once took more than 1 s there, `tests/tests/faults.rs`).
const SHUTDOWN_GRACE: Duration = Duration::from_secs(10);
/// How long a host launcher's exit waits for the end of its stdout, which a process it
/// started may still hold open.
const LAUNCHER_EOF_WAIT: Duration = Duration::from_secs(2);
/// How long children get after SIGTERM before they are killed.
const EXIT_GRACE: Duration = Duration::from_secs(10);

/// How `describe` renders a robot's clean exit after the world's shutdown sample.
const CLEAN_EXIT: &str = "exited with code 0";

/// What the supervisor learned about a run.
#[derive(Debug, Default)]
pub struct ProcessOutcome {
    /// The world's final report, if it made one.
    pub world_metrics: Option<serde_json::Value>,
    /// True when the run ended early (Ctrl-C or a Stop).
    pub interrupted: bool,
    /// Set when the world itself failed; the run's records stop at its last tick.
    pub world_failure: Option<String>,
    /// Robots whose process ended before the run did, with how.
    pub unscheduled_deaths: BTreeMap<u32, String>,
    /// Milliseconds from the world listening until every robot said hello.
    pub startup_ms: Option<u64>,
    /// The run id naming the run's iceoryx2 resources.
    pub run_id: String,
    /// Every robot process started, in start order, with how it ended.
    pub processes: Vec<RobotProcess>,
    /// Each remote host's counters (`--hosts` runs).
    pub hosts: Option<serde_json::Value>,
}

/// One robot process of a run (`metrics.json` → `processes`).
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct RobotProcess {
    /// The robot it ran.
    pub robot: u32,
    /// 0 for the robot's first process, then one more per scheduled restart.
    pub incarnation: u32,
    /// Its pid.
    pub pid: i32,
    /// How it ended ("exited with code 0" after the world's shutdown sample).
    pub end: String,
    /// True when the fault schedule killed it (a kill or a restart).
    pub scheduled_kill: bool,
    /// The remote host it ran on (`--hosts` runs; its pid is that host's).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub host: Option<String>,
}

enum Msg {
    Report(WorldReport),
    Host(usize, HostMsg),
    WorldEof,
    Exited { pid: i32, how: String },
    Interrupt,
}

/// A fresh run id: random, used only in names (never in a decision).
pub fn new_run_id() -> String {
    use std::hash::{BuildHasher, RandomState};
    let h = RandomState::new().hash_one((std::process::id(), Instant::now()));
    format!("{:012x}", h & 0xffff_ffff_ffff)
}

pub use crate::binaries::sibling_binary;

/// The reaper's report of `pid`'s end, as a message on `tx`.
fn exited(tx: &Sender<Msg>) -> impl FnOnce(Pid, String) + Send + 'static {
    let tx = tx.clone();
    move |pid, how| {
        let _ = tx.send(Msg::Exited { pid, how });
    }
}

/// Handles a message while the run's processes are seen out: exits are reaped (a launcher's
/// end is only logged), host reports recorded, a Ctrl-C kills everything at once.
fn seeing_out(
    sup: &mut Supervisor,
    m: Msg,
    remotes: Option<&mut Remotes>,
    remote_started: &mut RemoteStarts,
    remote_ended: &mut RemoteEnds,
) {
    match m {
        Msg::Exited { pid, how } => {
            if let Reaped::Other { pid, how } = sup.reaped(pid, &how) {
                tracing::debug!(pid, how, "process ended");
            }
        }
        Msg::Interrupt => launch::send(&sup.kill_all()),
        Msg::Host(host, HostMsg::Report(report)) => {
            if let Some(r) = remotes {
                r.note(host, &report);
                record_remote(host, &report, remote_started, remote_ended);
            }
        }
        _ => {}
    }
}

fn send_control(stdin: &mut Option<ChildStdin>, c: &Control) {
    if let Some(s) = stdin.as_mut()
        && s.write_all(c.to_line().as_bytes())
            .and_then(|_| s.flush())
            .is_err()
    {
        *stdin = None;
    }
}

/// Runs `cfg` as processes; records go to `dir`. `progress` sees completed ticks.
pub fn run(
    cfg: &Config,
    config_path: &Path,
    dir: &OutDir,
    interrupt: Receiver<()>,
    progress: impl FnMut(u64),
) -> anyhow::Result<ProcessOutcome> {
    let opts = RunOptions::default();
    run_on_hosts(cfg, config_path, dir, &opts, interrupt, progress)
}

/// How a multi-process run differs from the default lock-step run on one host.
#[derive(Debug, Default)]
pub struct RunOptions<'a> {
    /// The robots a hosts file names run on other hosts (`swarm run --hosts`).
    pub hosts: Option<&'a RunHosts>,
    /// The world ticks by the wall clock and applies whatever commands arrived
    /// (`swarm run --realtime`).
    pub realtime: bool,
    /// The hosts file's `tcp/` endpoints are allowed (`swarm run --insecure-link`).
    pub insecure_link: bool,
}

/// [`run`] with `opts`.
pub fn run_on_hosts(
    cfg: &Config,
    config_path: &Path,
    dir: &OutDir,
    opts: &RunOptions,
    interrupt: Receiver<()>,
    mut progress: impl FnMut(u64),
) -> anyhow::Result<ProcessOutcome> {
    let run_id = new_run_id();
    let run = RunServices::new(&run_id);
    if let Err(e) = cleanup::claim(&run_id) {
        // A base swarm refuses is the user's to fix: its one line, typed for exit 2.
        if let Some(r) = cleanup::BaseRefused::of(&e) {
            return Err(r.clone().into());
        }
        return Err(anyhow::Error::new(e).context("cannot create the run's iceoryx2 directory"));
    }
    let result = supervise(cfg, config_path, dir, opts, &run, interrupt, &mut progress);
    let removed = cleanup::remove_run(&run_id);
    tracing::debug!(run_id, removed, "run resources removed");
    result.map(|mut o| {
        o.run_id = run_id;
        o
    })
}

/// The run's phases: the world starts and listens, the remote hosts and this host's robots
/// start, the world's reports drive the run until its end, then everything is seen out.
fn supervise(
    cfg: &Config,
    config_path: &Path,
    dir: &OutDir,
    opts: &RunOptions,
    run: &RunServices,
    interrupt: Receiver<()>,
    progress: &mut impl FnMut(u64),
) -> anyhow::Result<ProcessOutcome> {
    let world_bin = sibling_binary("swarm-world")?;
    let agent_bin = sibling_binary("swarm-agent")?;
    // iceoryx2's tools read `config/iceoryx2.toml` from their working directory, so
    // `cd <run dir> && iox2 service list` sees this run; robot programs load it too.
    let ipc_config = dir.join(crate::run_dir::IPC_CONFIG);
    swarmrt_ipc::config_file_text(run)
        .map_err(|e| anyhow::anyhow!("{e}"))
        .and_then(|text| {
            let sub = dir.create_subdir(crate::run_dir::IPC_CONFIG_DIR)?;
            Ok(sub.write("iceoryx2.toml", text)?)
        })
        .with_context(|| format!("cannot write {}", ipc_config.display()))?;
    let (tx, rx) = crossbeam_channel::unbounded::<Msg>();
    // Dropped when this function returns: the relay thread ends with the run, so it never
    // swallows a Ctrl-C meant for a later run in the same process.
    let (_run_over, interrupted) = relay_interrupts(interrupt, &tx);
    let (world_pid, world_stdin) = start_world(&world_bin, run, config_path, dir, opts, &tx)?;
    let launch = Launch {
        agent: agent_bin,
        run: run.clone(),
        config: config_path.to_path_buf(),
        // Stable storage of the robots' persistent Raft state, for restarts.
        storage: dir.join(crate::run_dir::STORAGE_DIR),
        first: 0,
        cfg: cfg.clone(),
        ipc_config,
        quiet: false,
    };
    let mut local = LocalRun::new(launch, tx, rx, world_pid, world_stdin);

    // Robots start once the world's services exist.
    if !local.await_listening()? {
        return Ok(local.outcome);
    }
    // Remote hosts start now too: the world's Zenoh session is listening.
    local.launch_remotes(opts.hosts, run.run_id(), config_path)?;
    local.start_robots(cfg.robots.count, &interrupted);

    // Supervise until the world reports the end. The world's exit (from the reaper) and its
    // last report (from the stdout reader) race on the channel, so its end is judged only
    // once both its exit and the EOF of its stdout have arrived.
    while !local.done {
        let msg = local.rx.recv()?;
        local.handle(msg, progress);
    }
    local.finish(run.run_id())
}

/// Relays Ctrl-C from `interrupt` to `tx` and raises the returned flag, until the returned
/// sender is dropped.
fn relay_interrupts(interrupt: Receiver<()>, tx: &Sender<Msg>) -> (Sender<()>, Arc<AtomicBool>) {
    let interrupted_flag = Arc::new(AtomicBool::new(false));
    let (run_over_tx, run_over) = crossbeam_channel::bounded::<()>(0);
    let tx = tx.clone();
    let flag = interrupted_flag.clone();
    std::thread::spawn(move || {
        loop {
            crossbeam_channel::select! {
                recv(interrupt) -> r => {
                    if r.is_err() {
                        return;
                    }
                    flag.store(true, Ordering::SeqCst);
                    if tx.send(Msg::Interrupt).is_err() {
                        return;
                    }
                }
                recv(run_over) -> _ => return,
            }
        }
    });
    (run_over_tx, interrupted_flag)
}

/// The `swarm-world` command of this run.
fn world_command(
    world_bin: &Path,
    run: &RunServices,
    config_path: &Path,
    dir: &OutDir,
    opts: &RunOptions,
) -> std::process::Command {
    let mut world_cmd = child_command(world_bin);
    world_cmd
        .args(["--run-id", run.run_id(), "--config"])
        .arg(config_path)
        .arg("--out")
        .arg(dir.path())
        // The world refuses any directory but the one checked here.
        .arg("--out-id")
        .arg(dir.id().to_string());
    if let Some(h) = opts.hosts {
        world_cmd.arg("--hosts").arg(&h.path);
        world_cmd.arg("--certs").arg(&h.file.certs);
    }
    if opts.insecure_link {
        world_cmd.arg("--insecure-link");
    }
    if opts.realtime {
        world_cmd.arg("--realtime");
    }
    world_cmd
}

/// Starts `swarm-world` with its stdout reader and its reaper, both reporting on `tx`;
/// returns its pid and stdin (its controls).
fn start_world(
    world_bin: &Path,
    run: &RunServices,
    config_path: &Path,
    dir: &OutDir,
    opts: &RunOptions,
    tx: &Sender<Msg>,
) -> anyhow::Result<(Pid, Option<ChildStdin>)> {
    let mut world = world_command(world_bin, run, config_path, dir, opts)
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .spawn()
        .with_context(|| format!("cannot start {}", world_bin.display()))?;
    let world_pid = world.id() as i32;
    let world_stdin = world.stdin.take();
    let world_stdout = world.stdout.take().context("world stdout")?;
    read_world_reports(world_stdout, tx);
    if let Err(e) = launch::reap(world_pid, None, exited(tx)) {
        signal_all(&[world_pid], libc::SIGKILL);
        let _ = world.wait();
        bail!("cannot watch the world process: {e}");
    }
    Ok((world_pid, world_stdin))
}

/// The world's stdout reader: each report line as a message on `tx`, then its EOF.
fn read_world_reports(world_stdout: ChildStdout, tx: &Sender<Msg>) {
    let (tx, eof) = (tx.clone(), tx.clone());
    swarmrt_ipc::lines::read_json_lines(
        world_stdout,
        "the world".into(),
        move |r: WorldReport| tx.send(Msg::Report(r)).is_ok(),
        move || {
            let _ = eof.send(Msg::WorldEof);
        },
    );
}

/// Handles a message while processes are seen out before any robot started: exits are reaped.
fn just_reap(sup: &mut Supervisor, m: Msg) {
    if let Msg::Exited { pid, how } = m {
        sup.reaped(pid, &how);
    }
}

/// One multi-process run as `supervise` drives it through its phases: the run's processes
/// (the world's, this host's robots', the remote hosts' launchers) and what was learned.
struct LocalRun {
    /// Every process of the run, robots and the others, in one table.
    sup: Supervisor,
    launch: Launch,
    tx: Sender<Msg>,
    rx: Receiver<Msg>,
    world_pid: Pid,
    /// The world's controls; `None` once it cannot be written to.
    world_stdin: Option<ChildStdin>,
    outcome: ProcessOutcome,
    remotes: Option<Remotes>,
    /// Remote robot processes: (host, pid) -> (robot, incarnation), and how each ended.
    remote_started: RemoteStarts,
    remote_ended: RemoteEnds,
    /// The main loop is over: the world reported the end, failed, or a host failed.
    done: bool,
    /// The world's stdout has ended.
    world_eof: bool,
    /// How the world's process ended, once reaped.
    world_exit: Option<String>,
    /// False once the world's process was reaped (a failed world's run ends with no grace).
    world_alive: bool,
    /// The world reported tick 0.
    ready: bool,
    /// Ctrl-Cs seen by the main loop.
    interrupts: u32,
    /// A host that failed before tick 0 fails the run.
    startup_failure: Option<crate::hosts::HostFailure>,
}

impl LocalRun {
    /// A run whose world runs as `world_pid` (watched with the rest).
    fn new(
        launch: Launch,
        tx: Sender<Msg>,
        rx: Receiver<Msg>,
        world_pid: Pid,
        world_stdin: Option<ChildStdin>,
    ) -> LocalRun {
        let mut sup = Supervisor::new();
        sup.watch(world_pid);
        LocalRun {
            sup,
            launch,
            tx,
            rx,
            world_pid,
            world_stdin,
            outcome: ProcessOutcome::default(),
            remotes: None,
            remote_started: Vec::new(),
            remote_ended: BTreeMap::new(),
            done: false,
            world_eof: false,
            world_exit: None,
            world_alive: true,
            ready: false,
            interrupts: 0,
            startup_failure: None,
        }
    }

    /// Waits for the world to listen. `false` when a Ctrl-C came first: the world was
    /// stopped and seen out, and the run is over.
    fn await_listening(&mut self) -> anyhow::Result<bool> {
        loop {
            match self.rx.recv()? {
                Msg::Report(WorldReport::Listening) => return Ok(true),
                Msg::Report(r) => tracing::debug!(?r, "early report"),
                Msg::WorldEof => {}
                Msg::Exited { pid, how } if pid == self.world_pid => {
                    bail!(
                        "the world process failed before the run started ({how}); see its error above"
                    )
                }
                Msg::Exited { .. } | Msg::Host(..) => {}
                Msg::Interrupt => {
                    signal_all(&[self.world_pid], libc::SIGTERM);
                    self.outcome.interrupted = true;
                    launch::see_out(
                        &mut self.sup,
                        &self.rx,
                        Duration::ZERO,
                        EXIT_GRACE,
                        just_reap,
                    );
                    return Ok(false);
                }
            }
        }
    }

    /// Starts the remote hosts (`--hosts` runs) and watches their launchers; if that fails,
    /// the world is stopped and seen out and the run fails.
    fn launch_remotes(
        &mut self,
        hosts: Option<&RunHosts>,
        run_id: &str,
        config_path: &Path,
    ) -> anyhow::Result<()> {
        let Some(h) = hosts else { return Ok(()) };
        let tx = &self.tx;
        let watch = |pid, eof| launch::reap(pid, Some((eof, LAUNCHER_EOF_WAIT)), exited(tx));
        match Remotes::launch(&h.file, run_id, config_path, tx, Msg::Host, watch) {
            Ok(r) => {
                r.pids().into_iter().for_each(|pid| self.sup.watch(pid));
                self.remotes = Some(r);
                Ok(())
            }
            Err(e) => {
                send_control(&mut self.world_stdin, &Control::Stop);
                launch::see_out(
                    &mut self.sup,
                    &self.rx,
                    SHUTDOWN_GRACE,
                    EXIT_GRACE,
                    just_reap,
                );
                Err(e)
            }
        }
    }

    /// Starts the first process of each of the `n` robots not on a remote host, in id order.
    fn start_robots(&mut self, n: u32, interrupted: &AtomicBool) {
        for id in 0..n {
            if self
                .remotes
                .as_ref()
                .is_some_and(|r| r.host_of(id).is_some())
            {
                continue;
            }
            if interrupted.load(Ordering::SeqCst) {
                // Ctrl-C during start-up: start no more robots; the main loop stops the world.
                break;
            }
            let Some(Order::Spawn { robot, incarnation }) = self.sup.spawn(id) else {
                break;
            };
            if let Err(e) = self.start_robot(robot, incarnation) {
                tracing::error!(robot = id, "cannot start robot: {e}");
                self.not_started(id, format!("failed to start: {e}"), "failed to start");
            }
        }
    }

    /// Starts `robot`'s process of `incarnation` and tells the supervisor.
    fn start_robot(&mut self, robot: u32, incarnation: u32) -> std::io::Result<()> {
        let pid = launch::spawn(&self.launch, robot, incarnation, exited(&self.tx))?;
        self.sup.started(robot, incarnation, pid);
        Ok(())
    }

    /// A robot process could not be started: an unscheduled death (`death`), and the world
    /// is told the robot died (`reason`).
    fn not_started(&mut self, robot: u32, death: String, reason: &str) {
        self.outcome.unscheduled_deaths.insert(robot, death);
        send_control(
            &mut self.world_stdin,
            &Control::RobotDied {
                robot,
                reason: reason.to_string(),
            },
        );
    }

    /// One message of the main loop; then whether the run must end.
    fn handle(&mut self, msg: Msg, progress: &mut impl FnMut(u64)) {
        if let Msg::Report(report) = &msg
            && self.order_remote(report)
        {
            return;
        }
        match msg {
            Msg::Report(WorldReport::Ready { startup_ms }) => {
                self.ready = true;
                self.outcome.startup_ms = Some(startup_ms);
            }
            Msg::Report(WorldReport::Tick { tick }) => progress(tick),
            // The schedule's faults: the world counts a killed robot dead already; the real
            // signal exercises the crash path.
            Msg::Report(WorldReport::Fault(fault)) => self.carry_out_fault(fault),
            Msg::Report(WorldReport::Unresponsive { robot, waited_ms }) => {
                // Unscheduled: recorded as a death when the reaper reports the exit.
                if let Some(order) = self.sup.kill_hung(robot) {
                    tracing::warn!(robot, waited_ms, "robot unresponsive; killing it");
                    launch::send(&order);
                }
            }
            Msg::Report(WorldReport::Done {
                interrupted,
                metrics,
            }) => {
                self.outcome.interrupted |= interrupted;
                self.outcome.world_metrics = Some(metrics);
                self.done = true;
            }
            Msg::Report(WorldReport::Listening) => {}
            Msg::WorldEof => self.world_eof = true,
            Msg::Exited { pid, how } => self.process_ended(pid, how),
            Msg::Host(host, HostMsg::Report(report)) => {
                // Host messages come only with remotes; without them nothing else is done.
                if self.remotes.is_none() {
                    return;
                }
                self.host_report(host, report);
            }
            Msg::Host(_, HostMsg::Eof) => {}
            Msg::Report(WorldReport::HostLost { host, robots }) => self.host_lost(&host, robots),
            Msg::Interrupt => self.interrupt(),
        }
        self.check_end();
    }

    /// A fault or a death of a robot on a remote host: ordered through its swarm-host. True
    /// when `report` was such an order.
    fn order_remote(&mut self, report: &WorldReport) -> bool {
        if let Some(r) = self.remotes.as_mut()
            && let Some((robot, order)) = remote_order(report)
            && let Some(host) = r.host_of(robot)
        {
            if let WorldReport::Unresponsive { waited_ms, .. } = report {
                self.outcome.unscheduled_deaths.insert(
                    robot,
                    format!("unresponsive for {waited_ms} ms (on host {})", r.name(host)),
                );
            }
            r.order(host, &order);
            return true;
        }
        false
    }

    /// A fault of the schedule on a robot of this host: the world counts a killed robot dead
    /// already; the real signal exercises the crash path. A restart's old process is killed
    /// on the order and a fresh one started.
    fn carry_out_fault(&mut self, fault: ProcessFault) {
        let orders = match fault {
            ProcessFault::Kill { robot } => self.sup.kill(robot).into_iter().collect(),
            ProcessFault::Freeze { robot } => self.sup.freeze(robot).into_iter().collect(),
            ProcessFault::Thaw { robot } => self.sup.thaw(robot).into_iter().collect(),
            ProcessFault::Restart { robot, incarnation } => self.sup.restart(robot, incarnation),
        };
        for order in orders {
            let Order::Spawn { robot, incarnation } = order else {
                launch::send(&order);
                continue;
            };
            if let Err(e) = self.start_robot(robot, incarnation) {
                tracing::error!(robot, "cannot restart robot: {e}");
                self.not_started(
                    robot,
                    format!("failed to restart: {e}"),
                    "failed to restart",
                );
            }
        }
    }

    /// `pid` was reaped: a robot's end is told to the world, the world's is noted, a host
    /// launcher's loses its host.
    fn process_ended(&mut self, pid: Pid, how: String) {
        match self.sup.reaped(pid, &how) {
            Reaped::Robot(e) => robot_ended(
                e.robot,
                &e.how,
                e.ordered,
                &mut self.outcome,
                &mut self.world_stdin,
            ),
            Reaped::Other { .. } if pid == self.world_pid => {
                self.world_alive = false;
                self.world_exit = Some(how);
            }
            Reaped::Other { .. } | Reaped::Unknown => {
                if let Some(r) = self.remotes.as_mut()
                    && let Some(host) = r.by_pid(pid)
                {
                    let why = r.ended(host, &how);
                    let failure = &mut self.startup_failure;
                    let (outcome, stdin) = (&mut self.outcome, &mut self.world_stdin);
                    lose_host(r, host, why, self.ready, failure, outcome, stdin);
                }
            }
        }
    }

    /// A remote host's report: a robot process's start or end, or the host's failure.
    fn host_report(&mut self, host: usize, report: HostReport) {
        let Some(r) = self.remotes.as_mut() else {
            return;
        };
        r.note(host, &report);
        if let Some((robot, how, ordered)) = record_remote(
            host,
            &report,
            &mut self.remote_started,
            &mut self.remote_ended,
        ) {
            robot_ended(
                robot,
                &how,
                ordered,
                &mut self.outcome,
                &mut self.world_stdin,
            );
        }
        if let HostReport::Failed { .. } = report {
            let why = r.lost(host).map(str::to_string);
            let failure = &mut self.startup_failure;
            let (outcome, stdin) = (&mut self.outcome, &mut self.world_stdin);
            lose_host(r, host, why, self.ready, failure, outcome, stdin);
        }
    }

    /// The world lost its link to `host`: its `robots` died, unless they already had.
    fn host_lost(&mut self, host: &str, robots: Vec<u32>) {
        if let Some(r) = self.remotes.as_mut() {
            r.link_lost(host);
        }
        for robot in robots {
            self.outcome
                .unscheduled_deaths
                .entry(robot)
                .or_insert_with(|| format!("host {host} lost"));
        }
    }

    /// Ctrl-C: the first stops the run through the world, the next kills everything.
    fn interrupt(&mut self) {
        self.interrupts += 1;
        self.outcome.interrupted = true;
        if self.interrupts == 1 {
            tracing::warn!("stopping the run (Ctrl-C again to kill it)");
            send_control(&mut self.world_stdin, &Control::Stop);
        } else {
            launch::send(&self.sup.kill_all());
        }
    }

    /// After each message: a host's start-up failure stops the run, and a world that exited
    /// and closed its stdout without reporting the end failed.
    fn check_end(&mut self) {
        if self.startup_failure.is_some() && !self.done {
            // Stop the world and the other hosts; `finish` returns the error.
            send_control(&mut self.world_stdin, &Control::Stop);
            if let Some(r) = self.remotes.as_mut() {
                r.stop_all();
            }
            self.done = true;
        }
        if !self.done
            && self.world_eof
            && let Some(how) = &self.world_exit
        {
            self.outcome.world_failure = Some(format!("world process {how} before finishing"));
            self.done = true;
        }
    }

    /// Sees the run's processes out, cleans the remote hosts and records every robot
    /// process; a host's start-up failure is the run's error.
    fn finish(mut self, run_id: &str) -> anyhow::Result<ProcessOutcome> {
        drop(self.world_stdin.take());
        // The world told robots to exit (or died): give them a moment to go by themselves,
        // then SIGTERM, then SIGKILL. Each host sees its robots out after the world's
        // shutdown, then exits; its launcher is watched with the rest. A world that already
        // exited cleanly did publish the shutdown (it is often reaped before this point, and
        // a robot thawed just then was SIGTERMed mid-exit): only a failed world gives none.
        let world_clean = self.world_exit.as_deref() == Some(CLEAN_EXIT);
        let grace = if self.world_alive || world_clean {
            SHUTDOWN_GRACE
        } else {
            Duration::ZERO
        };
        launch::see_out(&mut self.sup, &self.rx, grace, EXIT_GRACE, |sup, m| {
            let remotes = self.remotes.as_mut();
            seeing_out(
                sup,
                m,
                remotes,
                &mut self.remote_started,
                &mut self.remote_ended,
            )
        });
        if let Some(r) = self.remotes.as_ref() {
            let unclean = r.clean(run_id);
            if !unclean.is_empty() {
                tracing::warn!(?unclean, "hosts whose resources could not be removed");
            }
            self.outcome.hosts = Some(r.stats());
        }
        self.record_processes();
        if let Some(f) = self.startup_failure {
            return Err(f.into());
        }
        Ok(self.outcome)
    }

    /// Every robot process started, this host's in start order, then the remote hosts'.
    fn record_processes(&mut self) {
        self.outcome.processes = self
            .sup
            .processes()
            .iter()
            .map(|p| RobotProcess {
                robot: p.robot,
                incarnation: p.incarnation,
                pid: p.pid,
                end: p.end.clone().unwrap_or_else(|| "not reaped".to_string()),
                scheduled_kill: p.ordered,
                host: None,
            })
            .collect();
        let Some(r) = self.remotes.as_ref() else {
            return;
        };
        for (host, pid, robot, incarnation) in std::mem::take(&mut self.remote_started) {
            let (end, ordered) = self
                .remote_ended
                .remove(&(host, pid))
                .unwrap_or_else(|| ("not reaped".to_string(), false));
            let unscheduled = self.outcome.unscheduled_deaths.contains_key(&robot);
            self.outcome.processes.push(RobotProcess {
                robot,
                incarnation,
                pid,
                end,
                scheduled_kill: ordered && !unscheduled,
                host: Some(r.name(host).to_string()),
            });
        }
    }
}

/// The order for a remote robot's swarm-host that a world report asks for, if any.
fn remote_order(r: &WorldReport) -> Option<(u32, HostControl)> {
    match *r {
        WorldReport::Fault(fault) => Some((fault.robot(), HostControl::Fault(fault))),
        WorldReport::Unresponsive { robot, .. } => {
            Some((robot, HostControl::Fault(ProcessFault::Kill { robot })))
        }
        _ => None,
    }
}

/// A host is gone (`why`; `None` when it had finished or was lost already): before tick 0
/// that fails the run; afterwards its robots are dead from now on, an unscheduled death each.
fn lose_host(
    r: &mut Remotes,
    host: usize,
    why: Option<String>,
    ready: bool,
    startup_failure: &mut Option<crate::hosts::HostFailure>,
    outcome: &mut ProcessOutcome,
    world_stdin: &mut Option<ChildStdin>,
) {
    let Some(why) = why else { return };
    if !ready {
        startup_failure.get_or_insert(crate::hosts::HostFailure {
            host: r.name(host).to_string(),
            why: why.to_string(),
        });
        return;
    }
    tracing::warn!(host = r.name(host), "host lost: {why}");
    for robot in r.alive_robots(host) {
        let reason = format!("host {} lost: {why}", r.name(host));
        outcome
            .unscheduled_deaths
            .entry(robot)
            .or_insert(reason.clone());
        send_control(world_stdin, &Control::RobotDied { robot, reason });
    }
}

/// Remote robot processes: (host, pid, robot, incarnation) in start order.
type RemoteStarts = Vec<(usize, i32, u32, u32)>;
/// How each remote robot process ended: (host, pid) -> (how, killed on an order).
type RemoteEnds = BTreeMap<(usize, i32), (String, bool)>;

/// Notes a remote robot process's start or end; an end is returned (robot, how, ordered).
fn record_remote(
    host: usize,
    report: &HostReport,
    started: &mut RemoteStarts,
    ended: &mut RemoteEnds,
) -> Option<(u32, String, bool)> {
    match report {
        HostReport::Started {
            robot,
            incarnation,
            pid,
        } => {
            started.push((host, *pid, *robot, *incarnation));
            None
        }
        HostReport::Exited {
            robot,
            pid,
            how,
            ordered,
        } => {
            ended.insert((host, *pid), (how.clone(), *ordered));
            Some((*robot, how.clone(), *ordered))
        }
        _ => None,
    }
}

/// A robot process ended (`how`), here or on a remote host. A process the fault schedule
/// killed is no death: the world accounted for it at its tick and only reclaims its ports.
/// Otherwise the world is told, and any end but the clean one after the world's shutdown
/// sample (which can come before we see the world's Done) is an unscheduled death.
fn robot_ended(
    robot: u32,
    how: &str,
    scheduled: bool,
    outcome: &mut ProcessOutcome,
    world_stdin: &mut Option<ChildStdin>,
) {
    if scheduled {
        send_control(world_stdin, &Control::Reaped { robot });
        return;
    }
    if how != CLEAN_EXIT {
        tracing::warn!(robot, "robot process {how}");
        outcome.unscheduled_deaths.insert(robot, how.to_string());
    }
    send_control(
        world_stdin,
        &Control::RobotDied {
            robot,
            reason: format!("process {how}"),
        },
    );
}
