//! Radio frames a C robot writes and reads without postcard: opaque frames (raw bytes
//! between robots of one kind, which Rust robots skip) and the go-to behaviour's pose beacon,
//! so a C go-to robot and a Rust one hear each other.

use swarmrt_protocol::{Command, Frame, MAX_OUTBOX, PushError};

/// First payload byte of a go-to beacon: the wire tag of `RadioMsg::Goto`, declared in
/// `agent/src/behaviours/mod.rs` (`SWARMRT_TAG_GOTO` of `swarmrt_tags.h`; checked against the
/// registry and the Rust robot's encoding in this module's tests).
pub const GOTO_TAG: u8 = 0;
/// Bytes of a go-to beacon: the tag, then `x`, `y`, `theta` as little-endian f64 (postcard's
/// encoding of `RadioMsg::Goto(Beacon { x, y, theta })`).
pub const GOTO_BEACON_LEN: usize = 1 + 3 * 8;

fn push(cmd: &mut Command, frame: Frame) -> Result<(), PushError> {
    let slot = cmd.outbox_len as usize;
    if slot >= MAX_OUTBOX {
        return Err(PushError::OutboxFull);
    }
    cmd.outbox[slot] = frame;
    cmd.outbox_len += 1;
    Ok(())
}

/// Queues an opaque frame carrying `bytes` (at most `MAX_PAYLOAD - 1`) for `dst`.
pub fn push_opaque(cmd: &mut Command, dst: u32, bytes: &[u8]) -> Result<(), PushError> {
    if cmd.outbox_len as usize >= MAX_OUTBOX {
        return Err(PushError::OutboxFull);
    }
    push(cmd, Frame::opaque(dst, bytes)?)
}

/// Queues a go-to pose beacon for `dst`: the bytes the Rust go-to robot sends.
pub fn push_goto_beacon(
    cmd: &mut Command,
    dst: u32,
    x: f64,
    y: f64,
    theta: f64,
) -> Result<(), PushError> {
    let mut f = Frame {
        dst,
        len: GOTO_BEACON_LEN as u16,
        ..Frame::EMPTY
    };
    f.payload[0] = GOTO_TAG;
    for (i, v) in [x, y, theta].into_iter().enumerate() {
        f.payload[1 + 8 * i..9 + 8 * i].copy_from_slice(&v.to_le_bytes());
    }
    push(cmd, f)
}

/// `(x, y, theta)` of a go-to beacon, `None` for any other frame.
pub fn goto_beacon(frame: &Frame) -> Option<(f64, f64, f64)> {
    let b = frame.bytes();
    if b.len() != GOTO_BEACON_LEN || b[0] != GOTO_TAG {
        return None;
    }
    let f = |i: usize| f64::from_le_bytes(b[1 + 8 * i..9 + 8 * i].try_into().unwrap());
    Some((f(0), f(1), f(2)))
}

#[cfg(test)]
mod tests {
    use super::*;
    use swarmrt_agent::RadioMsg;
    use swarmrt_agent::behaviours::goto::Beacon;
    use swarmrt_protocol::{BROADCAST, MAX_PAYLOAD};

    #[test]
    fn a_beacon_is_the_rust_robots_bytes() {
        assert_eq!(GOTO_TAG, swarmrt_agent::wire::WireTag::Goto as u8);
        let (x, y, theta) = (1.25, -3.5e-7, std::f64::consts::PI);
        let mut rust = Command::act(2, 7);
        rust.push_frame(BROADCAST, &RadioMsg::Goto(Beacon { x, y, theta }))
            .unwrap();
        let mut c = Command::act(2, 7);
        push_goto_beacon(&mut c, BROADCAST, x, y, theta).unwrap();
        assert_eq!(c, rust);
        assert_eq!(goto_beacon(&c.outbox[0]), Some((x, y, theta)));
        assert_eq!(
            RadioMsg::decode(c.outbox[0].bytes()),
            Some(RadioMsg::Goto(Beacon { x, y, theta }))
        );
    }

    #[test]
    fn opaque_frames_fill_the_outbox_and_no_more() {
        let mut c = Command::act(0, 0);
        assert_eq!(
            push_opaque(&mut c, 1, &[0; MAX_PAYLOAD]),
            Err(PushError::TooLarge)
        );
        for i in 0..MAX_OUTBOX {
            push_opaque(&mut c, 1, &[i as u8; 3]).unwrap();
        }
        assert_eq!(push_opaque(&mut c, 1, b"x"), Err(PushError::OutboxFull));
        assert_eq!(
            push_goto_beacon(&mut c, 1, 0.0, 0.0, 0.0),
            Err(PushError::OutboxFull)
        );
        assert_eq!(c.outbox[5].opaque_bytes(), Some(&[5u8; 3][..]));
        assert_eq!(goto_beacon(&c.outbox[5]), None);
        assert_eq!(RadioMsg::decode(&[GOTO_TAG, 1, 2]), None);
    }
}
