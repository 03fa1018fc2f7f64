//! Fixed-size `#[repr(C)]` messages that travel through iceoryx2 shared memory.
//!
//! Every message carries [`PROTOCOL_VERSION`] so a robot binary from another build is refused
//! instead of misread. Bounded collections are fixed arrays with a length field: shared memory
//! holds no pointers.

use iceoryx2_bb_derive_macros::ZeroCopySend;
use iceoryx2_bb_elementary_traits::zero_copy_send::ZeroCopySend;

/// Bumped whenever the layout or meaning of a message changes.
pub const PROTOCOL_VERSION: u32 = 5;
/// Largest radio payload in bytes; larger frames are refused by [`Command::push_frame`].
pub const MAX_PAYLOAD: usize = 128;
/// Frames one robot may put into one [`Command`]; the radio capacity `K` is at most this.
pub const MAX_OUTBOX: usize = 8;
/// Frames one robot may receive in one tick; excess copies are dropped as `inbox_full`.
pub const MAX_INBOX: usize = 32;
/// Most lidar rays a robot can be configured with.
pub const MAX_LIDAR_RAYS: usize = 64;
/// Most neighbours reported by the range-and-bearing sensor (nearest first).
pub const MAX_NEIGHBOURS: usize = 32;
/// Bytes a robot may report per tick (its notes for the run record).
pub const MAX_REPORT: usize = 256;
/// Destination id of a broadcast frame.
pub const BROADCAST: u32 = u32::MAX;
/// First payload byte of an opaque frame: the rest is raw bytes that robots of one kind
/// (e.g. foreign controllers) exchange without postcard. The world routes it like any frame;
/// Rust robots skip it. No postcard message starts with it (an enum tag of 255 would need
/// a second varint byte and more than 127 variants).
pub const OPAQUE_TAG: u8 = 0xff;

/// One radio frame: sender, destination (or [`BROADCAST`]) and a postcard-encoded payload.
#[derive(Debug, Clone, Copy, PartialEq, ZeroCopySend)]
#[type_name("swarmrt::Frame")]
#[repr(C)]
pub struct Frame {
    /// Sending robot id (set by the world, never trusted from the robot).
    pub src: u32,
    /// Receiving robot id or [`BROADCAST`].
    pub dst: u32,
    /// Tick at which the frame was sent.
    pub sent_tick: u64,
    /// Number of valid bytes in `payload`.
    pub len: u16,
    /// Payload bytes; only `..len` are meaningful.
    pub payload: [u8; MAX_PAYLOAD],
}

impl Frame {
    /// An empty frame, used to fill unused slots.
    pub const EMPTY: Frame = Frame {
        src: 0,
        dst: 0,
        sent_tick: 0,
        len: 0,
        payload: [0; MAX_PAYLOAD],
    };

    /// The valid payload bytes (clamped, so a malformed `len` cannot read past the array).
    pub fn bytes(&self) -> &[u8] {
        &self.payload[..(self.len as usize).min(MAX_PAYLOAD)]
    }

    /// An opaque frame to `dst` carrying `bytes` (at most `MAX_PAYLOAD - 1`).
    pub fn opaque(dst: u32, bytes: &[u8]) -> Result<Frame, PushError> {
        if bytes.len() >= MAX_PAYLOAD {
            return Err(PushError::TooLarge);
        }
        let mut f = Frame {
            dst,
            len: bytes.len() as u16 + 1,
            ..Frame::EMPTY
        };
        f.payload[0] = OPAQUE_TAG;
        f.payload[1..=bytes.len()].copy_from_slice(bytes);
        Ok(f)
    }

    /// The raw bytes of an opaque frame, `None` for a postcard message.
    pub fn opaque_bytes(&self) -> Option<&[u8]> {
        match self.bytes() {
            [OPAQUE_TAG, rest @ ..] => Some(rest),
            _ => None,
        }
    }
}

/// A robot's lifecycle state as the world sees it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
#[repr(u8)]
pub enum RobotState {
    /// Moving and sensing.
    Active = 0,
    /// Knocked down by a collision: it stays where it is as an obstacle, radio off.
    Down = 1,
    /// Its process is gone (killed or crashed): it stays where it is as an obstacle.
    Dead = 2,
    /// Its process is stopped (a scheduled freeze): it stands still and silent, the world does
    /// not wait for it, and it answers again when the freeze ends.
    Frozen = 3,
    /// Its process was killed for a scheduled restart and a fresh one is starting: it stands
    /// still and silent until it rejoins.
    Restarting = 4,
}

impl RobotState {
    /// Decodes the raw byte carried in shared memory; `None` for anything unknown.
    pub fn from_u8(v: u8) -> Option<RobotState> {
        match v {
            0 => Some(RobotState::Active),
            1 => Some(RobotState::Down),
            2 => Some(RobotState::Dead),
            3 => Some(RobotState::Frozen),
            4 => Some(RobotState::Restarting),
            _ => None,
        }
    }

    /// The name written in `trajectory.csv` and events.
    pub fn as_str(self) -> &'static str {
        match self {
            RobotState::Active => "active",
            RobotState::Down => "down",
            RobotState::Dead => "dead",
            RobotState::Frozen => "frozen",
            RobotState::Restarting => "restarting",
        }
    }

    /// The state named `name` in `trajectory.csv`, if it is one.
    pub fn from_name(name: &str) -> Option<RobotState> {
        [
            RobotState::Active,
            RobotState::Down,
            RobotState::Dead,
            RobotState::Frozen,
            RobotState::Restarting,
        ]
        .into_iter()
        .find(|s| s.as_str() == name)
    }

    /// True when the robot's process must answer this tick's observation (a down robot's
    /// process still runs and answers; its command is ignored).
    pub fn expects_command(self) -> bool {
        matches!(self, RobotState::Active | RobotState::Down)
    }
}

/// A robot seen by the range-and-bearing sensor.
#[derive(Debug, Clone, Copy, PartialEq, ZeroCopySend)]
#[type_name("swarmrt::Neighbour")]
#[repr(C)]
pub struct Neighbour {
    /// The neighbour's id.
    pub id: u32,
    /// Distance between centres in metres.
    pub range: f64,
    /// Bearing in the observer's frame, radians in (-pi, pi].
    pub bearing: f64,
}

impl Neighbour {
    /// Filler for unused slots.
    pub const EMPTY: Neighbour = Neighbour {
        id: 0,
        range: 0.0,
        bearing: 0.0,
    };
}

/// Everything one robot senses at one tick. The world writes one per robot into a single
/// shared-memory slice; each agent reads only its own slot.
#[derive(Debug, Clone, Copy, PartialEq, ZeroCopySend)]
#[type_name("swarmrt::Observation")]
#[repr(C)]
pub struct Observation {
    /// Must equal [`PROTOCOL_VERSION`].
    pub version: u32,
    /// The robot this slot belongs to.
    pub robot: u32,
    /// The tick this observation describes.
    pub tick: u64,
    /// The robot's state, a [`RobotState`] as `u8` (shared memory carries no Rust enums).
    pub state: u8,
    /// Non-zero once the robot has been inside the goal radius.
    pub reached: u8,
    /// Non-zero when the goal sensor sees the goal this tick.
    pub goal_visible: u8,
    /// Number of valid entries in `lidar`; zero when the lidar was off.
    pub lidar_len: u16,
    /// Number of valid entries in `neighbours`.
    pub neighbours_len: u16,
    /// Number of valid entries in `inbox`.
    pub inbox_len: u16,
    /// Estimated x position in metres (with the configured noise).
    pub x: f64,
    /// Estimated y position in metres.
    pub y: f64,
    /// Estimated heading in radians.
    pub theta: f64,
    /// Estimated height in metres (aerial robots; 0 for ground robots).
    pub z: f64,
    /// Distance to the goal, valid when `goal_visible != 0`.
    pub goal_range: f64,
    /// Bearing to the goal in the robot frame, valid when `goal_visible != 0`.
    pub goal_bearing: f64,
    /// Lidar ranges in metres, ray 0 at `-fov/2` counter-clockwise to `+fov/2`; max range = no hit.
    pub lidar: [f64; MAX_LIDAR_RAYS],
    /// Neighbours seen by range-and-bearing, nearest first.
    pub neighbours: [Neighbour; MAX_NEIGHBOURS],
    /// Radio frames delivered at this tick, in delivery order.
    pub inbox: [Frame; MAX_INBOX],
}

impl Observation {
    /// A blank observation for `robot` at `tick`.
    pub fn empty(robot: u32, tick: u64) -> Self {
        Observation {
            version: PROTOCOL_VERSION,
            robot,
            tick,
            state: RobotState::Active as u8,
            reached: 0,
            goal_visible: 0,
            lidar_len: 0,
            neighbours_len: 0,
            inbox_len: 0,
            x: 0.0,
            y: 0.0,
            theta: 0.0,
            z: 0.0,
            goal_range: 0.0,
            goal_bearing: 0.0,
            lidar: [0.0; MAX_LIDAR_RAYS],
            neighbours: [Neighbour::EMPTY; MAX_NEIGHBOURS],
            inbox: [Frame::EMPTY; MAX_INBOX],
        }
    }

    /// Valid lidar ranges.
    pub fn lidar(&self) -> &[f64] {
        &self.lidar[..(self.lidar_len as usize).min(MAX_LIDAR_RAYS)]
    }

    /// Valid neighbours.
    pub fn neighbours(&self) -> &[Neighbour] {
        &self.neighbours[..(self.neighbours_len as usize).min(MAX_NEIGHBOURS)]
    }

    /// Valid inbox frames.
    pub fn inbox(&self) -> &[Frame] {
        &self.inbox[..(self.inbox_len as usize).min(MAX_INBOX)]
    }
}

/// Header of the observation sample: the tick and whether the run is over.
#[derive(Debug, Clone, Copy, PartialEq, Default, ZeroCopySend)]
#[type_name("swarmrt::ObservationHeader")]
#[repr(C)]
pub struct ObservationHeader {
    /// Must equal [`PROTOCOL_VERSION`].
    pub version: u32,
    /// Non-zero when the world has finished: agents exit instead of answering.
    pub shutdown: u32,
    /// The tick of every observation in the sample.
    pub tick: u64,
}

/// Header of a propagation round's sample (`radio.rounds`): which round of which tick.
#[derive(Debug, Clone, Copy, PartialEq, Default, ZeroCopySend)]
#[type_name("swarmrt::RoundHeader")]
#[repr(C)]
pub struct RoundHeader {
    /// Must equal [`PROTOCOL_VERSION`].
    pub version: u32,
    /// The round, from 1 (round 0 is the tick's observation itself).
    pub round: u32,
    /// The tick the round belongs to.
    pub tick: u64,
}

/// One woken robot's frames in a propagation round. A round's sample holds one per robot
/// woken in it, in ascending robot order; a robot not in it has nothing to react to.
#[derive(Debug, Clone, Copy, PartialEq, ZeroCopySend)]
#[type_name("swarmrt::RoundInbox")]
#[repr(C)]
pub struct RoundInbox {
    /// The woken robot.
    pub robot: u32,
    /// Number of valid entries in `inbox`.
    pub inbox_len: u16,
    /// The frames that reached it in this round, in delivery order.
    pub inbox: [Frame; MAX_INBOX],
}

impl RoundInbox {
    /// An empty inbox for `robot`.
    pub fn empty(robot: u32) -> RoundInbox {
        RoundInbox {
            robot,
            inbox_len: 0,
            inbox: [Frame::EMPTY; MAX_INBOX],
        }
    }

    /// Valid frames (clamped against a malformed length).
    pub fn inbox(&self) -> &[Frame] {
        &self.inbox[..(self.inbox_len as usize).min(MAX_INBOX)]
    }
}

/// What a [`Command`] is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[repr(u32)]
pub enum CommandKind {
    /// The robot's ports exist; it is ready for tick 0. `tick` is ignored.
    Hello = 1,
    /// The robot's decision for `tick`.
    Act = 2,
    /// The robot's reaction, within `tick`, to the frames of a propagation round
    /// (`radio.rounds`): its motion replaces the tick's decision, its frames travel on in
    /// the next round.
    React = 3,
}

impl CommandKind {
    /// Decodes the raw value; `None` for anything unknown.
    pub fn from_u32(v: u32) -> Option<CommandKind> {
        match v {
            1 => Some(CommandKind::Hello),
            2 => Some(CommandKind::Act),
            3 => Some(CommandKind::React),
            _ => None,
        }
    }
}

/// A robot's answer to one observation: velocities, lidar switch and outgoing frames.
#[derive(Debug, Clone, Copy, PartialEq, ZeroCopySend)]
#[type_name("swarmrt::Command")]
#[repr(C)]
pub struct Command {
    /// Must equal [`PROTOCOL_VERSION`].
    pub version: u32,
    /// The sending robot.
    pub robot: u32,
    /// The tick this command answers.
    pub tick: u64,
    /// A [`CommandKind`] as `u32`; anything else is rejected by the world.
    pub kind: u32,
    /// The robot process id (sent with Hello, so the world can name it in logs).
    pub pid: u32,
    /// Forward speed in m/s (clamped by the world to the robot's limits).
    pub v: f64,
    /// Turn rate in rad/s (clamped by the world).
    pub omega: f64,
    /// Aerial robots only (ground robots leave it 0 and use `v`, `omega`): the velocity in
    /// the world frame, m/s: east ...
    pub vx: f64,
    /// ... north ...
    pub vy: f64,
    /// ... and up. Limits: `robots.max_speed` on `(vx, vy)`, `max_vertical_speed` on `vz`.
    pub vz: f64,
    /// Non-zero to have the lidar on for the next observation.
    pub lidar_on: u8,
    /// Number of valid frames in `outbox`.
    pub outbox_len: u16,
    /// With `radio.rounds` > 0, the first `in_tick` frames of an Act's outbox travel within
    /// this tick (their receivers react before the world steps) instead of arriving with the
    /// next observation; ignored without rounds. A React's frames all travel within the tick.
    pub in_tick: u16,
    /// Frames to send this tick; `src` and `sent_tick` are overwritten by the world.
    pub outbox: [Frame; MAX_OUTBOX],
    /// Number of valid bytes in `report`.
    pub report_len: u16,
    /// The robot's own notes for the run record: a postcard-encoded `Vec` of the robots'
    /// note type (`swarmrt_agent::Note`)
    /// (empty when `report_len` is 0). The world checks and logs them; it never acts on them.
    pub report: [u8; MAX_REPORT],
}

/// Why a frame could not be queued.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PushError {
    /// The outbox already holds [`MAX_OUTBOX`] frames.
    OutboxFull,
    /// The encoded message is larger than [`MAX_PAYLOAD`].
    TooLarge,
}

impl Command {
    /// A stopped, silent command for `robot` at `tick`.
    pub fn act(robot: u32, tick: u64) -> Self {
        Command {
            version: PROTOCOL_VERSION,
            robot,
            tick,
            kind: CommandKind::Act as u32,
            pid: 0,
            v: 0.0,
            omega: 0.0,
            vx: 0.0,
            vy: 0.0,
            vz: 0.0,
            lidar_on: 0,
            outbox_len: 0,
            in_tick: 0,
            outbox: [Frame::EMPTY; MAX_OUTBOX],
            report_len: 0,
            report: [0; MAX_REPORT],
        }
    }

    /// The readiness message a robot sends once its ports exist.
    pub fn hello(robot: u32, pid: u32) -> Self {
        Command {
            kind: CommandKind::Hello as u32,
            pid,
            ..Command::act(robot, 0)
        }
    }

    /// Valid outgoing frames (clamped against a malformed length).
    pub fn outbox(&self) -> &[Frame] {
        &self.outbox[..(self.outbox_len as usize).min(MAX_OUTBOX)]
    }

    /// Encodes `msg` with postcard and queues it for `dst`.
    pub fn push_frame<M: serde::Serialize>(&mut self, dst: u32, msg: &M) -> Result<(), PushError> {
        let slot = self.outbox_len as usize;
        if slot >= MAX_OUTBOX {
            return Err(PushError::OutboxFull);
        }
        let mut frame = Frame {
            dst,
            ..Frame::EMPTY
        };
        let used = postcard::to_slice(msg, &mut frame.payload)
            .map_err(|_| PushError::TooLarge)?
            .len();
        frame.len = used as u16;
        self.outbox[slot] = frame;
        self.outbox_len += 1;
        Ok(())
    }
}

impl Command {
    /// Encodes `notes` into the report (replacing any earlier report).
    pub fn set_notes<N: serde::Serialize>(&mut self, notes: &[N]) -> Result<(), PushError> {
        if notes.is_empty() {
            self.report_len = 0;
            return Ok(());
        }
        let used = postcard::to_slice(notes, &mut self.report)
            .map_err(|_| PushError::TooLarge)?
            .len();
        self.report_len = used as u16;
        Ok(())
    }

    /// Decodes the report: `Ok(empty)` when there is none, `Err` when it is malformed.
    pub fn notes<N: serde::de::DeserializeOwned>(&self) -> Result<Vec<N>, &'static str> {
        let report = self.report()?;
        if report.is_empty() {
            return Ok(Vec::new());
        }
        postcard::from_bytes(report).map_err(|_| "malformed report")
    }

    /// The report's bytes, `Err` when its length is out of range.
    pub fn report(&self) -> Result<&[u8], &'static str> {
        let len = self.report_len as usize;
        if len > MAX_REPORT {
            return Err("report length out of range");
        }
        Ok(&self.report[..len])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn notes_round_trip_and_garbage_is_refused() {
        let mut cmd = Command::act(1, 0);
        assert_eq!(cmd.notes::<(u8, i8)>(), Ok(vec![]));
        let notes = vec![(1u8, -1i8), (2, 0)];
        cmd.set_notes(&notes).unwrap();
        assert_eq!(cmd.notes(), Ok(notes));
        cmd.report[0] = 200;
        assert!(cmd.notes::<(u8, i8)>().is_err());
        cmd.report_len = MAX_REPORT as u16 + 1;
        assert_eq!(cmd.notes::<(u8, i8)>(), Err("report length out of range"));
    }

    #[test]
    fn outbox_refuses_the_ninth_frame() {
        let mut cmd = Command::act(0, 0);
        let msg = (0.0f64, 0.0f64, 0.0f64);
        for _ in 0..MAX_OUTBOX {
            cmd.push_frame(BROADCAST, &msg).unwrap();
        }
        assert_eq!(cmd.push_frame(BROADCAST, &msg), Err(PushError::OutboxFull));
        assert_eq!(cmd.outbox().len(), MAX_OUTBOX);
    }

    #[test]
    fn malformed_lengths_are_clamped_not_trusted() {
        let mut obs = Observation::empty(0, 0);
        obs.inbox_len = u16::MAX;
        obs.lidar_len = u16::MAX;
        assert_eq!(obs.inbox().len(), MAX_INBOX);
        assert_eq!(obs.lidar().len(), MAX_LIDAR_RAYS);
        let mut f = Frame::EMPTY;
        f.len = 999;
        assert_eq!(f.bytes().len(), MAX_PAYLOAD);
    }

    #[test]
    fn opaque_frames_carry_raw_bytes_no_message_starts_like_them() {
        let f = Frame::opaque(BROADCAST, b"hi").unwrap();
        assert_eq!(f.opaque_bytes(), Some(&b"hi"[..]));
        assert!(Frame::opaque(0, &[0; MAX_PAYLOAD]).is_err());
        let mut cmd = Command::act(0, 0);
        cmd.push_frame(BROADCAST, &(1u8, 2.0f64)).unwrap();
        assert_eq!(cmd.outbox()[0].opaque_bytes(), None);
    }
}
