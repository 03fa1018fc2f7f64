//! The robot process lifecycle, written once: which process runs which robot, what the fault
//! schedule did to it, and how a run's processes are seen out.
//!
//! [`Supervisor`] is a state machine in raft-rs's shape: its shell (`swarm` for the world's
//! host, `swarm-host` for a remote one) tells it what happened as one [`Event`] (a process
//! started, one was reaped, the world ordered a fault, the run is ending, a wait ran out) and
//! [`launch::carry_out`] performs the [`Order`]s [`Supervisor::on`] returns with real spawns
//! and signals, handing the news (a robot process ended) to the shell. It does no I/O, so the
//! rules are tested against a fake process table (`runtime/tests/supervisor.rs`).
//!
//! - [`hello`]: which publisher speaks for which robot; only a hello takes a robot's slot.
//! - [`launch`]: the I/O half: a robot's command line, the reaper thread, signals, the one
//!   `carry_out` every shell uses, the shutdown wait.

pub mod hello;
pub mod launch;

use std::collections::BTreeMap;

use swarmrt_protocol::control::ProcessFault;

/// A process id of this host.
pub type Pid = i32;

/// A signal the supervisor asks its shell to send.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Signal {
    /// SIGKILL: a kill, a restart's old process, an unresponsive robot, the last resort.
    Kill,
    /// SIGSTOP: a freeze.
    Stop,
    /// SIGCONT: a thaw, and before any shutdown (a stopped process can see no shutdown).
    Cont,
    /// SIGTERM: a process that did not go by itself at the end.
    Term,
}

impl Signal {
    /// The signal's number.
    pub fn raw(self) -> i32 {
        match self {
            Signal::Kill => libc::SIGKILL,
            Signal::Stop => libc::SIGSTOP,
            Signal::Cont => libc::SIGCONT,
            Signal::Term => libc::SIGTERM,
        }
    }
}

/// What happened, as the shell tells the supervisor.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Event {
    /// Start `robot`'s first process (nothing once the run is ending: Ctrl-C during start-up
    /// starts no more robots).
    Launch {
        /// The robot.
        robot: u32,
    },
    /// Robot `robot`'s process of `incarnation` runs as `pid` (the answer to a spawn order).
    Started {
        /// The robot.
        robot: u32,
        /// Its incarnation.
        incarnation: u32,
        /// Its pid.
        pid: Pid,
    },
    /// Watch one of the run's other processes (the world, a host launcher): it is reaped like
    /// a robot and seen out with them, but no fault touches it.
    Watch {
        /// Its pid.
        pid: Pid,
    },
    /// The fault schedule did this to a robot: the world accounted for it at its tick, the
    /// real signal exercises the crash path.
    Fault(ProcessFault),
    /// A robot answered nothing for too long: SIGKILL, and its end is a death (unlike a
    /// scheduled kill's).
    Hung {
        /// The robot.
        robot: u32,
    },
    /// `pid` was reaped, having ended `how`.
    Reaped {
        /// Its pid.
        pid: Pid,
        /// How it ended.
        how: String,
    },
    /// The run is ending: every process gets a grace period to go by itself.
    ShutDown,
    /// The grace period, or the last escalation step, passed with processes left.
    Overdue,
    /// Kill everything at once (a second Ctrl-C).
    KillAll,
}

/// What the shell must do, or must tell others.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Order {
    /// Start `robot`'s process of `incarnation`, then feed [`Event::Started`] with its pid.
    Spawn {
        /// The robot.
        robot: u32,
        /// 0 for the first process, one more per scheduled restart.
        incarnation: u32,
    },
    /// Send `signal` to `pids` (all live children of this shell, so never reused).
    Signal {
        /// The processes.
        pids: Vec<Pid>,
        /// The signal.
        signal: Signal,
    },
    /// A robot process was reaped: the shell tells whoever counts robots (the world, or the
    /// orchestrator for a remote host).
    Ended(Ended),
    /// One of the other watched processes was reaped.
    OtherEnded {
        /// Its pid.
        pid: Pid,
        /// How it ended.
        how: String,
    },
    /// SIGKILL was sent and still not everything was reaped: nothing more to send.
    GiveUp,
}

/// One robot process of a run, in start order (`metrics.json` -> `processes`).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ProcessRecord {
    /// The robot it ran.
    pub robot: u32,
    /// 0 for the robot's first process, then one more per scheduled restart.
    pub incarnation: u32,
    /// Its pid.
    pub pid: Pid,
    /// How it ended, once reaped.
    pub end: Option<String>,
    /// True when it was killed on an order (a scheduled kill or a restart): its end is no
    /// death. An unresponsive robot's kill is not such an order.
    pub ordered: bool,
}

/// A robot process that was reaped.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Ended {
    /// The robot it ran.
    pub robot: u32,
    /// Its incarnation.
    pub incarnation: u32,
    /// Its pid.
    pub pid: Pid,
    /// How it ended.
    pub how: String,
    /// Killed on an order: the world accounted for it at its tick, and its end is no death.
    pub ordered: bool,
}

/// Where the end of the run has got to.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub enum Stage {
    /// Robots are started, signalled and reaped on orders.
    Running,
    /// [`Event::ShutDown`]: processes get a grace period to go by themselves.
    Grace,
    /// SIGTERM (and SIGCONT) sent to what was left.
    Terminated,
    /// SIGKILL sent to what was left.
    Killed,
    /// Nothing more to send: what is left could not be reaped.
    GaveUp,
}

#[derive(Debug, Clone, Copy)]
struct Live {
    /// `Some((robot, incarnation))` for a robot process, `None` for another watched one.
    robot: Option<(u32, u32)>,
    ordered: bool,
    frozen: bool,
    /// Index in `history` (robots only).
    record: usize,
}

/// The robot process table of one host. See the module doc.
#[derive(Debug)]
pub struct Supervisor {
    live: BTreeMap<Pid, Live>,
    history: Vec<ProcessRecord>,
    stage: Stage,
}

impl Default for Supervisor {
    fn default() -> Self {
        Supervisor::new()
    }
}

impl Supervisor {
    /// No processes yet.
    pub fn new() -> Supervisor {
        Supervisor {
            live: BTreeMap::new(),
            history: Vec::new(),
            stage: Stage::Running,
        }
    }

    /// What to do about `event`: the one entry of the rules.
    pub fn on(&mut self, event: Event) -> Vec<Order> {
        match event {
            Event::Launch { robot } => self.spawn(robot, 0).into_iter().collect(),
            Event::Started {
                robot,
                incarnation,
                pid,
            } => {
                self.started(robot, incarnation, pid);
                Vec::new()
            }
            Event::Watch { pid } => {
                self.watch(pid);
                Vec::new()
            }
            Event::Fault(fault) => self.fault(fault),
            Event::Hung { robot } => self.kill(robot, false).into_iter().collect(),
            Event::Reaped { pid, how } => self.reaped(pid, how).into_iter().collect(),
            Event::ShutDown => self.shut_down(),
            Event::Overdue => self.escalate(),
            Event::KillAll => vec![self.kill_all()],
        }
    }

    /// Where the end of the run has got to.
    pub fn stage(&self) -> Stage {
        self.stage
    }

    /// The process now running `robot`: after a restart the old one may not be reaped yet,
    /// and it is no longer the robot's.
    pub fn pid_of(&self, robot: u32) -> Option<Pid> {
        self.live
            .iter()
            .find(|(_, l)| !l.ordered && l.robot.is_some_and(|(r, _)| r == robot))
            .map(|(&pid, _)| pid)
    }

    /// Every process not reaped yet, robots and watched ones.
    pub fn live_pids(&self) -> Vec<Pid> {
        self.live.keys().copied().collect()
    }

    /// True when every process was reaped.
    pub fn is_empty(&self) -> bool {
        self.live.is_empty()
    }

    /// Every robot process started, in start order, with how it ended.
    pub fn processes(&self) -> &[ProcessRecord] {
        &self.history
    }

    /// A process of `incarnation` for `robot`, unless the run is ending.
    fn spawn(&self, robot: u32, incarnation: u32) -> Option<Order> {
        (self.stage == Stage::Running).then_some(Order::Spawn { robot, incarnation })
    }

    fn started(&mut self, robot: u32, incarnation: u32, pid: Pid) {
        self.history.push(ProcessRecord {
            robot,
            incarnation,
            pid,
            end: None,
            ordered: false,
        });
        self.live.insert(
            pid,
            Live {
                robot: Some((robot, incarnation)),
                ordered: false,
                frozen: false,
                record: self.history.len() - 1,
            },
        );
    }

    fn watch(&mut self, pid: Pid) {
        self.live.insert(
            pid,
            Live {
                robot: None,
                ordered: false,
                frozen: false,
                record: usize::MAX,
            },
        );
    }

    /// A scheduled fault. A kill is SIGKILL on an order, so the process's end is no death.
    /// A restart kills the old process (if any) on the order and asks for a fresh one of
    /// `incarnation`; the world waits for its hello before the robot rejoins, so how long
    /// this takes changes nothing in the records.
    fn fault(&mut self, fault: ProcessFault) -> Vec<Order> {
        match fault {
            ProcessFault::Kill { robot } => self.kill(robot, true).into_iter().collect(),
            ProcessFault::Freeze { robot } => self.freeze(robot, true).into_iter().collect(),
            ProcessFault::Thaw { robot } => self.freeze(robot, false).into_iter().collect(),
            ProcessFault::Restart { robot, incarnation } => {
                let mut orders: Vec<Order> = self.kill(robot, true).into_iter().collect();
                orders.extend(self.spawn(robot, incarnation));
                orders
            }
        }
    }

    /// SIGKILL `robot`'s process; `ordered` when the schedule asked (its end is no death).
    fn kill(&mut self, robot: u32, ordered: bool) -> Option<Order> {
        let pid = self.pid_of(robot)?;
        let l = self.live.get_mut(&pid).expect("a live pid");
        l.frozen = false;
        if ordered {
            l.ordered = true;
            self.history[l.record].ordered = true;
        }
        Some(Order::Signal {
            pids: vec![pid],
            signal: Signal::Kill,
        })
    }

    /// SIGSTOP (`frozen`) or SIGCONT `robot`'s process.
    fn freeze(&mut self, robot: u32, frozen: bool) -> Option<Order> {
        let pid = self.pid_of(robot)?;
        self.live.get_mut(&pid).expect("live").frozen = frozen;
        Some(Order::Signal {
            pids: vec![pid],
            signal: if frozen { Signal::Stop } else { Signal::Cont },
        })
    }

    /// What the reaped `pid` was; `None` for no process of this supervisor (or one already
    /// reaped).
    fn reaped(&mut self, pid: Pid, how: String) -> Option<Order> {
        let l = self.live.remove(&pid)?;
        let Some((robot, incarnation)) = l.robot else {
            return Some(Order::OtherEnded { pid, how });
        };
        self.history[l.record].end = Some(how.clone());
        Some(Order::Ended(Ended {
            robot,
            incarnation,
            pid,
            how,
            ordered: l.ordered,
        }))
    }

    /// The run is ending: frozen processes are continued (a stopped process can neither see
    /// the shutdown sample nor act on SIGTERM), and everything gets a grace period.
    fn shut_down(&mut self) -> Vec<Order> {
        if self.stage < Stage::Grace {
            self.stage = Stage::Grace;
        }
        let frozen: Vec<Pid> = self
            .live
            .iter_mut()
            .filter(|(_, l)| l.frozen)
            .map(|(&pid, l)| {
                l.frozen = false;
                pid
            })
            .collect();
        if frozen.is_empty() {
            return Vec::new();
        }
        vec![Order::Signal {
            pids: frozen,
            signal: Signal::Cont,
        }]
    }

    /// The next step of the end: Grace -> SIGTERM then SIGCONT (a process stopped from
    /// outside acts on SIGTERM only once continued) -> SIGKILL -> give up.
    fn escalate(&mut self) -> Vec<Order> {
        let pids = self.live_pids();
        let signals: &[Signal] = match self.stage {
            Stage::Running | Stage::Grace => {
                self.stage = Stage::Terminated;
                &[Signal::Term, Signal::Cont]
            }
            Stage::Terminated => {
                self.stage = Stage::Killed;
                &[Signal::Kill]
            }
            Stage::Killed | Stage::GaveUp => {
                self.stage = Stage::GaveUp;
                return vec![Order::GiveUp];
            }
        };
        for l in self.live.values_mut() {
            l.frozen = false;
        }
        signals
            .iter()
            .map(|&signal| Order::Signal {
                pids: pids.clone(),
                signal,
            })
            .collect()
    }

    fn kill_all(&mut self) -> Order {
        self.stage = self.stage.max(Stage::Killed);
        for l in self.live.values_mut() {
            l.frozen = false;
        }
        Order::Signal {
            pids: self.live_pids(),
            signal: Signal::Kill,
        }
    }
}
