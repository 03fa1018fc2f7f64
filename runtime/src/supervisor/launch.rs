//! The I/O half of the [`Supervisor`]: a robot's command line (built here and nowhere else),
//! one reaper thread per child, signals, and the shutdown wait.

use std::path::PathBuf;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use crossbeam_channel::{Receiver, RecvTimeoutError};
use swarmrt_protocol::services::RunServices;
use swarmrt_scenario::process::{child_command, describe, signal_all};

use super::{Order, Pid, Stage, Supervisor};

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

/// Starts `robot`'s process of `incarnation` with its reaper; `exited(pid, how)` is called
/// from the reaper when it ends. Returns its pid.
pub fn spawn(
    l: &Launch,
    robot: u32,
    incarnation: u32,
    exited: impl FnOnce(Pid, String) + Send + 'static,
) -> std::io::Result<Pid> {
    let child = robot_command(l, robot, incarnation).spawn()?;
    let pid = child.id() as Pid;
    // The reaper owns the child's end; `Child` is dropped without waiting.
    drop(child);
    reap(pid, None, exited).inspect_err(|_| {
        // No reaper: kill and reap it here so it cannot outlive the run unseen.
        signal_all(&[pid], libc::SIGKILL);
        let mut status = 0;
        // SAFETY: waitpid on our own child, just sent SIGKILL, so this returns promptly.
        unsafe { libc::waitpid(pid, &mut status, 0) };
    })?;
    Ok(pid)
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

/// Carries out a signal order (a spawn order is the shell's: it needs its reaper channel).
pub fn send(order: &Order) {
    if let Order::Signal { pids, signal } = order {
        signal_all(pids, signal.raw());
    }
}

/// Sees every process of `sup` out: `grace` to go by themselves, then SIGTERM (with
/// SIGCONT), then SIGKILL, `step` apart, and gives up after that. `handle` gets every
/// message; it feeds exits to [`Supervisor::reaped`] (and may [`Supervisor::kill_all`]).
pub fn see_out<M>(
    sup: &mut Supervisor,
    rx: &Receiver<M>,
    grace: Duration,
    step: Duration,
    mut handle: impl FnMut(&mut Supervisor, M),
) {
    sup.shut_down().iter().for_each(send);
    let mut until = Instant::now() + grace;
    while !sup.is_empty() {
        let stage = sup.stage();
        match rx.recv_timeout(until.saturating_duration_since(Instant::now())) {
            Ok(m) => {
                handle(sup, m);
                if sup.stage() != stage {
                    until = Instant::now() + step;
                }
            }
            Err(RecvTimeoutError::Timeout) => match sup.escalate() {
                Some(orders) => {
                    if sup.stage() == Stage::Killed {
                        tracing::warn!(pids = ?sup.live_pids(), "processes did not exit in time; killing them");
                    } else {
                        tracing::debug!(
                            count = sup.live_pids().len(),
                            "processes still running; sending SIGTERM"
                        );
                    }
                    orders.iter().for_each(send);
                    until = Instant::now() + step;
                }
                None => {
                    tracing::error!(pids = ?sup.live_pids(), "processes could not be reaped");
                    return;
                }
            },
            Err(RecvTimeoutError::Disconnected) => return,
        }
    }
}
