//! The I/O half of the [`Supervisor`]: a robot's command line (built here and nowhere else),
//! one reaper thread per child, the one [`carry_out`] of orders every shell uses (`swarm`,
//! `swarm-host`), and the shutdown wait.

use std::collections::VecDeque;
use std::path::PathBuf;
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use crossbeam_channel::{Receiver, RecvTimeoutError};
use swarmrt_protocol::services::RunServices;
use swarmrt_scenario::process::{child_command, describe, signal_all};

use super::{Ended, Event, Order, Pid, Signal, Stage, Supervisor};

/// How to start the robots of one host.
#[derive(Debug, Clone)]
pub struct Launch {
    /// The `swarm-agent` executable (robots without `robots.program`).
    pub agent: PathBuf,
    /// The run's names.
    pub run: RunServices,
    /// The run's config file on this host.
    pub config: PathBuf,
    /// Stable storage for the robots' Raft state (`consensus.storage`), across restarts.
    pub storage: PathBuf,
    /// The host's first robot id (its robots read slot `id - first`); 0 on the world's host.
    pub first: u32,
    /// The run's config (which program each robot runs).
    pub cfg: swarmrt_scenario::Config,
    /// The run's iceoryx2 config on this host, for robot programs.
    pub ipc_config: PathBuf,
    /// Robots' stdout goes nowhere (on a remote host the stdout carries its reports).
    pub quiet: bool,
}

/// The command line of `robot`'s process of `incarnation`. A robot program (`robots.program`)
/// gets swarm-agent's arguments after its own, and the run's names in its environment
/// (docs/robot-interface.md). A new robot flag is added here, once.
pub fn robot_command(l: &Launch, robot: u32, incarnation: u32) -> Command {
    let mut cmd = match swarmrt_scenario::program::program_of(&l.cfg, robot) {
        None => child_command(&l.agent),
        Some((_, argv)) => {
            let mut c = child_command(std::path::Path::new(&argv[0]));
            c.args(&argv[1..]);
            c
        }
    };
    cmd.envs(l.run.robot_env(
        robot,
        incarnation,
        &l.config,
        &l.storage,
        l.first,
        &l.ipc_config,
    ))
    .args(["--run-id", l.run.run_id(), "--robot", &robot.to_string()])
    .args(["--incarnation", &incarnation.to_string()])
    .args(["--slot-offset", &l.first.to_string(), "--config"])
    .arg(&l.config)
    .arg("--storage")
    .arg(&l.storage)
    .stdin(Stdio::null());
    if l.quiet {
        cmd.stdout(Stdio::null());
    }
    cmd
}

/// Starts `cmd` with its reaper; `exited(pid, how)` is called from the reaper when it ends.
/// The `Child` is returned for its pipes only: the reaper owns its end, so it is never waited
/// for (dropping it does not wait either).
pub fn start(
    cmd: &mut Command,
    exited: impl FnOnce(Pid, String) + Send + 'static,
) -> std::io::Result<Child> {
    let child = cmd.spawn()?;
    let pid = child.id() as Pid;
    reap(pid, None, exited).inspect_err(|_| {
        // No reaper: kill and reap it here so it cannot outlive the run unseen.
        signal_all(&[pid], libc::SIGKILL);
        let mut status = 0;
        // SAFETY: waitpid on our own child, just sent SIGKILL, so this returns promptly.
        unsafe { libc::waitpid(pid, &mut status, 0) };
    })?;
    Ok(child)
}

/// Starts `robot`'s process of `incarnation` with its reaper (see [`start`]); returns its pid.
pub fn spawn(
    l: &Launch,
    robot: u32,
    incarnation: u32,
    exited: impl FnOnce(Pid, String) + Send + 'static,
) -> std::io::Result<Pid> {
    let child = start(&mut robot_command(l, robot, incarnation), exited)?;
    Ok(child.id() as Pid)
}

/// Reaps one child: a small thread blocked in `waitpid(pid)`, so iceoryx2 never sees a
/// zombie and a run never reaps a process that is not its own (an orchestrator may run
/// several runs, as `swarm bench swarm` does, or have other children).
///
/// With `after`, the exit is reported only once that channel's senders are gone or its
/// timeout passed: a host launcher's stdout reader holds one, so the host's last report is
/// on the channel before its exit.
pub fn reap(
    pid: Pid,
    after: Option<(Receiver<()>, Duration)>,
    exited: impl FnOnce(Pid, String) + Send + 'static,
) -> std::io::Result<()> {
    std::thread::Builder::new()
        .name(format!("reap-{pid}"))
        .stack_size(64 * 1024)
        .spawn(move || {
            let how = loop {
                let mut status = 0;
                // SAFETY: waitpid on our own child, writing only `status`.
                let r = unsafe { libc::waitpid(pid, &mut status, 0) };
                if r == pid {
                    break describe(status);
                }
                let e = std::io::Error::last_os_error();
                if e.raw_os_error() != Some(libc::EINTR) {
                    break format!("could not be waited for: {e}");
                }
            };
            if let Some((rx, wait)) = after {
                let _ = rx.recv_timeout(wait);
            }
            exited(pid, how);
        })
        .map(|_| ())
}

/// What one shell (`swarm`, `swarm-host`, a test's fake process table) does for the
/// supervisor's orders: its own way to start a robot, and whom it tells about ends.
pub trait ShellSide {
    /// What a failed start makes of the run (`Infallible` where it is only recorded).
    type Error;

    /// Starts `robot`'s process of `incarnation`, its reaper reporting to the shell's loop.
    fn spawn(&mut self, robot: u32, incarnation: u32) -> std::io::Result<Pid>;

    /// A spawned robot process runs as `pid` (the supervisor knows already).
    fn started(&mut self, _robot: u32, _incarnation: u32, _pid: Pid) {}

    /// `robot`'s process of `incarnation` could not be started.
    fn not_started(
        &mut self,
        robot: u32,
        incarnation: u32,
        e: std::io::Error,
    ) -> Result<(), Self::Error>;

    /// A robot process was reaped.
    fn ended(&mut self, ended: Ended);

    /// One of the other watched processes (the world, a host launcher) was reaped.
    fn other_ended(&mut self, _pid: Pid, _how: String) {}

    /// Sends `signal` to `pids`.
    fn signal(&mut self, pids: &[Pid], signal: Signal) {
        signal_all(pids, signal.raw());
    }
}

/// Performs `orders` through `shell`: signals are sent, spawns started (their pids fed back
/// as [`Event::Started`], whose orders are performed in turn), ends handed over. A failed
/// start is the shell's to judge; an `Err` stops here. [`Order::GiveUp`] needs nothing done.
pub fn carry_out<S: ShellSide>(
    sup: &mut Supervisor,
    orders: Vec<Order>,
    shell: &mut S,
) -> Result<(), S::Error> {
    let mut orders = VecDeque::from(orders);
    while let Some(order) = orders.pop_front() {
        match order {
            Order::Signal { pids, signal } => shell.signal(&pids, signal),
            Order::Spawn { robot, incarnation } => match shell.spawn(robot, incarnation) {
                Ok(pid) => {
                    orders.extend(sup.on(Event::Started {
                        robot,
                        incarnation,
                        pid,
                    }));
                    shell.started(robot, incarnation, pid);
                }
                Err(e) => shell.not_started(robot, incarnation, e)?,
            },
            Order::Ended(e) => shell.ended(e),
            Order::OtherEnded { pid, how } => shell.other_ended(pid, how),
            Order::GiveUp => {}
        }
    }
    Ok(())
}

/// Tells `sup` about `event` and performs what it orders through `shell`.
pub fn handle<S: ShellSide>(
    sup: &mut Supervisor,
    event: Event,
    shell: &mut S,
) -> Result<(), S::Error> {
    let orders = sup.on(event);
    carry_out(sup, orders, shell)
}

/// Sees every process of `sup` out: `grace` to go by themselves, then SIGTERM (with
/// SIGCONT), then SIGKILL, `step` apart, and gives up after that. `event` makes of each
/// message what the supervisor must hear, if anything (an exit is [`Event::Reaped`], a
/// second Ctrl-C [`Event::KillAll`]); the clock is this loop's, the rules the supervisor's.
pub fn see_out<M, S: ShellSide>(
    sup: &mut Supervisor,
    rx: &Receiver<M>,
    (grace, step): (Duration, Duration),
    shell: &mut S,
    mut event: impl FnMut(&mut S, M) -> Option<Event>,
) {
    let perform = |sup: &mut Supervisor, shell: &mut S, orders| {
        if carry_out(sup, orders, shell).is_err() {
            // Only a start can fail, and no robot starts once the run is ending.
            tracing::error!("an order failed while the run's processes were seen out");
        }
    };
    let orders = sup.on(Event::ShutDown);
    perform(sup, shell, orders);
    let mut until = Instant::now() + grace;
    while !sup.is_empty() {
        let stage = sup.stage();
        match rx.recv_timeout(until.saturating_duration_since(Instant::now())) {
            Ok(m) => {
                if let Some(e) = event(shell, m) {
                    let orders = sup.on(e);
                    perform(sup, shell, orders);
                }
                if sup.stage() != stage {
                    until = Instant::now() + step;
                }
            }
            Err(RecvTimeoutError::Timeout) => {
                let orders = sup.on(Event::Overdue);
                if orders.contains(&Order::GiveUp) {
                    tracing::error!(pids = ?sup.live_pids(), "processes could not be reaped");
                    return;
                }
                if sup.stage() == Stage::Killed {
                    tracing::warn!(pids = ?sup.live_pids(), "processes did not exit in time; killing them");
                } else {
                    tracing::debug!(
                        count = sup.live_pids().len(),
                        "processes still running; sending SIGTERM"
                    );
                }
                perform(sup, shell, orders);
                until = Instant::now() + step;
            }
            Err(RecvTimeoutError::Disconnected) => return,
        }
    }
}
