//! One multi-process run as `supervise` drives it: the process table (the world's, this
//! host's robots', the remote hosts' launchers) and the shell that carries out its orders,
//! from the world's first report to the last process seen out.

use std::collections::BTreeMap;
use std::path::Path;
use std::time::Duration;

use anyhow::bail;
use crossbeam_channel::{Receiver, Sender};
use swarmrt_protocol::control::{Control, WorldReport};
use swarmrt_runtime::supervisor::launch::{self, Launch};
use swarmrt_runtime::supervisor::{Event, Supervisor};

use super::phase::{Phase, Step};
use super::shell::RunShell;
use super::world::World;
use super::{
    CLEAN_EXIT, EXIT_GRACE, LAUNCHER_EOF_WAIT, Msg, ProcessOutcome, RobotProcess, SHUTDOWN_GRACE,
    exited,
};
use crate::hosts::{HostMsg, Remotes, RunHosts};

/// A multi-process run: every process of it in one table, and the rest in its shell.
pub(super) struct LocalRun {
    sup: Supervisor,
    shell: RunShell,
    rx: Receiver<Msg>,
}

impl LocalRun {
    /// A run whose world is started already: it is watched with the rest.
    pub fn new(launch: Launch, tx: Sender<Msg>, rx: Receiver<Msg>, world: World) -> LocalRun {
        let world_pid = world.pid;
        let mut run = LocalRun {
            sup: Supervisor::new(),
            shell: RunShell {
                launch,
                tx,
                world,
                outcome: ProcessOutcome::default(),
                remotes: None,
                remote_started: Vec::new(),
                remote_ended: BTreeMap::new(),
                phase: Phase::Starting,
            },
            rx,
        };
        run.on(Event::Watch { pid: world_pid });
        run
    }

    /// What was learned (a run stopped before its robots started).
    pub fn into_outcome(self) -> ProcessOutcome {
        self.shell.outcome
    }

    /// Tells the supervisor `event` and carries out its orders.
    fn on(&mut self, event: Event) {
        let Ok(()) = launch::handle(&mut self.sup, event, &mut self.shell);
    }

    /// Sees every process out: `grace`, then SIGTERM, then SIGKILL. Exits are reaped; at the
    /// run's `end`, host reports are recorded and a Ctrl-C kills everything at once (before
    /// robots started, only exits count).
    fn see_out(&mut self, grace: Duration, end: bool) {
        let times = (grace, EXIT_GRACE);
        launch::see_out(
            &mut self.sup,
            &self.rx,
            times,
            &mut self.shell,
            |shell, m| {
                match m {
                    Msg::Exited { pid, how } => return Some(Event::Reaped { pid, how }),
                    Msg::Interrupt if end => return Some(Event::KillAll),
                    Msg::Host(host, HostMsg::Report(report)) if end => {
                        shell.host_report(host, report)
                    }
                    _ => {}
                }
                None
            },
        );
    }

    /// Waits for the world to listen. `false` when a Ctrl-C came first: the world was
    /// stopped and seen out, and the run is over.
    pub fn await_listening(&mut self) -> anyhow::Result<bool> {
        loop {
            match self.rx.recv()? {
                Msg::Report(WorldReport::Listening) => return Ok(true),
                Msg::Report(r) => tracing::debug!(?r, "early report"),
                Msg::WorldEof => {}
                Msg::Exited { pid, how } if pid == self.shell.world.pid => {
                    bail!(
                        "the world process failed before the run started ({how}); see its error above"
                    )
                }
                Msg::Exited { .. } | Msg::Host(..) => {}
                Msg::Interrupt => {
                    // No grace: the world gets SIGTERM at once.
                    self.shell.outcome.interrupted = true;
                    self.see_out(Duration::ZERO, false);
                    return Ok(false);
                }
            }
        }
    }

    /// Starts the remote hosts (`--hosts` runs) and watches their launchers; if that fails,
    /// the world is stopped and seen out and the run fails.
    pub fn launch_remotes(
        &mut self,
        hosts: Option<&RunHosts>,
        run_id: &str,
        config_path: &Path,
    ) -> anyhow::Result<()> {
        let Some(h) = hosts else { return Ok(()) };
        let tx = &self.shell.tx;
        let watch = |pid, eof| launch::reap(pid, Some((eof, LAUNCHER_EOF_WAIT)), exited(tx));
        match Remotes::launch(&h.file, run_id, config_path, tx, Msg::Host, watch) {
            Ok(r) => {
                let pids = r.pids();
                self.shell.remotes = Some(r);
                pids.into_iter()
                    .for_each(|pid| self.on(Event::Watch { pid }));
                Ok(())
            }
            Err(e) => {
                self.shell.world.send(&Control::Stop);
                self.see_out(SHUTDOWN_GRACE, false);
                Err(e)
            }
        }
    }

    /// Starts the first process of each of the `n` robots not on a remote host, in id
    /// order. What came meanwhile is handled first: a Ctrl-C during start-up (or the run's
    /// end) starts no more robots.
    pub fn start_robots(&mut self, n: u32, progress: &mut impl FnMut(u64)) {
        for robot in 0..n {
            let remote = self.shell.remotes.as_ref();
            if remote.is_some_and(|r| r.host_of(robot).is_some()) {
                continue;
            }
            let came: Vec<Msg> = self.rx.try_iter().collect();
            came.into_iter().for_each(|m| self.handle(m, progress));
            if !self.shell.phase.starting() {
                break;
            }
            self.on(Event::Launch { robot });
        }
    }

    /// Runs the main loop until the world reports the end, fails, or a host fails.
    pub fn supervise(&mut self, progress: &mut impl FnMut(u64)) -> anyhow::Result<()> {
        while !self.shell.phase.is_done() {
            let msg = self.rx.recv()?;
            self.handle(msg, progress);
        }
        Ok(())
    }

    /// One message of the main loop.
    fn handle(&mut self, msg: Msg, progress: &mut impl FnMut(u64)) {
        if let Msg::Report(report) = &msg
            && self.shell.order_remote(report)
        {
            return;
        }
        let shell = &mut self.shell;
        match msg {
            Msg::Report(WorldReport::Ready { startup_ms }) => {
                shell.outcome.startup_ms = Some(startup_ms);
                shell.step(Step::Ready);
            }
            Msg::Report(WorldReport::Tick { tick }) => progress(tick),
            Msg::Report(WorldReport::Fault(fault)) => self.on(Event::Fault(fault)),
            Msg::Report(WorldReport::Unresponsive { robot, waited_ms }) => {
                // Unscheduled: recorded as a death when the reaper reports the exit.
                if self.sup.pid_of(robot).is_some() {
                    tracing::warn!(robot, waited_ms, "robot unresponsive; killing it");
                }
                self.on(Event::Hung { robot });
            }
            Msg::Report(WorldReport::Done {
                interrupted,
                metrics,
            }) => {
                shell.outcome.interrupted |= interrupted;
                shell.outcome.world_metrics = Some(metrics);
                shell.step(Step::Over);
            }
            Msg::Report(WorldReport::Listening) => {}
            Msg::WorldEof => shell.world.eof = true,
            Msg::Exited { pid, how } => self.on(Event::Reaped { pid, how }),
            Msg::Host(host, HostMsg::Report(report)) => shell.host_report(host, report),
            Msg::Host(_, HostMsg::Eof) => {}
            Msg::Report(WorldReport::HostLost { host, robots }) => shell.host_lost(&host, robots),
            Msg::Interrupt => {
                shell.outcome.interrupted = true;
                if shell.step(Step::Interrupt) {
                    self.on(Event::KillAll);
                }
            }
        }
        // A world that exited and closed its stdout without reporting the end failed.
        if !self.shell.phase.is_done()
            && let Some(failure) = self.shell.world.failure()
        {
            self.shell.outcome.world_failure = Some(failure);
            self.shell.step(Step::Over);
        }
    }

    /// Sees the run's processes out, cleans the remote hosts and records every robot
    /// process; a host's start-up failure is the run's error.
    pub fn finish(mut self, run_id: &str) -> anyhow::Result<ProcessOutcome> {
        self.shell.world.close();
        // The world told robots to exit (or died): give them a moment to go by themselves,
        // then SIGTERM, then SIGKILL. Each host sees its robots out after the world's
        // shutdown, then exits; its launcher is watched with the rest. A world that already
        // exited cleanly did publish the shutdown (it is often reaped before this point, and
        // a robot thawed just then was SIGTERMed mid-exit): only a failed world gives none.
        let exit = self.shell.world.exit.as_deref();
        let grace = if exit.is_none() || exit == Some(CLEAN_EXIT) {
            SHUTDOWN_GRACE
        } else {
            Duration::ZERO
        };
        self.see_out(grace, true);
        if let Some(r) = self.shell.remotes.as_ref() {
            let unclean = r.clean(run_id);
            if !unclean.is_empty() {
                tracing::warn!(?unclean, "hosts whose resources could not be removed");
            }
            self.shell.outcome.hosts = Some(r.stats());
        }
        self.record_processes();
        match std::mem::replace(&mut self.shell.phase, Phase::Starting) {
            Phase::Done { failure: Some(f) } => Err(f.into()),
            _ => Ok(self.shell.outcome),
        }
    }

    /// Every robot process started, this host's in start order, then the remote hosts'.
    fn record_processes(&mut self) {
        let shell = &mut self.shell;
        shell.outcome.processes = self
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
        let Some(r) = shell.remotes.as_ref() else {
            return;
        };
        for (host, pid, robot, incarnation) in std::mem::take(&mut shell.remote_started) {
            let (end, ordered) = shell
                .remote_ended
                .remove(&(host, pid))
                .unwrap_or_else(|| ("not reaped".to_string(), false));
            let unscheduled = shell.outcome.unscheduled_deaths.contains_key(&robot);
            shell.outcome.processes.push(RobotProcess {
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
