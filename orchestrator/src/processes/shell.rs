//! The orchestrator's side of the supervisor's orders, and what it tells others: a robot's
//! end goes to the world, a host's loss to the world or to the run's error, the phase moves.

use std::convert::Infallible;

use crossbeam_channel::Sender;
use swarmrt_protocol::control::{Control, HostReport, WorldReport};
use swarmrt_runtime::supervisor::launch::{self, Launch, ShellSide};
use swarmrt_runtime::supervisor::{Ended, Pid};

use super::phase::{Phase, Step, Then};
use super::remote::{RemoteEnds, RemoteStarts, record_remote, remote_order};
use super::world::World;
use super::{CLEAN_EXIT, Msg, ProcessOutcome, exited};
use crate::hosts::{HostFailure, Remotes};

/// Everything of a run but its process table: how robots start, the world, the remote hosts,
/// what was learned so far, and the phase.
pub(super) struct RunShell {
    pub launch: Launch,
    /// Where the reapers report.
    pub tx: Sender<Msg>,
    pub world: World,
    pub outcome: ProcessOutcome,
    pub remotes: Option<Remotes>,
    /// Remote robot processes, and how each ended.
    pub remote_started: RemoteStarts,
    pub remote_ended: RemoteEnds,
    pub phase: Phase,
}

impl ShellSide for RunShell {
    /// A robot that cannot be started is an unscheduled death; the run goes on.
    type Error = Infallible;

    fn spawn(&mut self, robot: u32, incarnation: u32) -> std::io::Result<Pid> {
        launch::spawn(&self.launch, robot, incarnation, exited(&self.tx))
    }

    fn not_started(
        &mut self,
        robot: u32,
        incarnation: u32,
        e: std::io::Error,
    ) -> Result<(), Infallible> {
        let verb = if incarnation == 0 { "start" } else { "restart" };
        tracing::error!(robot, "cannot {verb} robot: {e}");
        self.outcome
            .unscheduled_deaths
            .insert(robot, format!("failed to {verb}: {e}"));
        self.world.send(&Control::RobotDied {
            robot,
            reason: format!("failed to {verb}"),
        });
        Ok(())
    }

    fn ended(&mut self, e: Ended) {
        if !self.phase.is_done() {
            self.robot_ended(e.robot, &e.how, e.ordered);
        }
    }

    /// The world's end is noted; a host launcher's loses its host.
    fn other_ended(&mut self, pid: Pid, how: String) {
        if self.phase.is_done() {
            tracing::debug!(pid, how, "process ended");
        } else if pid == self.world.pid {
            self.world.exit = Some(how);
        } else if let Some(r) = self.remotes.as_mut()
            && let Some(host) = r.by_pid(pid)
        {
            let why = r.ended(host, &how);
            self.lose_host(host, why);
        }
    }
}

impl RunShell {
    /// Moves the run on and tells the world and the hosts what that takes; true when every
    /// process must be killed at once (the supervisor's to order).
    pub fn step(&mut self, step: Step) -> bool {
        match self.phase.next(step) {
            Then::Nothing => {}
            Then::StopWorld => {
                tracing::warn!("stopping the run (Ctrl-C again to kill it)");
                self.world.send(&Control::Stop);
            }
            Then::StopAll => {
                // `finish` returns the failure.
                self.world.send(&Control::Stop);
                if let Some(r) = self.remotes.as_mut() {
                    r.stop_all();
                }
            }
            Then::KillAll => return true,
        }
        false
    }

    /// A robot process ended (`how`), here or on a remote host. A process the fault schedule
    /// killed is no death: the world accounted for it at its tick and only reclaims its
    /// ports. Otherwise the world is told, and any end but the clean one after the world's
    /// shutdown sample (which can come before we see the world's Done) is an unscheduled
    /// death.
    fn robot_ended(&mut self, robot: u32, how: &str, scheduled: bool) {
        if scheduled {
            self.world.send(&Control::Reaped { robot });
            return;
        }
        if how != CLEAN_EXIT {
            tracing::warn!(robot, "robot process {how}");
            self.outcome
                .unscheduled_deaths
                .insert(robot, how.to_string());
        }
        self.world.send(&Control::RobotDied {
            robot,
            reason: format!("process {how}"),
        });
    }

    /// A fault or a death of a robot on a remote host: ordered through its swarm-host. True
    /// when `report` was such an order.
    pub fn order_remote(&mut self, report: &WorldReport) -> bool {
        let Some(r) = self.remotes.as_mut() else {
            return false;
        };
        let Some((robot, order)) = remote_order(report) else {
            return false;
        };
        let Some(host) = r.host_of(robot) else {
            return false;
        };
        if let WorldReport::Unresponsive { waited_ms, .. } = report {
            self.outcome.unscheduled_deaths.insert(
                robot,
                format!("unresponsive for {waited_ms} ms (on host {})", r.name(host)),
            );
        }
        r.order(host, &order);
        true
    }

    /// A remote host's report: a robot process's start or end, or the host's failure. Once
    /// the main loop is over they are only recorded.
    pub fn host_report(&mut self, host: usize, report: HostReport) {
        let Some(r) = self.remotes.as_mut() else {
            return;
        };
        r.note(host, &report);
        let end = record_remote(
            host,
            &report,
            &mut self.remote_started,
            &mut self.remote_ended,
        );
        if self.phase.is_done() {
            return;
        }
        if let Some((robot, how, ordered)) = end {
            self.robot_ended(robot, &how, ordered);
        }
        if let HostReport::Failed { .. } = report {
            let why = self
                .remotes
                .as_ref()
                .and_then(|r| r.lost(host))
                .map(str::to_string);
            self.lose_host(host, why);
        }
    }

    /// The world lost its link to `host`: its `robots` died, unless they already had.
    pub fn host_lost(&mut self, host: &str, robots: Vec<u32>) {
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

    /// A host is gone (`why`; `None` when it had finished or was lost already): before tick
    /// 0 that fails the run; afterwards its robots are dead from now on, an unscheduled death
    /// each.
    fn lose_host(&mut self, host: usize, why: Option<String>) {
        let (Some(why), Some(r)) = (why, self.remotes.as_ref()) else {
            return;
        };
        let name = r.name(host).to_string();
        if !self.phase.ready() {
            self.step(Step::HostFailed(HostFailure { host: name, why }));
            return;
        }
        tracing::warn!(host = name, "host lost: {why}");
        for robot in r.alive_robots(host) {
            let reason = format!("host {name} lost: {why}");
            self.outcome
                .unscheduled_deaths
                .entry(robot)
                .or_insert(reason.clone());
            self.world.send(&Control::RobotDied { robot, reason });
        }
    }
}
