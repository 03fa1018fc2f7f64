//! The run records' schema: what the world writes to `trajectory.csv` and `events.jsonl` and
//! every reader (metrics, the consensus checker, plots) reads back. Columns are found by name,
//! so a reader never depends on their order.

use serde::{Deserialize, Serialize};
use serde_json::Value;

use crate::RobotState;

/// Something worth a line in `events.jsonl`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "event", rename_all = "snake_case")]
pub enum Event<N> {
    /// A robot hit an obstacle, a wall or another robot and went down.
    Collision {
        /// Tick of the step in which it happened.
        tick: u64,
        /// The robot that went down.
        robot: u32,
        /// The other robot, when it was a robot.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        other: Option<u32>,
    },
    /// A robot entered the goal radius for the first time.
    Reached {
        /// Tick at which it was first inside.
        tick: u64,
        /// The robot.
        robot: u32,
    },
    /// A robot's process is gone; it stays where it is as an obstacle.
    Died {
        /// Tick from which it counts as dead.
        tick: u64,
        /// The robot.
        robot: u32,
        /// Why (e.g. "process exited: signal 9").
        reason: String,
    },
    /// A scheduled fault took effect or ended.
    Fault {
        /// Tick from which it holds.
        tick: u64,
        /// What happened.
        fault: FaultKind,
        /// The robot, for a process fault.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        robot: Option<u32>,
        /// True for a fault drawn from `faults.kill_rate` / `faults.freeze_rate`.
        #[serde(default, skip_serializing_if = "std::ops::Not::not")]
        random: bool,
    },
    /// A robot's note about its own decisions (role, turn, consensus state).
    Note {
        /// Tick of the command that carried it.
        tick: u64,
        /// The robot.
        robot: u32,
        /// What it said: the world writes it as the robots' vocabulary renders it
        /// ([`crate::NoteJson`]); a reader takes it as JSON (`serde_json::Value`).
        note: N,
    },
    /// A robot sent a command the world refused (logged once per robot and reason).
    Rejected {
        /// Tick of the refused command.
        tick: u64,
        /// The robot.
        robot: u32,
        /// What was wrong.
        reason: String,
    },
}

/// What a `fault` event says happened.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum FaultKind {
    /// The robot's process is killed; the robot is dead from this tick.
    Kill,
    /// The robot's process is stopped; it stands still and silent.
    Freeze,
    /// A freeze ended: the robot answers again.
    Thaw,
    /// The robot's process is killed and a fresh one started after `down_ticks`.
    Restart,
    /// A restarted robot's fresh process answers again.
    Rejoin,
    /// A radio partition began.
    PartitionStart,
    /// A radio partition ended.
    PartitionEnd,
    /// Every radio went silent.
    BlackoutStart,
    /// The radios came back.
    BlackoutEnd,
    /// A kill whose target was dead, or a `"leader"` target with no leader.
    KillSkipped,
    /// A freeze whose target was not running, or had no leader.
    FreezeSkipped,
    /// A restart whose target was dead or already out, or had no leader.
    RestartSkipped,
}

/// Header line of `trajectory.csv`.
pub const TRAJECTORY_HEADER: &str = "tick,id,x,y,theta,v,omega,lidar,state\n";
/// Header line of `trajectory.csv` for aerial robots: `z` (height) and `vz` (vertical speed)
/// added; `v` is the horizontal speed and `omega` the heading's rate of change.
pub const TRAJECTORY_HEADER_AERIAL: &str = "tick,id,x,y,z,theta,v,vz,omega,lidar,state\n";

/// One robot at one tick (a `trajectory.csv` row).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Row {
    /// Tick.
    pub tick: u64,
    /// Robot id.
    pub id: u32,
    /// x, metres.
    pub x: f64,
    /// y, metres.
    pub y: f64,
    /// Height, metres (0 when the records have no `z` column: ground robots).
    pub z: f64,
    /// Heading, radians.
    pub theta: f64,
    /// Lidar on for this tick's observation.
    pub lidar: bool,
    /// Its lifecycle state.
    pub state: RobotState,
    /// Still active (not down, dead, frozen or restarting).
    pub active: bool,
}

/// Where each field of [`Row`] is in a `trajectory.csv` line, found from its header.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Columns {
    tick: usize,
    id: usize,
    x: usize,
    y: usize,
    z: Option<usize>,
    theta: usize,
    lidar: usize,
    state: usize,
    count: usize,
}

impl Columns {
    /// The columns of a header line; `Err` names a missing column.
    pub fn from_header(header: &str) -> Result<Columns, String> {
        let names: Vec<&str> = header.trim_end().split(',').collect();
        let at = |name: &str| {
            names
                .iter()
                .position(|n| *n == name)
                .ok_or_else(|| format!("trajectory.csv has no `{name}` column"))
        };
        Ok(Columns {
            tick: at("tick")?,
            id: at("id")?,
            x: at("x")?,
            y: at("y")?,
            z: at("z").ok(),
            theta: at("theta")?,
            lidar: at("lidar")?,
            state: at("state")?,
            count: names.len(),
        })
    }

    /// One data line, `None` when it is not a whole row.
    pub fn parse(&self, line: &str) -> Option<Row> {
        let f: Vec<&str> = line.split(',').collect();
        if f.len() != self.count {
            return None;
        }
        let state = RobotState::from_name(f[self.state])?;
        Some(Row {
            tick: f[self.tick].parse().ok()?,
            id: f[self.id].parse().ok()?,
            x: f[self.x].parse().ok()?,
            y: f[self.y].parse().ok()?,
            z: match self.z {
                Some(k) => f[k].parse().ok()?,
                None => 0.0,
            },
            theta: f[self.theta].parse().ok()?,
            lidar: f[self.lidar] == "1",
            state,
            active: state == RobotState::Active,
        })
    }
}

/// A run's records, parsed.
#[derive(Debug, Clone, Default)]
pub struct Records {
    /// Rows grouped by tick, in tick order; each holds every robot, in id order.
    pub ticks: Vec<Vec<Row>>,
    /// Every event line, parsed.
    pub events: Vec<Value>,
}

impl Records {
    /// Parses the text of `trajectory.csv` and `events.jsonl` (lines that are not whole are
    /// skipped, as a crashed run's last line may be).
    pub fn parse(trajectory: &str, events: &str) -> Result<Records, String> {
        let mut lines = trajectory.lines();
        let cols = Columns::from_header(lines.next().unwrap_or(""))?;
        let mut ticks: Vec<Vec<Row>> = Vec::new();
        for row in lines.filter_map(|l| cols.parse(l)) {
            match ticks.last_mut() {
                Some(last) if last[0].tick == row.tick => last.push(row),
                _ => ticks.push(vec![row]),
            }
        }
        let events = events
            .lines()
            .filter_map(|l| serde_json::from_str(l).ok())
            .collect();
        Ok(Records { ticks, events })
    }

    /// Events of one kind (`"event"` field).
    pub fn events_of<'a>(&'a self, kind: &'a str) -> impl Iterator<Item = &'a Value> {
        self.events.iter().filter(move |e| e["event"] == kind)
    }

    /// The notes robots reported (`"note"` events' `note` field), in record order.
    pub fn notes(&self) -> impl Iterator<Item = &Value> {
        self.events_of("note").map(|e| &e["note"])
    }
}
