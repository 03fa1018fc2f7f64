//! Multi-process mode: spawn the world and one process per robot, watch them, tell the world
//! when a robot dies, stop everything cleanly on completion, Ctrl-C or a crashed child, and
//! remove the run's iceoryx2 resources on every path.
//!
//! Threads feed one channel the main loop sleeps on: the world's stdout reader (reports), one
//! small reaper per child (`waitpid` on exactly that child, so iceoryx2 never sees zombies)
//! and the Ctrl-C relay. No polling.

use std::collections::{BTreeMap, BTreeSet};
use std::io::{BufRead, BufReader, Write};
use std::path::{Path, PathBuf};
use std::process::{ChildStdin, Stdio};
use std::time::{Duration, Instant};

use anyhow::{Context, bail};
use crossbeam_channel::{Receiver, Sender};
use swarmrt_protocol::control::{Control, HostControl, HostReport, WorldReport};
use swarmrt_protocol::services::RunServices;
use swarmrt_scenario::Config;

use crate::hosts::{HostMsg, Remotes, RunHosts};
use swarmrt_ipc::cleanup;
pub use swarmrt_scenario::process::{child_command, describe, signal_all};

/// How long robots get to exit on the world's shutdown sample before they are sent SIGTERM
/// (a robot that subscribed after that sample never sees it). The wait ends as soon as all
/// have gone; 3 s because a robot thawed from a freeze on a loaded 2-core machine took more
/// than 1 s to be scheduled, see its shutdown and exit (`tests/tests/faults.rs`, under the
/// whole test suite).
const SHUTDOWN_GRACE: Duration = Duration::from_secs(3);
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

/// Finds `swarm-world` / `swarm-agent` beside the running executable.
pub fn sibling_binary(name: &str) -> anyhow::Result<PathBuf> {
    let exe = std::env::current_exe().context("cannot locate the swarm executable")?;
    let dir = exe.parent().context("executable has no directory")?;
    let p = dir.join(name);
    if p.exists() {
        return Ok(p);
    }
    // `cargo test` runs from target/<profile>/deps/.
    if let Some(up) = dir.parent() {
        let p = up.join(name);
        if p.exists() {
            return Ok(p);
        }
    }
    bail!(
        "cannot find {name} beside {}; build the whole workspace (cargo build --release)",
        exe.display()
    )
}

/// Reaps one child: a small thread blocked in `waitpid(pid)`, so iceoryx2 never sees a zombie
/// and a run never reaps a process that is not its own (an orchestrator may run several runs,
/// as `swarm bench swarm` does, or have other children).
///
/// With `after`, the exit is reported only once that channel's senders are gone (or
/// [`LAUNCHER_EOF_WAIT`] later): a host launcher's stdout reader holds one, so the host's last
/// report (`Done`) is on the channel before its exit. Without it, the exit of a launcher that
/// finished could be judged first and the host called lost (`multihost::three_hosts...`,
/// 1 run in ~10).
fn reap(pid: i32, tx: Sender<Msg>, after: Option<Receiver<()>>) -> std::io::Result<()> {
    std::thread::Builder::new()
        .name(format!("reap-{pid}"))
        .stack_size(64 * 1024)
        .spawn(move || {
            loop {
                let mut status = 0;
                // SAFETY: waitpid on our own child, writing only `status`.
                let r = unsafe { libc::waitpid(pid, &mut status, 0) };
                let how = if r == pid {
                    describe(status)
                } else if std::io::Error::last_os_error().raw_os_error() == Some(libc::EINTR) {
                    continue;
                } else {
                    format!(
                        "could not be waited for: {}",
                        std::io::Error::last_os_error()
                    )
                };
                if let Some(after) = &after {
                    let _ = after.recv_timeout(LAUNCHER_EOF_WAIT);
                }
                let _ = tx.send(Msg::Exited { pid, how });
                return;
            }
        })
        .map(|_| ())
}

/// Starts a robot's reaper; if even that fails, the robot is killed and reaped here so it
/// cannot outlive the run unseen.
fn reap_robot(pid: i32, tx: &Sender<Msg>) -> std::io::Result<()> {
    reap(pid, tx.clone(), None).inspect_err(|_| {
        signal_all(&[pid], libc::SIGKILL);
        let mut status = 0;
        // SAFETY: as in `reap`; the child was just sent SIGKILL, so this returns promptly.
        unsafe { libc::waitpid(pid, &mut status, 0) };
    })
}

/// The process currently running `robot`: after a restart the old one may not be reaped yet.
fn live_pid(
    robots: &BTreeMap<i32, u32>,
    scheduled_kills: &BTreeSet<i32>,
    robot: u32,
) -> Option<i32> {
    robots
        .iter()
        .find(|(pid, id)| **id == robot && !scheduled_kills.contains(pid))
        .map(|(&pid, _)| pid)
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
    dir: &Path,
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
}

/// [`run`] with `opts`.
pub fn run_on_hosts(
    cfg: &Config,
    config_path: &Path,
    dir: &Path,
    opts: &RunOptions,
    interrupt: Receiver<()>,
    mut progress: impl FnMut(u64),
) -> anyhow::Result<ProcessOutcome> {
    let run_id = new_run_id();
    let run = RunServices::new(&run_id);
    cleanup::claim(&run_id).context("cannot create the run's iceoryx2 directory")?;
    let result = supervise(cfg, config_path, dir, opts, &run, interrupt, &mut progress);
    let removed = cleanup::remove_run(&run_id);
    tracing::debug!(run_id, removed, "run resources removed");
    result.map(|mut o| {
        o.run_id = run_id;
        o
    })
}

fn supervise(
    cfg: &Config,
    config_path: &Path,
    dir: &Path,
    opts: &RunOptions,
    run: &RunServices,
    interrupt: Receiver<()>,
    progress: &mut impl FnMut(u64),
) -> anyhow::Result<ProcessOutcome> {
    let hosts = opts.hosts;
    let world_bin = sibling_binary("swarm-world")?;
    let agent_bin = sibling_binary("swarm-agent")?;
    // iceoryx2's tools read `config/iceoryx2.toml` from their working directory, so
    // `cd <run dir> && iox2 service list` sees this run; robot programs load it too.
    let ipc_config = dir.join(crate::run_dir::IPC_CONFIG);
    swarmrt_ipc::write_config_file(run, &ipc_config)
        .map_err(|e| anyhow::anyhow!("cannot write {}: {e}", ipc_config.display()))?;
    let n = cfg.robots.count;
    let mut outcome = ProcessOutcome::default();
    let (tx, rx) = crossbeam_channel::unbounded::<Msg>();

    let interrupted_flag = std::sync::Arc::new(std::sync::atomic::AtomicBool::new(false));
    // Dropped when this function returns: the relay thread ends with the run, so it never
    // swallows a Ctrl-C meant for a later run in the same process.
    let (_run_over, run_over) = crossbeam_channel::bounded::<()>(0);
    {
        let tx = tx.clone();
        let flag = interrupted_flag.clone();
        std::thread::spawn(move || {
            loop {
                crossbeam_channel::select! {
                    recv(interrupt) -> r => {
                        if r.is_err() {
                            return;
                        }
                        flag.store(true, std::sync::atomic::Ordering::SeqCst);
                        if tx.send(Msg::Interrupt).is_err() {
                            return;
                        }
                    }
                    recv(run_over) -> _ => return,
                }
            }
        });
    }

    let mut world_cmd = child_command(&world_bin);
    world_cmd
        .args(["--run-id", run.run_id(), "--config"])
        .arg(config_path)
        .arg("--out")
        .arg(dir);
    if let Some(h) = hosts {
        world_cmd.arg("--hosts").arg(&h.path);
    }
    if opts.realtime {
        world_cmd.arg("--realtime");
    }
    let mut world = world_cmd
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .spawn()
        .with_context(|| format!("cannot start {}", world_bin.display()))?;
    let world_pid = world.id() as i32;
    let mut world_stdin = world.stdin.take();
    let world_stdout = world.stdout.take().context("world stdout")?;
    {
        let tx = tx.clone();
        std::thread::spawn(move || {
            for line in BufReader::new(world_stdout).lines() {
                let Ok(line) = line else { break };
                match serde_json::from_str::<WorldReport>(&line) {
                    Ok(r) => {
                        if tx.send(Msg::Report(r)).is_err() {
                            return;
                        }
                    }
                    Err(_) => tracing::warn!("world said: {line}"),
                }
            }
            let _ = tx.send(Msg::WorldEof);
        });
    }
    if let Err(e) = reap(world_pid, tx.clone(), None) {
        signal_all(&[world_pid], libc::SIGKILL);
        let _ = world.wait();
        bail!("cannot watch the world process: {e}");
    }

    // Robots start once the world's services exist.
    let mut world_alive = true;
    let mut listening = false;
    while !listening {
        match rx.recv()? {
            Msg::Report(WorldReport::Listening) => listening = true,
            Msg::Report(r) => tracing::debug!(?r, "early report"),
            Msg::WorldEof => {}
            Msg::Exited { pid, how } if pid == world_pid => {
                bail!(
                    "the world process failed before the run started ({how}); see its error above"
                )
            }
            Msg::Exited { .. } | Msg::Host(..) => {}
            Msg::Interrupt => {
                signal_all(&[world_pid], libc::SIGTERM);
                outcome.interrupted = true;
                wait_for_exit(
                    &rx,
                    &[world_pid],
                    &mut BTreeMap::new(),
                    Duration::ZERO,
                    |_| {},
                );
                return Ok(outcome);
            }
        }
    }
    // Remote hosts start now too: the world's Zenoh session is listening.
    let mut remotes = match hosts {
        None => None,
        Some(h) => {
            match Remotes::launch(
                &h.file,
                run.run_id(),
                config_path,
                &tx,
                Msg::Host,
                |pid, eof| reap(pid, tx.clone(), Some(eof)),
            ) {
                Ok(r) => Some(r),
                Err(e) => {
                    send_control(&mut world_stdin, &Control::Stop);
                    wait_for_exit(
                        &rx,
                        &[world_pid],
                        &mut BTreeMap::new(),
                        SHUTDOWN_GRACE,
                        |_| {},
                    );
                    return Err(e);
                }
            }
        }
    };
    // Stable storage of the robots' persistent Raft state, for restarts (`consensus.storage`).
    let storage = dir.join(crate::run_dir::STORAGE_DIR);
    let spawn_robot = |id: u32, incarnation: u32| {
        // A robot program gets swarm-agent's arguments after its own, and the run's names
        // in its environment (docs/robot-interface.md).
        let mut cmd = match swarmrt_scenario::program::program_of(cfg, id) {
            None => child_command(&agent_bin),
            Some((_, argv)) => {
                let mut c = child_command(Path::new(&argv[0]));
                c.args(&argv[1..]);
                c
            }
        };
        cmd.envs(run.robot_env(id, incarnation, config_path, &storage, 0, &ipc_config))
            .args([
                "--run-id",
                run.run_id(),
                "--robot",
                &id.to_string(),
                "--incarnation",
                &incarnation.to_string(),
                "--config",
            ])
            .arg(config_path)
            .arg("--storage")
            .arg(&storage)
            .stdin(Stdio::null())
            .spawn()
            .and_then(|c| reap_robot(c.id() as i32, &tx).map(|()| c))
    };
    let mut robots: BTreeMap<i32, u32> = BTreeMap::new();
    // (pid, robot, incarnation) of every robot process, and how each ended.
    let mut started: Vec<(i32, u32, u32)> = Vec::new();
    let mut ended: BTreeMap<i32, String> = BTreeMap::new();
    for id in 0..n {
        if remotes.as_ref().is_some_and(|r| r.host_of(id).is_some()) {
            continue;
        }
        if interrupted_flag.load(std::sync::atomic::Ordering::SeqCst) {
            // Ctrl-C during start-up: start no more robots; the main loop stops the world.
            break;
        }
        match spawn_robot(id, 0) {
            Ok(c) => {
                robots.insert(c.id() as i32, id);
                started.push((c.id() as i32, id, 0));
            }
            Err(e) => {
                tracing::error!(robot = id, "cannot start robot: {e}");
                outcome
                    .unscheduled_deaths
                    .insert(id, format!("failed to start: {e}"));
                send_control(
                    &mut world_stdin,
                    &Control::RobotDied {
                        robot: id,
                        reason: "failed to start".to_string(),
                    },
                );
            }
        }
    }

    // Supervise until the world reports the end. The world's exit (from the reaper) and its
    // last report (from the stdout reader) race on the channel, so its end is judged only
    // once both its exit and the EOF of its stdout have arrived.
    let mut done = false;
    let mut world_eof = false;
    let mut world_exit: Option<String> = None;
    let mut interrupts = 0;
    // Processes the fault schedule killed (for a kill or a restart): their end is no death.
    let mut scheduled_kills: BTreeSet<i32> = BTreeSet::new();
    // Processes the fault schedule stopped; they get SIGCONT before any shutdown.
    let mut frozen: BTreeSet<i32> = BTreeSet::new();
    // Remote robot processes: (host, pid) -> (robot, incarnation), and how each ended.
    let mut remote_started: RemoteStarts = Vec::new();
    let mut remote_ended: RemoteEnds = BTreeMap::new();
    let mut ready = false;
    // A host that failed before tick 0 fails the run.
    let mut startup_failure: Option<crate::hosts::HostFailure> = None;
    while !done {
        let msg = rx.recv()?;
        // A fault or a death of a robot on a remote host: ordered through its swarm-host.
        if let (Some(r), Msg::Report(report)) = (remotes.as_mut(), &msg)
            && let Some((robot, order)) = remote_order(report)
            && let Some(host) = r.host_of(robot)
        {
            if let WorldReport::Unresponsive { waited_ms, .. } = report {
                outcome.unscheduled_deaths.insert(
                    robot,
                    format!("unresponsive for {waited_ms} ms (on host {})", r.name(host)),
                );
            }
            r.order(host, &order);
            continue;
        }
        match msg {
            Msg::Report(WorldReport::Ready { startup_ms }) => {
                ready = true;
                outcome.startup_ms = Some(startup_ms);
            }
            Msg::Report(WorldReport::Tick { tick }) => progress(tick),
            Msg::Report(WorldReport::Kill { robot }) => {
                // A scheduled kill: the world counts the robot dead already; the real signal
                // exercises the crash path.
                if let Some(pid) = live_pid(&robots, &scheduled_kills, robot) {
                    scheduled_kills.insert(pid);
                    frozen.remove(&pid);
                    signal_all(&[pid], libc::SIGKILL);
                }
            }
            Msg::Report(WorldReport::Freeze { robot }) => {
                if let Some(pid) = live_pid(&robots, &scheduled_kills, robot) {
                    frozen.insert(pid);
                    signal_all(&[pid], libc::SIGSTOP);
                }
            }
            Msg::Report(WorldReport::Thaw { robot }) => {
                if let Some(pid) = live_pid(&robots, &scheduled_kills, robot) {
                    frozen.remove(&pid);
                    signal_all(&[pid], libc::SIGCONT);
                }
            }
            Msg::Report(WorldReport::Restart { robot, incarnation }) => {
                // The world waits for the fresh process's hello before the robot rejoins, so
                // how long this takes changes nothing in the records.
                if let Some(pid) = live_pid(&robots, &scheduled_kills, robot) {
                    scheduled_kills.insert(pid);
                    frozen.remove(&pid);
                    signal_all(&[pid], libc::SIGKILL);
                }
                match spawn_robot(robot, incarnation) {
                    Ok(c) => {
                        robots.insert(c.id() as i32, robot);
                        started.push((c.id() as i32, robot, incarnation));
                    }
                    Err(e) => {
                        tracing::error!(robot, "cannot restart robot: {e}");
                        outcome
                            .unscheduled_deaths
                            .insert(robot, format!("failed to restart: {e}"));
                        send_control(
                            &mut world_stdin,
                            &Control::RobotDied {
                                robot,
                                reason: "failed to restart".to_string(),
                            },
                        );
                    }
                }
            }
            Msg::Report(WorldReport::Unresponsive { robot, waited_ms }) => {
                // Unscheduled: recorded as a death when the reaper reports the exit.
                if let Some(pid) = live_pid(&robots, &scheduled_kills, robot) {
                    tracing::warn!(robot, waited_ms, "robot unresponsive; killing it");
                    frozen.remove(&pid);
                    signal_all(&[pid], libc::SIGKILL);
                }
            }
            Msg::Report(WorldReport::Done {
                interrupted,
                metrics,
            }) => {
                outcome.interrupted |= interrupted;
                outcome.world_metrics = Some(metrics);
                done = true;
            }
            Msg::Report(WorldReport::Listening) => {}
            Msg::WorldEof => world_eof = true,
            Msg::Exited { pid, how }
                if remotes.as_ref().is_some_and(|r| r.by_pid(pid).is_some()) =>
            {
                let r = remotes.as_mut().expect("checked");
                let host = r.by_pid(pid).expect("checked");
                let why = r.ended(host, &how);
                let failure = &mut startup_failure;
                lose_host(r, host, why, ready, failure, &mut outcome, &mut world_stdin);
            }
            Msg::Exited { pid, how } => {
                if pid == world_pid {
                    world_alive = false;
                    world_exit = Some(how);
                } else if let Some(id) = robots.remove(&pid) {
                    frozen.remove(&pid);
                    ended.insert(pid, how.clone());
                    let scheduled = scheduled_kills.contains(&pid);
                    robot_ended(id, &how, scheduled, &mut outcome, &mut world_stdin);
                }
            }
            Msg::Host(host, HostMsg::Report(report)) => {
                let Some(r) = remotes.as_mut() else { continue };
                r.note(host, &report);
                if let Some((robot, how, ordered)) =
                    record_remote(host, &report, &mut remote_started, &mut remote_ended)
                {
                    robot_ended(robot, &how, ordered, &mut outcome, &mut world_stdin);
                }
                if let HostReport::Failed { .. } = report {
                    let why = r.lost(host).map(str::to_string);
                    let failure = &mut startup_failure;
                    lose_host(r, host, why, ready, failure, &mut outcome, &mut world_stdin);
                }
            }
            Msg::Host(_, HostMsg::Eof) => {}
            Msg::Report(WorldReport::HostLost { host, robots }) => {
                if let Some(r) = remotes.as_mut() {
                    r.link_lost(&host);
                }
                for robot in robots {
                    outcome
                        .unscheduled_deaths
                        .entry(robot)
                        .or_insert_with(|| format!("host {host} lost"));
                }
            }
            Msg::Interrupt => {
                interrupts += 1;
                outcome.interrupted = true;
                if interrupts == 1 {
                    tracing::warn!("stopping the run (Ctrl-C again to kill it)");
                    send_control(&mut world_stdin, &Control::Stop);
                } else {
                    let mut all: Vec<i32> = robots.keys().copied().collect();
                    all.push(world_pid);
                    signal_all(&all, libc::SIGKILL);
                    frozen.clear();
                }
            }
        }
        if startup_failure.is_some() && !done {
            // Stop the world and the other hosts; the error is returned below.
            send_control(&mut world_stdin, &Control::Stop);
            if let Some(r) = remotes.as_mut() {
                r.stop_all();
            }
            done = true;
        }
        if !done
            && world_eof
            && let Some(how) = &world_exit
        {
            outcome.world_failure = Some(format!("world process {how} before finishing"));
            done = true;
        }
    }
    drop(world_stdin);
    // A stopped process can neither see the shutdown sample nor act on SIGTERM.
    signal_all(&frozen.iter().copied().collect::<Vec<_>>(), libc::SIGCONT);

    // The world told robots to exit (or died): give them a moment to go by themselves, then
    // SIGTERM, then SIGKILL.
    let mut remaining: Vec<i32> = robots.keys().copied().collect();
    if world_alive {
        remaining.push(world_pid);
    }
    let grace = if world_alive {
        SHUTDOWN_GRACE
    } else {
        Duration::ZERO
    };
    if let Some(r) = remotes.as_ref() {
        // Each host sees its robots out after the world's shutdown, then exits.
        remaining.extend(r.running());
    }
    let mut launcher_ends: BTreeMap<i32, String> = BTreeMap::new();
    wait_for_exit(&rx, &remaining, &mut ended, grace, |m| {
        if let (Msg::Host(host, HostMsg::Report(report)), Some(r)) = (m, remotes.as_mut()) {
            r.note(host, &report);
            record_remote(host, &report, &mut remote_started, &mut remote_ended);
        }
    });
    if let Some(r) = remotes.as_ref() {
        for pid in r.pids() {
            if let Some(how) = ended.remove(&pid) {
                launcher_ends.insert(pid, how);
            }
        }
        let unclean = r.clean(run.run_id());
        if !unclean.is_empty() {
            tracing::warn!(?unclean, "hosts whose resources could not be removed");
        }
        outcome.hosts = Some(r.stats());
    }
    tracing::debug!(?launcher_ends, "hosts ended");
    outcome.processes = started
        .into_iter()
        .map(|(pid, robot, incarnation)| RobotProcess {
            robot,
            incarnation,
            pid,
            end: ended
                .remove(&pid)
                .unwrap_or_else(|| "not reaped".to_string()),
            scheduled_kill: scheduled_kills.contains(&pid),
            host: None,
        })
        .collect();
    if let Some(r) = remotes.as_ref() {
        for (host, pid, robot, incarnation) in remote_started {
            let (end, ordered) = remote_ended
                .remove(&(host, pid))
                .unwrap_or_else(|| ("not reaped".to_string(), false));
            outcome.processes.push(RobotProcess {
                robot,
                incarnation,
                pid,
                end,
                scheduled_kill: ordered && !outcome.unscheduled_deaths.contains_key(&robot),
                host: Some(r.name(host).to_string()),
            });
        }
    }
    if let Some(f) = startup_failure {
        return Err(f.into());
    }
    Ok(outcome)
}

/// Waits until every pid in `pids` has been reaped, noting how each ended in `ended`: after
/// `grace` the rest get SIGTERM, after a further [`EXIT_GRACE`] SIGKILL. Ctrl-C while waiting
/// kills at once.
fn wait_for_exit(
    rx: &Receiver<Msg>,
    pids: &[i32],
    ended: &mut BTreeMap<i32, String>,
    grace: Duration,
    mut other: impl FnMut(Msg),
) {
    let mut left: std::collections::BTreeSet<i32> = pids.iter().copied().collect();
    let mut stage = 0; // 0: waiting, 1: SIGTERM sent, 2: SIGKILL sent
    let mut deadline = Instant::now() + grace;
    while !left.is_empty() {
        let wait = deadline.saturating_duration_since(Instant::now());
        let pending: Vec<i32> = left.iter().copied().collect();
        match rx.recv_timeout(wait) {
            Ok(Msg::Exited { pid, how }) => {
                left.remove(&pid);
                ended.insert(pid, how);
            }
            Ok(Msg::Interrupt) => {
                signal_all(&pending, libc::SIGKILL);
                stage = 2;
                deadline = Instant::now() + EXIT_GRACE;
            }
            Ok(m) => other(m),
            Err(crossbeam_channel::RecvTimeoutError::Timeout) if stage == 0 => {
                tracing::debug!(
                    count = left.len(),
                    "processes still running; sending SIGTERM"
                );
                signal_all(&pending, libc::SIGTERM);
                // A process stopped from outside acts on SIGTERM only once continued.
                signal_all(&pending, libc::SIGCONT);
                stage = 1;
                deadline = Instant::now() + EXIT_GRACE;
            }
            Err(crossbeam_channel::RecvTimeoutError::Timeout) if stage == 1 => {
                tracing::warn!(
                    count = left.len(),
                    pids = ?pending,
                    "processes did not exit in time; killing them"
                );
                signal_all(&pending, libc::SIGKILL);
                stage = 2;
                deadline = Instant::now() + EXIT_GRACE;
            }
            Err(_) => {
                tracing::error!(count = left.len(), "processes could not be reaped");
                return;
            }
        }
    }
}

/// The order for a remote robot's swarm-host that a world report asks for, if any.
fn remote_order(r: &WorldReport) -> Option<(u32, HostControl)> {
    Some(match *r {
        WorldReport::Kill { robot } => (robot, HostControl::Kill { robot }),
        WorldReport::Freeze { robot } => (robot, HostControl::Freeze { robot }),
        WorldReport::Thaw { robot } => (robot, HostControl::Thaw { robot }),
        WorldReport::Restart { robot, incarnation } => {
            (robot, HostControl::Restart { robot, incarnation })
        }
        WorldReport::Unresponsive { robot, .. } => (robot, HostControl::Kill { robot }),
        _ => return None,
    })
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
