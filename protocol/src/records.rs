//! The run records' schema: what the world writes to `trajectory.csv` and `events.jsonl` (and,
//! with `scenario.record_radio`, `radio.csv`) and every reader (metrics, the consensus checker,
//! plots, the viewer) reads back. Columns are found by name, so a reader never depends on their
//! order.

use serde::de::DeserializeOwned;
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
        /// ([`crate::NoteJson`]); a reader takes it as JSON (`serde_json::Value`) and decodes
        /// it as the robots' note type ([`Records::notes_as`]).
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

/// Where each column is in a `trajectory.csv` line, found from its header (readers that need
/// more than a [`Row`], such as the viewer's robot inspector, index lines with it).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Columns {
    /// `tick`.
    pub tick: usize,
    /// `id`.
    pub id: usize,
    /// `x`.
    pub x: usize,
    /// `y`.
    pub y: usize,
    /// `z`, aerial records only.
    pub z: Option<usize>,
    /// `theta`.
    pub theta: usize,
    /// `v`.
    pub v: usize,
    /// `vz`, aerial records only.
    pub vz: Option<usize>,
    /// `omega`.
    pub omega: usize,
    /// `lidar`.
    pub lidar: usize,
    /// `state`.
    pub state: usize,
    /// How many columns a whole line has.
    pub count: usize,
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
            v: at("v")?,
            vz: at("vz").ok(),
            omega: at("omega")?,
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
    /// Every `events.jsonl` line that parses as an [`Event`], in record order. A note's body
    /// stays JSON here (this crate cannot see the robots' note types): read it typed with
    /// [`Records::notes_as`] or [`Records::try_notes_as`].
    pub events: Vec<Event<Value>>,
}

impl Records {
    /// Parses the text of `trajectory.csv` and `events.jsonl` (lines that are not whole are
    /// skipped, as a crashed run's last line may be; so are event lines of a kind this build
    /// does not know).
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

    /// `(tick, robot)` of every `reached` event, in record order.
    pub fn reached(&self) -> impl Iterator<Item = (u64, u32)> + '_ {
        self.events.iter().filter_map(|e| match *e {
            Event::Reached { tick, robot } => Some((tick, robot)),
            _ => None,
        })
    }

    /// `(tick, robot, other)` of every `collision` event, in record order.
    pub fn collisions(&self) -> impl Iterator<Item = (u64, u32, Option<u32>)> + '_ {
        self.events.iter().filter_map(|e| match *e {
            Event::Collision { tick, robot, other } => Some((tick, robot, other)),
            _ => None,
        })
    }

    /// `(tick, robot, note)` of every `note` event, the note as recorded JSON, in record order.
    pub fn notes(&self) -> impl Iterator<Item = (u64, u32, &Value)> {
        self.events.iter().filter_map(|e| match e {
            Event::Note { tick, robot, note } => Some((*tick, *robot, note)),
            _ => None,
        })
    }

    /// Every note decoded as `T`, in record order: `Err` for a note that is not one (a note of
    /// another kind, or one written by a build whose note type differed).
    pub fn try_notes_as<T: DeserializeOwned>(
        &self,
    ) -> impl Iterator<Item = (u64, u32, Result<T, serde_json::Error>)> + '_ {
        self.notes()
            .map(|(tick, robot, note)| (tick, robot, T::deserialize(note)))
    }

    /// `(tick, robot, note)` of every note that decodes as `T`, in record order; the others
    /// are left out (use [`Records::try_notes_as`] where a note that does not decode matters).
    pub fn notes_as<T: DeserializeOwned>(&self) -> impl Iterator<Item = (u64, u32, T)> + '_ {
        self.try_notes_as()
            .filter_map(|(tick, robot, note)| Some((tick, robot, note.ok()?)))
    }
}

impl<N> Event<N> {
    /// The tick the event belongs to.
    pub fn tick(&self) -> u64 {
        match *self {
            Event::Collision { tick, .. }
            | Event::Reached { tick, .. }
            | Event::Died { tick, .. }
            | Event::Fault { tick, .. }
            | Event::Note { tick, .. }
            | Event::Rejected { tick, .. } => tick,
        }
    }
}

/// Header line of `radio.csv` (written only with `scenario.record_radio = true`).
///
/// One line per radio copy whose fate is decided, in the order the medium decided them:
/// `tick` when it happened (the send tick for drops at routing, the delivery tick for
/// deliveries and drops at delivery), `sent_tick`, `from` (the sender), `to` (the receiver; for
/// a broadcast copy the robot that was to hear it; empty for a broadcast frame refused for
/// capacity, which has no receiver), `bytes` (payload length) and `outcome`
/// ([`RadioOutcome::as_str`]). Copies still in flight at the end of a run have no line, so the
/// lines number `sent - in_flight` of `metrics.json`'s `radio`, and each outcome's lines equal
/// its counter (`delivered`, `dropped_<outcome>`).
pub const RADIO_HEADER: &str = "tick,sent_tick,from,to,bytes,outcome\n";

/// What became of one radio copy: delivered, or dropped with a reason (the `dropped_*`
/// counters of `metrics.json`'s `radio`, without the prefix).
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum RadioOutcome {
    /// Put into the receiver's inbox.
    Delivered,
    /// Lost by the loss model.
    Loss,
    /// A unicast whose receiver was out of range, unknown or the sender itself.
    OutOfRange,
    /// Beyond the sender's per-tick capacity.
    Capacity,
    /// Blocked by an obstacle between sender and receiver.
    LineOfSight,
    /// The receiver was down or dead at send or delivery time.
    ReceiverDown,
    /// Due when the receiver's inbox was already full.
    InboxFull,
    /// Sender and receiver were apart in a scheduled partition or blackout.
    Partition,
}

impl RadioOutcome {
    /// Every outcome, in the order of the `radio` counters.
    pub const ALL: [RadioOutcome; 8] = [
        RadioOutcome::Delivered,
        RadioOutcome::Loss,
        RadioOutcome::OutOfRange,
        RadioOutcome::Capacity,
        RadioOutcome::LineOfSight,
        RadioOutcome::ReceiverDown,
        RadioOutcome::InboxFull,
        RadioOutcome::Partition,
    ];

    /// The name in `radio.csv`.
    pub fn as_str(self) -> &'static str {
        match self {
            RadioOutcome::Delivered => "delivered",
            RadioOutcome::Loss => "loss",
            RadioOutcome::OutOfRange => "out_of_range",
            RadioOutcome::Capacity => "capacity",
            RadioOutcome::LineOfSight => "line_of_sight",
            RadioOutcome::ReceiverDown => "receiver_down",
            RadioOutcome::InboxFull => "inbox_full",
            RadioOutcome::Partition => "partition",
        }
    }

    /// The outcome named `name` in `radio.csv`, if it is one.
    pub fn from_name(name: &str) -> Option<RadioOutcome> {
        RadioOutcome::ALL.into_iter().find(|o| o.as_str() == name)
    }

    /// The key of its counter in `metrics.json`'s `radio` (`delivered`, `dropped_loss`, ...).
    pub fn counter(self) -> &'static str {
        match self {
            RadioOutcome::Delivered => "delivered",
            RadioOutcome::Loss => "dropped_loss",
            RadioOutcome::OutOfRange => "dropped_out_of_range",
            RadioOutcome::Capacity => "dropped_capacity",
            RadioOutcome::LineOfSight => "dropped_line_of_sight",
            RadioOutcome::ReceiverDown => "dropped_receiver_down",
            RadioOutcome::InboxFull => "dropped_inbox_full",
            RadioOutcome::Partition => "dropped_partition",
        }
    }
}

/// One radio copy's fate (a `radio.csv` line, see [`RADIO_HEADER`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct RadioRow {
    /// Tick at which the outcome happened.
    pub tick: u64,
    /// Tick at which the frame was sent.
    pub sent_tick: u64,
    /// The sender.
    pub from: u32,
    /// The receiver; `None` for a broadcast frame refused for capacity (it had none).
    pub to: Option<u32>,
    /// Payload length in bytes.
    pub bytes: u16,
    /// What became of it.
    pub outcome: RadioOutcome,
}

impl RadioRow {
    /// Appends this row as one `radio.csv` line (with its newline) to `out`.
    pub fn write_line(&self, out: &mut String) {
        use std::fmt::Write as _;
        let _ = write!(out, "{},{},{},", self.tick, self.sent_tick, self.from);
        if let Some(to) = self.to {
            let _ = write!(out, "{to}");
        }
        let _ = writeln!(out, ",{},{}", self.bytes, self.outcome.as_str());
    }
}

/// Where each field of [`RadioRow`] is in a `radio.csv` line, found from its header.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct RadioColumns {
    tick: usize,
    sent_tick: usize,
    from: usize,
    to: usize,
    bytes: usize,
    outcome: usize,
    count: usize,
}

impl RadioColumns {
    /// The columns of a header line; `Err` names a missing column.
    pub fn from_header(header: &str) -> Result<RadioColumns, String> {
        let names: Vec<&str> = header.trim_end().split(',').collect();
        let at = |name: &str| {
            names
                .iter()
                .position(|n| *n == name)
                .ok_or_else(|| format!("radio.csv has no `{name}` column"))
        };
        Ok(RadioColumns {
            tick: at("tick")?,
            sent_tick: at("sent_tick")?,
            from: at("from")?,
            to: at("to")?,
            bytes: at("bytes")?,
            outcome: at("outcome")?,
            count: names.len(),
        })
    }

    /// One data line (without its newline), `None` when it is not a whole row.
    pub fn parse(&self, line: &str) -> Option<RadioRow> {
        let f: Vec<&str> = line.split(',').collect();
        if f.len() != self.count {
            return None;
        }
        Some(RadioRow {
            tick: f[self.tick].parse().ok()?,
            sent_tick: f[self.sent_tick].parse().ok()?,
            from: f[self.from].parse().ok()?,
            to: match f[self.to] {
                "" => None,
                to => Some(to.parse().ok()?),
            },
            bytes: f[self.bytes].parse().ok()?,
            outcome: RadioOutcome::from_name(f[self.outcome])?,
        })
    }
}

/// Parses the text of `radio.csv`: every whole row, in file order. Lines that are not whole
/// rows are skipped, and so is a last line without its newline (a crashed run's may be torn
/// anywhere, even right after a valid outcome name).
pub fn parse_radio(text: &str) -> Result<Vec<RadioRow>, String> {
    let mut lines = text.split_inclusive('\n');
    let cols = RadioColumns::from_header(lines.next().unwrap_or(""))?;
    Ok(lines
        .filter_map(|l| l.strip_suffix('\n'))
        .filter_map(|l| cols.parse(l.strip_suffix('\r').unwrap_or(l)))
        .collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn radio_rows_round_trip_and_torn_lines_are_skipped() {
        let rows = [
            RadioRow {
                tick: 5,
                sent_tick: 3,
                from: 1,
                to: Some(2),
                bytes: 17,
                outcome: RadioOutcome::Delivered,
            },
            RadioRow {
                tick: 5,
                sent_tick: 5,
                from: 4,
                to: None,
                bytes: 9,
                outcome: RadioOutcome::Capacity,
            },
        ];
        let mut text = RADIO_HEADER.to_string();
        for r in &rows {
            r.write_line(&mut text);
        }
        assert_eq!(
            text,
            "tick,sent_tick,from,to,bytes,outcome\n5,3,1,2,17,delivered\n5,5,4,,9,capacity\n"
        );
        assert_eq!(parse_radio(&text).unwrap(), rows);
        // A torn last line is skipped, even one cut right after a valid outcome name.
        assert_eq!(parse_radio(&format!("{text}6,6,0,1,3,loss")).unwrap(), rows);
        assert_eq!(parse_radio(&format!("{text}6,6,0,1")).unwrap(), rows);
        assert_eq!(parse_radio(&format!("{text}6,6,0,1,3,lo\n")).unwrap(), rows);
        assert!(parse_radio("tick,from\n").is_err());
        for o in RadioOutcome::ALL {
            assert_eq!(RadioOutcome::from_name(o.as_str()), Some(o));
            assert!(o.counter().ends_with(o.as_str()));
        }
    }
}
