//! The robot process lifecycle, written once: which process runs which robot, what the fault
//! schedule did to it, and how a run's processes are seen out.
//!
//! [`Supervisor`] is a state machine in turmoil's shape: its shell (`swarm` for the world's
//! host, `swarm-host` for a remote one) tells it what happened (a process started, one was
//! reaped, the world ordered a fault, the run is ending) and carries out the [`Order`]s it
//! returns with real spawns and signals ([`launch`]). It does no I/O, so the rules are tested
//! against a fake process table (`runtime/tests/supervisor.rs`).
//!
//! - [`hello`]: which publisher speaks for which robot; only a hello takes a robot's slot.
//! - [`launch`]: the I/O half: a robot's command line, the reaper thread, signals, the
//!   shutdown wait.

pub mod hello;
pub mod launch;

use std::collections::BTreeMap;

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

/// What the shell must do.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Order {
    /// Start `robot`'s process of `incarnation`, then call [`Supervisor::started`] with its pid.
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

/// What a reaped pid was.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Reaped {
    /// A robot process.
    Robot(Ended),
    /// One of the run's other processes ([`Supervisor::watch`]): the world, a host launcher.
    Other {
        /// Its pid.
        pid: Pid,
        /// How it ended.
        how: String,
    },
    /// No process of this supervisor (or one already reaped).
    Unknown,
}

/// Where the end of the run has got to.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub enum Stage {
    /// Robots are started, signalled and reaped on orders.
    Running,
    /// [`Supervisor::shut_down`]: processes get a grace period to go by themselves.
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

    /// Where the end of the run has got to.
    pub fn stage(&self) -> Stage {
        self.stage
    }

    /// Asks for `robot`'s first process; `None` once the run is ending (Ctrl-C during
    /// start-up starts no more robots).
    pub fn spawn(&self, robot: u32) -> Option<Order> {
        (self.stage == Stage::Running).then_some(Order::Spawn {
            robot,
            incarnation: 0,
        })
    }

    /// Robot `robot`'s process of `incarnation` runs as `pid`.
    pub fn started(&mut self, robot: u32, incarnation: u32, pid: Pid) {
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

    /// Watches one of the run's other processes (the world, a host launcher): it is
    /// reaped like a robot and seen out with them, but no fault touches it.
    pub fn watch(&mut self, pid: Pid) {
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

    /// The process now running `robot`: after a restart the old one may not be reaped yet,
    /// and it is no longer the robot's.
    pub fn pid_of(&self, robot: u32) -> Option<Pid> {
        self.live
            .iter()
            .find(|(_, l)| !l.ordered && l.robot.is_some_and(|(r, _)| r == robot))
            .map(|(&pid, _)| pid)
    }

    fn kill_pid(&mut self, pid: Pid, ordered: bool) -> Order {
        let l = self.live.get_mut(&pid).expect("a live pid");
        l.frozen = false;
        if ordered {
            l.ordered = true;
            self.history[l.record].ordered = true;
        }
        Order::Signal {
            pids: vec![pid],
            signal: Signal::Kill,
        }
    }

    /// A scheduled kill: SIGKILL on an order, so the process's end is no death (the world
    /// counted the robot dead at its tick; the real signal exercises the crash path).
    pub fn kill(&mut self, robot: u32) -> Option<Order> {
        let pid = self.pid_of(robot)?;
        Some(self.kill_pid(pid, true))
    }

    /// An unresponsive robot: SIGKILL, and its end is a death (unlike [`Self::kill`]).
    pub fn kill_hung(&mut self, robot: u32) -> Option<Order> {
        let pid = self.pid_of(robot)?;
        Some(self.kill_pid(pid, false))
    }

    /// A scheduled freeze: SIGSTOP.
    pub fn freeze(&mut self, robot: u32) -> Option<Order> {
        let pid = self.pid_of(robot)?;
        self.live.get_mut(&pid).expect("live").frozen = true;
        Some(Order::Signal {
            pids: vec![pid],
            signal: Signal::Stop,
        })
    }

    /// A scheduled thaw: SIGCONT.
    pub fn thaw(&mut self, robot: u32) -> Option<Order> {
        let pid = self.pid_of(robot)?;
        self.live.get_mut(&pid).expect("live").frozen = false;
        Some(Order::Signal {
            pids: vec![pid],
            signal: Signal::Cont,
        })
    }

    /// A scheduled restart: the old process (if any) is killed on the order and a fresh one
    /// of `incarnation` is asked for. The world waits for the fresh process's hello before
    /// the robot rejoins, so how long this takes changes nothing in the records.
    pub fn restart(&mut self, robot: u32, incarnation: u32) -> Vec<Order> {
        let mut orders: Vec<Order> = self.kill(robot).into_iter().collect();
        if self.stage == Stage::Running {
            orders.push(Order::Spawn { robot, incarnation });
        }
        orders
    }

    /// `pid` was reaped, having ended `how`.
    pub fn reaped(&mut self, pid: Pid, how: &str) -> Reaped {
        let Some(l) = self.live.remove(&pid) else {
            return Reaped::Unknown;
        };
        let Some((robot, incarnation)) = l.robot else {
            return Reaped::Other {
                pid,
                how: how.to_string(),
            };
        };
        self.history[l.record].end = Some(how.to_string());
        Reaped::Robot(Ended {
            robot,
            incarnation,
            pid,
            how: how.to_string(),
            ordered: l.ordered,
        })
    }

    /// The run is ending: frozen processes are continued (a stopped process can neither see
    /// the shutdown sample nor act on SIGTERM), and everything gets a grace period.
    pub fn shut_down(&mut self) -> Vec<Order> {
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

    /// The grace period (or the last step) passed with processes left: the next step, or
    /// `None` when there is none (SIGKILL was sent and still nothing was reaped).
    /// Grace -> SIGTERM then SIGCONT (a process stopped from outside acts on SIGTERM only
    /// once continued) -> SIGKILL -> give up.
    pub fn escalate(&mut self) -> Option<Vec<Order>> {
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
                return None;
            }
        };
        for l in self.live.values_mut() {
            l.frozen = false;
        }
        Some(
            signals
                .iter()
                .map(|&signal| Order::Signal {
                    pids: pids.clone(),
                    signal,
                })
                .collect(),
        )
    }

    /// Kills everything at once (a second Ctrl-C).
    pub fn kill_all(&mut self) -> Order {
        self.stage = self.stage.max(Stage::Killed);
        for l in self.live.values_mut() {
            l.frozen = false;
        }
        Order::Signal {
            pids: self.live_pids(),
            signal: Signal::Kill,
        }
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
}
