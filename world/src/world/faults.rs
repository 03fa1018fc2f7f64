//! Stage `faults`: the faults scheduled (or drawn) at a tick boundary, applied to the core's
//! state at once; process faults also leave a [`ProcessSignal`] for the shell to carry out.

use rand::Rng as _;
use swarmrt_protocol::RobotState;
use swarmrt_protocol::control::ProcessFault;
use swarmrt_protocol::records::FaultKind;
use swarmrt_scenario::faults::FaultTarget;

use super::{Event, World};

/// What the shell must do at this tick boundary. The world core has already applied it to
/// its own state, so the run replays whatever the timing of what the shell does.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ProcessSignal {
    /// A fault to carry out on the robot's process (a real signal, via its supervisor).
    Fault(ProcessFault),
    /// A restarted robot's fresh process must have said hello before this tick is published.
    Rejoin(u32),
}

/// A freeze or a restart in progress.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Outage {
    /// First tick it answers again.
    pub(super) until: u64,
    /// State to return to (a robot knocked down before stays down).
    pub(super) resume: RobotState,
}

impl World {
    /// Process faults applied since the last call, in order: the process shell carries them
    /// out with real signals (via the orchestrator); in-process runs restart agents on them.
    pub fn take_signals(&mut self) -> Vec<ProcessSignal> {
        std::mem::take(&mut self.signals)
    }

    fn fault_event(&mut self, fault: FaultKind, robot: Option<u32>, random: bool) {
        self.events.push(Event::Fault {
            tick: self.tick,
            fault,
            robot,
            random,
        });
    }

    fn target(&self, t: &FaultTarget) -> Option<u32> {
        match t {
            FaultTarget::Id(id) => Some(*id),
            FaultTarget::Named(_) => self.leader,
        }
    }

    /// True when the robot's process runs and answers (not dead, frozen or restarting).
    fn running(&self, robot: u32) -> bool {
        self.robots
            .get(robot as usize)
            .is_some_and(|r| r.state.expects_command())
    }

    fn kill(&mut self, robot: u32, random: bool) {
        self.metrics.faults_injected += 1;
        self.fault_event(FaultKind::Kill, Some(robot), random);
        self.mark_dead(robot, "fault: kill");
        self.signals
            .push(ProcessSignal::Fault(ProcessFault::Kill { robot }));
    }

    fn freeze(&mut self, robot: u32, until: u64, random: bool) {
        self.metrics.faults_injected += 1;
        self.fault_event(FaultKind::Freeze, Some(robot), random);
        let r = &mut self.robots[robot as usize];
        self.outages[robot as usize] = Some(Outage {
            until,
            resume: r.state,
        });
        r.state = RobotState::Frozen;
        r.v = 0.0;
        r.omega = 0.0;
        self.signals
            .push(ProcessSignal::Fault(ProcessFault::Freeze { robot }));
    }

    /// Applies the faults scheduled at the current tick boundary: first outages that end,
    /// then kills, restarts, freezes, random faults and radio windows.
    pub(super) fn apply_faults(&mut self) {
        let tick = self.tick;
        let faults = std::mem::take(&mut self.cfg.faults);
        for robot in 0..self.robots.len() as u32 {
            let Some(o) = self.outages[robot as usize].filter(|o| o.until == tick) else {
                continue;
            };
            self.outages[robot as usize] = None;
            let r = &mut self.robots[robot as usize];
            let was = r.state;
            r.state = o.resume;
            if was == RobotState::Frozen {
                self.fault_event(FaultKind::Thaw, Some(robot), false);
                self.signals
                    .push(ProcessSignal::Fault(ProcessFault::Thaw { robot }));
            } else {
                self.fault_event(FaultKind::Rejoin, Some(robot), false);
                self.signals.push(ProcessSignal::Rejoin(robot));
            }
        }
        for k in faults.kill.iter().filter(|k| k.tick == tick) {
            let target = self.target(&k.robot);
            // A frozen or restarting process can be killed too.
            match target.filter(|&r| {
                self.robots
                    .get(r as usize)
                    .is_some_and(|r| r.state != RobotState::Dead)
            }) {
                Some(robot) => self.kill(robot, false),
                None => self.fault_event(FaultKind::KillSkipped, target, false),
            }
        }
        for k in faults.restart.iter().filter(|k| k.tick == tick) {
            let target = self.target(&k.robot);
            match target.filter(|&r| {
                self.robots
                    .get(r as usize)
                    .is_some_and(|r| r.state != RobotState::Dead)
            }) {
                Some(robot) => {
                    self.metrics.faults_injected += 1;
                    self.metrics.restarts += 1;
                    self.fault_event(FaultKind::Restart, Some(robot), false);
                    let i = robot as usize;
                    self.incarnations[i] += 1;
                    let r = &mut self.robots[i];
                    // Restarting a frozen robot ends the freeze: the stopped process is killed.
                    let resume = match (self.outages[i], r.state) {
                        (Some(o), _) => o.resume,
                        (None, s) => s,
                    };
                    self.outages[i] = Some(Outage {
                        until: tick + k.down_ticks,
                        resume,
                    });
                    r.state = RobotState::Restarting;
                    r.v = 0.0;
                    r.omega = 0.0;
                    r.lidar_on = false;
                    if self.leader == Some(robot) {
                        self.leader = None;
                    }
                    self.signals
                        .push(ProcessSignal::Fault(ProcessFault::Restart {
                            robot,
                            incarnation: self.incarnations[i],
                        }));
                }
                None => self.fault_event(FaultKind::RestartSkipped, target, false),
            }
        }
        for f in faults.freeze.iter().filter(|f| f.from == tick) {
            let target = self.target(&f.robot);
            match target.filter(|&r| self.running(r)) {
                Some(robot) => self.freeze(robot, f.to, false),
                None => self.fault_event(FaultKind::FreezeSkipped, target, false),
            }
        }
        if faults.kill_rate > 0.0 || faults.freeze_rate > 0.0 {
            // Two draws per robot every tick, whatever its state, so one robot's fate never
            // shifts another's draws.
            for robot in 0..self.robots.len() as u32 {
                let kill = self.fault_rng.random::<f64>() < faults.kill_rate;
                let freeze = self.fault_rng.random::<f64>() < faults.freeze_rate;
                if !self.running(robot) {
                    continue;
                }
                if kill {
                    self.kill(robot, true);
                } else if freeze {
                    self.freeze(robot, tick + faults.freeze_ticks, true);
                }
            }
        }
        let windows = faults
            .partition
            .iter()
            .map(|p| {
                (
                    FaultKind::PartitionStart,
                    FaultKind::PartitionEnd,
                    p.from,
                    p.to,
                )
            })
            .chain(faults.blackout.iter().map(|b| {
                (
                    FaultKind::BlackoutStart,
                    FaultKind::BlackoutEnd,
                    b.from,
                    b.to,
                )
            }));
        for (start, end, from, to) in windows {
            for (at, kind) in [(from, start), (to, end)] {
                if at == tick {
                    if kind == start {
                        self.metrics.faults_injected += 1;
                    }
                    self.fault_event(kind, None, false);
                }
            }
        }
        self.metrics.frozen_ticks += self
            .robots
            .iter()
            .filter(|r| r.state == RobotState::Frozen)
            .count() as u64;
        self.radio
            .set_groups(faults.radio_groups(tick, self.robots.len()));
        self.cfg.faults = faults;
    }
}
