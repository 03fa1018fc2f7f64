//! The orchestrator and the world talk over the world's stdin and stdout, one JSON object a
//! line. Pipes need no shared memory, survive either side dying (EOF), and keep the
//! orchestrator free of iceoryx2 ports.

use serde::{Deserialize, Serialize};

/// Orchestrator -> world (stdin).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "control", rename_all = "snake_case")]
pub enum Control {
    /// A robot process is gone (reaped by the orchestrator): mark it dead, stop waiting for it.
    RobotDied {
        /// The robot.
        robot: u32,
        /// How it ended, e.g. "killed by signal 9".
        reason: String,
    },
    /// The process of a robot the schedule killed or restarted has been reaped: reclaim its
    /// ports. The world already accounted for the fault at its tick.
    Reaped {
        /// The robot.
        robot: u32,
    },
    /// End the run now and write the records (Ctrl-C or a failed child).
    Stop,
}

/// What is done to a robot's process: the one vocabulary of faults, from the world's
/// schedule (which applied it to its own state already) through the orchestrator to the
/// supervisor of the robot's host, which sends the real signal.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(tag = "fault", rename_all = "snake_case")]
pub enum ProcessFault {
    /// SIGKILL it: it is dead from this tick.
    Kill {
        /// The robot.
        robot: u32,
    },
    /// SIGSTOP it: it is frozen from this tick; the world no longer waits for it.
    Freeze {
        /// The robot.
        robot: u32,
    },
    /// SIGCONT it: the world waits for its answer again.
    Thaw {
        /// The robot.
        robot: u32,
    },
    /// SIGKILL it and start a fresh process with the same id; the world waits for the fresh
    /// process's hello before the robot rejoins.
    Restart {
        /// The robot.
        robot: u32,
        /// 1 for the first restart of this robot, 2 for the second, ...
        incarnation: u32,
    },
}

impl ProcessFault {
    /// The robot whose process it is.
    pub fn robot(&self) -> u32 {
        match *self {
            ProcessFault::Kill { robot }
            | ProcessFault::Freeze { robot }
            | ProcessFault::Thaw { robot }
            | ProcessFault::Restart { robot, .. } => robot,
        }
    }
}

/// World -> orchestrator (stdout).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "report", rename_all = "snake_case")]
pub enum WorldReport {
    /// The services exist: robots can be started now.
    Listening,
    /// Every robot said hello (or died): tick 0 is about to be published.
    Ready {
        /// Milliseconds from `Listening` until the last hello.
        startup_ms: u64,
    },
    /// The fault schedule did this to a robot's process at the tick boundary: carry it out.
    /// The world already applied it to its own state, so the run replays whatever the
    /// signal's timing.
    Fault(ProcessFault),
    /// A robot answered nothing for `scenario.unresponsive_ms`: the world marked it dead;
    /// SIGKILL its process. An unscheduled death: the run is no longer reproducible.
    Unresponsive {
        /// The robot.
        robot: u32,
        /// How long the world waited, ms.
        waited_ms: u64,
    },
    /// A remote host's link is gone (its `swarm-host` died or its link was cut): the world
    /// marked its robots dead at this tick. Unscheduled: the run is no longer reproducible.
    HostLost {
        /// The host's name.
        host: String,
        /// Its robots the world marked dead.
        robots: Vec<u32>,
    },
    /// Progress, sent at most a few times a second.
    Tick {
        /// The tick just completed.
        tick: u64,
    },
    /// The run is over and the records are complete.
    Done {
        /// True when it ended early on request or on a termination signal.
        interrupted: bool,
        /// The world's metrics (JSON object).
        metrics: serde_json::Value,
    },
}

impl WorldReport {
    /// One line, newline-terminated.
    pub fn to_line(&self) -> String {
        let mut s = serde_json::to_string(self).expect("reports always serialize");
        s.push('\n');
        s
    }
}

impl Control {
    /// One line, newline-terminated.
    pub fn to_line(&self) -> String {
        let mut s = serde_json::to_string(self).expect("controls always serialize");
        s.push('\n');
        s
    }
}

/// Orchestrator -> `swarm-host` (its stdin, through the host's launcher): the run's config
/// first, then the faults of the host's robots, as the world reported them.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "control", rename_all = "snake_case")]
pub enum HostControl {
    /// The resolved config of the run (the first line; a remote host cannot read the run
    /// directory).
    Config {
        /// The config as TOML.
        toml: String,
    },
    /// A fault to carry out on one of the host's robots: one the schedule ordered, or the
    /// kill of a robot the world found unresponsive.
    Fault(ProcessFault),
    /// End now: robots are told to exit, then the host cleans up and exits.
    Stop,
}

/// `swarm-host` -> orchestrator (its stdout, through the launcher).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "report", rename_all = "snake_case")]
pub enum HostReport {
    /// The world accepted the host; its robots are starting.
    Joined,
    /// A robot process started.
    Started {
        /// The robot.
        robot: u32,
        /// 0, then one more per restart.
        incarnation: u32,
        /// Its pid on that host.
        pid: i32,
    },
    /// A robot process ended.
    Exited {
        /// The robot.
        robot: u32,
        /// Its pid on that host.
        pid: i32,
        /// How it ended ("exited with code 0" after the world's shutdown).
        how: String,
        /// True when the host killed it on the orchestrator's order (kill, restart).
        ordered: bool,
    },
    /// The host is done and has removed its iceoryx2 resources.
    Done {
        /// The host's counters (JSON object).
        stats: serde_json::Value,
    },
    /// The host failed and is exiting; one line saying why.
    Failed {
        /// What failed.
        why: String,
    },
}

impl HostControl {
    /// One line, newline-terminated.
    pub fn to_line(&self) -> String {
        let mut s = serde_json::to_string(self).expect("controls always serialize");
        s.push('\n');
        s
    }
}

impl HostReport {
    /// One line, newline-terminated.
    pub fn to_line(&self) -> String {
        let mut s = serde_json::to_string(self).expect("reports always serialize");
        s.push('\n');
        s
    }
}
