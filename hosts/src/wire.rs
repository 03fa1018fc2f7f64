//! The two messages per remote host per tick, and the join handshake, as bytes on Zenoh.
//!
//! World -> host ([`Down`]): that host's observation slots and which of its robots the world
//! waits for. Host -> world ([`Up`]): one batch of its robots' commands. When the world
//! dropped messages of a host (it sent past its share of the world's queue), the world asks
//! it to resend ([`Down::Resend`]) and it answers with what it still holds ([`Up::Resent`]). Slots travel
//! compactly (only the valid lidar rays, neighbours, frames and report bytes), so a 6,216-byte
//! slot of a goto robot with 16 rays is a few hundred bytes on the wire. Length fields travel
//! raw, so a robot's malformed length reaches the world exactly as it was sent and is refused
//! there as on one host. Every decode is bounds-checked: a malformed message is an error,
//! never a panic.

use swarmrt_protocol::messages::{
    Command, Frame, MAX_INBOX, MAX_LIDAR_RAYS, MAX_NEIGHBOURS, MAX_OUTBOX, MAX_PAYLOAD, MAX_REPORT,
    Neighbour, Observation,
};

/// World -> host.
#[derive(Debug, Clone, PartialEq)]
pub enum Down {
    /// The host's join was accepted: start the robots.
    Welcome,
    /// The host's join was refused (a different build or config); the reason.
    Refuse(String),
    /// One tick: the host's slots, in robot order from its first robot.
    Tick {
        /// The tick.
        tick: u64,
        /// Robots of this host the world waits for this tick.
        expect: Vec<u32>,
        /// The host's observation slots.
        slots: Vec<Observation>,
    },
    /// The run is over: robots exit.
    Shutdown {
        /// The last tick.
        tick: u64,
    },
    /// Messages of this host were dropped while the world waited for these robots: send
    /// again their first command since `tick`'s slots (`answers`) and their last hello
    /// (`hellos`).
    Resend {
        /// The world's current tick.
        tick: u64,
        /// Robots whose answer to `tick` the world has not received.
        answers: Vec<u32>,
        /// Robots whose hello the world has not received.
        hellos: Vec<u32>,
    },
}

/// Host -> world.
#[derive(Debug, Clone, PartialEq)]
pub enum Up {
    /// The host is up; repeated until the world answers. `layout` is [`crate::link::layout`].
    Join {
        /// The host's name.
        host: String,
        /// Hash of the host's message layout and the config it was given.
        layout: u32,
    },
    /// Commands of the host's robots, each attributed by the host to the robot whose
    /// publisher sent it (a hello binds a publisher to a robot, as on one host).
    Commands(Vec<(u32, Command)>),
    /// The host's robots are gone after the shutdown; the world may close its session.
    Bye,
    /// The answer to a [`Down::Resend`]: what the host holds of what was asked. The world
    /// takes an entry only if it still waits for it, so a resend of something that did
    /// arrive changes nothing.
    Resent {
        /// The tick the answers answer.
        tick: u64,
        /// Robots' first commands since that tick's slots.
        answers: Vec<(u32, Command)>,
        /// Robots' last hellos.
        hellos: Vec<(u32, Command)>,
    },
}

/// Changes whenever a message is added or changes shape here: part of the handshake's
/// layout hash ([`crate::link::layout`]), so a host of another wire revision is refused.
pub const WIRE_REVISION: u32 = 2;

/// Why a message did not decode.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("malformed link message: {0}")]
pub struct Malformed(pub &'static str);

const DOWN_WELCOME: u8 = 1;
const DOWN_REFUSE: u8 = 2;
const DOWN_TICK: u8 = 3;
const DOWN_SHUTDOWN: u8 = 4;
const DOWN_RESEND: u8 = 5;
const UP_JOIN: u8 = 11;
const UP_COMMANDS: u8 = 12;
const UP_BYE: u8 = 13;
const UP_RESENT: u8 = 14;

struct W(Vec<u8>);

impl W {
    fn u8(&mut self, v: u8) {
        self.0.push(v);
    }
    fn u16(&mut self, v: u16) {
        self.0.extend_from_slice(&v.to_le_bytes());
    }
    fn u32(&mut self, v: u32) {
        self.0.extend_from_slice(&v.to_le_bytes());
    }
    fn u64(&mut self, v: u64) {
        self.0.extend_from_slice(&v.to_le_bytes());
    }
    /// Bit-exact (NaN payloads included): the world judges the value the robot sent.
    fn f64(&mut self, v: f64) {
        self.u64(v.to_bits());
    }
    fn bytes(&mut self, b: &[u8]) {
        self.u32(b.len() as u32);
        self.0.extend_from_slice(b);
    }
    fn ids(&mut self, ids: &[u32]) {
        self.u32(ids.len() as u32);
        ids.iter().for_each(|&r| self.u32(r));
    }
    fn commands(&mut self, cmds: &[(u32, Command)]) {
        self.u32(cmds.len() as u32);
        for (robot, c) in cmds {
            self.u32(*robot);
            put_command(self, c);
        }
    }
    fn frame(&mut self, f: &Frame) {
        self.u32(f.src);
        self.u32(f.dst);
        self.u64(f.sent_tick);
        self.u16(f.len);
        self.0.extend_from_slice(f.bytes());
    }
}

struct R<'a>(&'a [u8]);

impl<'a> R<'a> {
    fn take(&mut self, n: usize) -> Result<&'a [u8], Malformed> {
        if self.0.len() < n {
            return Err(Malformed("truncated"));
        }
        let (a, b) = self.0.split_at(n);
        self.0 = b;
        Ok(a)
    }
    fn u8(&mut self) -> Result<u8, Malformed> {
        Ok(self.take(1)?[0])
    }
    fn u16(&mut self) -> Result<u16, Malformed> {
        Ok(u16::from_le_bytes(
            self.take(2)?.try_into().expect("2 bytes"),
        ))
    }
    fn u32(&mut self) -> Result<u32, Malformed> {
        Ok(u32::from_le_bytes(
            self.take(4)?.try_into().expect("4 bytes"),
        ))
    }
    fn u64(&mut self) -> Result<u64, Malformed> {
        Ok(u64::from_le_bytes(
            self.take(8)?.try_into().expect("8 bytes"),
        ))
    }
    fn f64(&mut self) -> Result<f64, Malformed> {
        Ok(f64::from_bits(self.u64()?))
    }
    fn bytes(&mut self) -> Result<&'a [u8], Malformed> {
        let n = self.u32()? as usize;
        self.take(n)
    }
    fn count(&mut self, limit: usize) -> Result<usize, Malformed> {
        let n = self.u32()? as usize;
        if n > limit {
            return Err(Malformed("count past the limit"));
        }
        Ok(n)
    }
    fn ids(&mut self, limit: usize) -> Result<Vec<u32>, Malformed> {
        let n = self.count(limit)?;
        (0..n).map(|_| self.u32()).collect()
    }
    fn commands(&mut self, limit: usize) -> Result<Vec<(u32, Command)>, Malformed> {
        let n = self.count(limit)?;
        (0..n)
            .map(|_| Ok((self.u32()?, get_command(self)?)))
            .collect()
    }
    fn frame(&mut self) -> Result<Frame, Malformed> {
        let mut f = Frame::EMPTY;
        f.src = self.u32()?;
        f.dst = self.u32()?;
        f.sent_tick = self.u64()?;
        f.len = self.u16()?;
        let n = (f.len as usize).min(MAX_PAYLOAD);
        f.payload[..n].copy_from_slice(self.take(n)?);
        Ok(f)
    }
    fn end(&self) -> Result<(), Malformed> {
        if self.0.is_empty() {
            Ok(())
        } else {
            Err(Malformed("trailing bytes"))
        }
    }
}

fn put_observation(w: &mut W, o: &Observation) {
    w.u32(o.version);
    w.u32(o.robot);
    w.u64(o.tick);
    w.u8(o.state);
    w.u8(o.reached);
    w.u8(o.goal_visible);
    w.u16(o.lidar_len);
    w.u16(o.neighbours_len);
    w.u16(o.inbox_len);
    for v in [o.x, o.y, o.theta, o.z, o.goal_range, o.goal_bearing] {
        w.f64(v);
    }
    o.lidar().iter().for_each(|&r| w.f64(r));
    for n in o.neighbours() {
        w.u32(n.id);
        w.f64(n.range);
        w.f64(n.bearing);
    }
    o.inbox().iter().for_each(|f| w.frame(f));
}

fn get_observation(r: &mut R) -> Result<Observation, Malformed> {
    let mut o = Observation::empty(0, 0);
    o.version = r.u32()?;
    o.robot = r.u32()?;
    o.tick = r.u64()?;
    o.state = r.u8()?;
    o.reached = r.u8()?;
    o.goal_visible = r.u8()?;
    o.lidar_len = r.u16()?;
    o.neighbours_len = r.u16()?;
    o.inbox_len = r.u16()?;
    o.x = r.f64()?;
    o.y = r.f64()?;
    o.theta = r.f64()?;
    o.z = r.f64()?;
    o.goal_range = r.f64()?;
    o.goal_bearing = r.f64()?;
    for i in 0..(o.lidar_len as usize).min(MAX_LIDAR_RAYS) {
        o.lidar[i] = r.f64()?;
    }
    for i in 0..(o.neighbours_len as usize).min(MAX_NEIGHBOURS) {
        o.neighbours[i] = Neighbour {
            id: r.u32()?,
            range: r.f64()?,
            bearing: r.f64()?,
        };
    }
    for i in 0..(o.inbox_len as usize).min(MAX_INBOX) {
        o.inbox[i] = r.frame()?;
    }
    Ok(o)
}

fn put_command(w: &mut W, c: &Command) {
    w.u32(c.version);
    w.u32(c.robot);
    w.u64(c.tick);
    w.u32(c.kind);
    w.u32(c.pid);
    for v in [c.v, c.omega, c.vx, c.vy, c.vz] {
        w.f64(v);
    }
    w.u8(c.lidar_on);
    w.u16(c.outbox_len);
    c.outbox[..(c.outbox_len as usize).min(MAX_OUTBOX)]
        .iter()
        .for_each(|f| w.frame(f));
    w.u16(c.report_len);
    w.0.extend_from_slice(&c.report[..(c.report_len as usize).min(MAX_REPORT)]);
}

fn get_command(r: &mut R) -> Result<Command, Malformed> {
    let mut c = Command::act(0, 0);
    c.version = r.u32()?;
    c.robot = r.u32()?;
    c.tick = r.u64()?;
    c.kind = r.u32()?;
    c.pid = r.u32()?;
    c.v = r.f64()?;
    c.omega = r.f64()?;
    c.vx = r.f64()?;
    c.vy = r.f64()?;
    c.vz = r.f64()?;
    c.lidar_on = r.u8()?;
    c.outbox_len = r.u16()?;
    for i in 0..(c.outbox_len as usize).min(MAX_OUTBOX) {
        c.outbox[i] = r.frame()?;
    }
    c.report_len = r.u16()?;
    let n = (c.report_len as usize).min(MAX_REPORT);
    c.report[..n].copy_from_slice(r.take(n)?);
    Ok(c)
}

/// The bytes of a [`Down::Tick`], straight from the world's slots (no copy of them first).
pub fn encode_tick(tick: u64, expect: &[u32], slots: &[Observation]) -> Vec<u8> {
    let mut w = W(Vec::with_capacity(
        32 + 4 * expect.len() + 400 * slots.len(),
    ));
    w.u8(DOWN_TICK);
    w.u64(tick);
    w.u32(expect.len() as u32);
    expect.iter().for_each(|&r| w.u32(r));
    w.u32(slots.len() as u32);
    slots.iter().for_each(|o| put_observation(&mut w, o));
    w.0
}

impl Down {
    /// The message as bytes.
    pub fn encode(&self) -> Vec<u8> {
        let mut w = W(Vec::new());
        match self {
            Down::Welcome => w.u8(DOWN_WELCOME),
            Down::Refuse(why) => {
                w.u8(DOWN_REFUSE);
                w.bytes(why.as_bytes());
            }
            Down::Tick {
                tick,
                expect,
                slots,
            } => return encode_tick(*tick, expect, slots),
            Down::Shutdown { tick } => {
                w.u8(DOWN_SHUTDOWN);
                w.u64(*tick);
            }
            Down::Resend {
                tick,
                answers,
                hellos,
            } => {
                w.u8(DOWN_RESEND);
                w.u64(*tick);
                w.ids(answers);
                w.ids(hellos);
            }
        }
        w.0
    }

    /// Decodes a message; `max_slots` bounds the slot and expect counts (the host's robots).
    pub fn decode(bytes: &[u8], max_slots: usize) -> Result<Down, Malformed> {
        let mut r = R(bytes);
        let d = match r.u8()? {
            DOWN_WELCOME => Down::Welcome,
            DOWN_REFUSE => Down::Refuse(String::from_utf8_lossy(r.bytes()?).into_owned()),
            DOWN_TICK => {
                let tick = r.u64()?;
                let n = r.count(max_slots)?;
                let expect = (0..n).map(|_| r.u32()).collect::<Result<_, _>>()?;
                let n = r.count(max_slots)?;
                let slots = (0..n)
                    .map(|_| get_observation(&mut r))
                    .collect::<Result<_, _>>()?;
                Down::Tick {
                    tick,
                    expect,
                    slots,
                }
            }
            DOWN_SHUTDOWN => Down::Shutdown { tick: r.u64()? },
            DOWN_RESEND => Down::Resend {
                tick: r.u64()?,
                answers: r.ids(max_slots)?,
                hellos: r.ids(max_slots)?,
            },
            _ => return Err(Malformed("unknown kind")),
        };
        r.end()?;
        Ok(d)
    }
}

impl Up {
    /// True when a message whose first byte is `kind` is a [`Up::Resent`] (the world gives
    /// those places of their own before decoding anything).
    pub fn is_resent(kind: u8) -> bool {
        kind == UP_RESENT
    }

    /// The message as bytes.
    pub fn encode(&self) -> Vec<u8> {
        let mut w = W(Vec::new());
        match self {
            Up::Join { host, layout } => {
                w.u8(UP_JOIN);
                w.bytes(host.as_bytes());
                w.u32(*layout);
            }
            Up::Commands(cmds) => {
                w.u8(UP_COMMANDS);
                w.commands(cmds);
            }
            Up::Bye => w.u8(UP_BYE),
            Up::Resent {
                tick,
                answers,
                hellos,
            } => {
                w.u8(UP_RESENT);
                w.u64(*tick);
                w.commands(answers);
                w.commands(hellos);
            }
        }
        w.0
    }

    /// Decodes a message; `max_commands` bounds a batch (the host's robots, twice: a robot
    /// may answer late and again).
    pub fn decode(bytes: &[u8], max_commands: usize) -> Result<Up, Malformed> {
        let mut r = R(bytes);
        let u = match r.u8()? {
            UP_JOIN => Up::Join {
                host: String::from_utf8_lossy(r.bytes()?).into_owned(),
                layout: r.u32()?,
            },
            UP_COMMANDS => Up::Commands(r.commands(max_commands)?),
            UP_BYE => Up::Bye,
            // Together within the batch bound: one answer and one hello per robot at most.
            UP_RESENT => {
                let tick = r.u64()?;
                let answers = r.commands(max_commands)?;
                let hellos = r.commands(max_commands - answers.len().min(max_commands))?;
                Up::Resent {
                    tick,
                    answers,
                    hellos,
                }
            }
            _ => return Err(Malformed("unknown kind")),
        };
        r.end()?;
        Ok(u)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn busy_observation() -> Observation {
        let mut o = Observation::empty(7, 42);
        o.x = 1.5;
        o.theta = f64::NAN;
        o.lidar_len = 3;
        o.lidar[..3].copy_from_slice(&[0.5, 1.0, 2.0]);
        o.neighbours_len = 1;
        o.neighbours[0] = Neighbour {
            id: 3,
            range: 0.4,
            bearing: -1.0,
        };
        o.inbox_len = 1;
        o.inbox[0].src = 3;
        o.inbox[0].len = 2;
        o.inbox[0].payload[..2].copy_from_slice(&[9, 8]);
        o
    }

    #[test]
    fn a_tick_round_trips_bit_for_bit() {
        let d = Down::Tick {
            tick: 42,
            expect: vec![7],
            slots: vec![busy_observation(), Observation::empty(8, 42)],
        };
        let bytes = d.encode();
        let back = Down::decode(&bytes, 2).unwrap();
        let Down::Tick { slots, .. } = &back else {
            panic!("not a tick")
        };
        // NaN != NaN, so compare bits.
        assert_eq!(slots[0].theta.to_bits(), f64::NAN.to_bits());
        assert_eq!(slots[0].lidar(), &[0.5, 1.0, 2.0]);
        assert_eq!(slots[0].inbox()[0].bytes(), &[9, 8]);
        assert_eq!(slots[1], Observation::empty(8, 42));
        // A compact slot: far below the 6,216 bytes of the shared-memory layout.
        assert!(bytes.len() < 400, "{} bytes", bytes.len());
    }

    #[test]
    fn malformed_lengths_travel_raw() {
        let mut c = Command::act(5, 9);
        c.v = 0.1;
        c.outbox_len = u16::MAX;
        c.report_len = 3;
        c.report[..3].copy_from_slice(&[1, 2, 3]);
        let bytes = Up::Commands(vec![(5, c)]).encode();
        let Up::Commands(back) = Up::decode(&bytes, 1).unwrap() else {
            panic!("not commands")
        };
        assert_eq!(back[0].1.outbox_len, u16::MAX);
        assert_eq!(&back[0].1.report[..3], &[1, 2, 3]);
        assert_eq!(back[0].1.v, 0.1);
    }

    #[test]
    fn a_resend_and_its_answer_round_trip_within_the_bounds() {
        let ask = Down::Resend {
            tick: 9,
            answers: vec![4, 5],
            hellos: vec![6],
        };
        assert_eq!(Down::decode(&ask.encode(), 3).unwrap(), ask);
        assert!(
            Down::decode(&ask.encode(), 1).is_err(),
            "more ids than robots"
        );
        let mut hello = Command::act(6, 0);
        hello.kind = swarmrt_protocol::messages::CommandKind::Hello as u32;
        let back = Up::Resent {
            tick: 9,
            answers: vec![(4, Command::act(4, 9)), (5, Command::act(5, 9))],
            hellos: vec![(6, hello)],
        };
        assert_eq!(Up::decode(&back.encode(), 3).unwrap(), back);
        assert!(Up::is_resent(back.encode()[0]));
        assert!(!Up::is_resent(Up::Commands(Vec::new()).encode()[0]));
        assert!(
            Up::decode(&back.encode(), 2).is_err(),
            "past the batch bound"
        );
        let bytes = back.encode();
        for cut in 0..bytes.len() {
            assert!(Up::decode(&bytes[..cut], 3).is_err(), "cut at {cut}");
        }
    }

    #[test]
    fn garbage_is_an_error_not_a_panic() {
        let good = Down::Tick {
            tick: 1,
            expect: vec![],
            slots: vec![busy_observation()],
        }
        .encode();
        for cut in 0..good.len() {
            assert!(Down::decode(&good[..cut], 4).is_err(), "cut at {cut}");
        }
        assert!(Down::decode(&good, 0).is_err(), "slot count past the limit");
        let mut long = good.clone();
        long.push(0);
        assert!(Down::decode(&long, 4).is_err());
        assert!(Up::decode(&[0xff, 1, 2], 4).is_err());
        assert!(Up::decode(&[], 4).is_err());
    }

    /// The link's size bound lets the largest legitimate messages through: every slot full
    /// (all lidar rays, neighbours and inbox frames) down, the most commands `Up::decode`
    /// accepts up.
    #[test]
    fn the_largest_legitimate_messages_fit_the_links_bound() {
        for robots in [1usize, 10, 450] {
            let mut full = Observation::empty(0, 0);
            full.lidar_len = MAX_LIDAR_RAYS as u16;
            full.neighbours_len = full.neighbours.len() as u16;
            full.inbox_len = full.inbox.len() as u16;
            for f in full.inbox.iter_mut() {
                f.len = f.payload.len() as u16;
            }
            let expect: Vec<u32> = (0..robots as u32).collect();
            let down = encode_tick(u64::MAX, &expect, &vec![full; robots]);
            let mut c = Command::act(0, 0);
            c.outbox_len = c.outbox.len() as u16;
            for f in c.outbox.iter_mut() {
                f.len = f.payload.len() as u16;
            }
            let up = Up::Commands(vec![(0, c); 2 * robots + 8]).encode();
            let bound = crate::link::max_message_size(robots);
            assert!(
                down.len() < bound,
                "{robots} robots: down {} >= {bound}",
                down.len()
            );
            assert!(
                up.len() < bound,
                "{robots} robots: up {} >= {bound}",
                up.len()
            );
        }
    }
}
