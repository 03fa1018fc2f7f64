//! What a flocking robot broadcasts every tick: its id and heading (section II-A).

use serde::{Deserialize, Serialize};
use std::f64::consts::TAU;

/// A flock-mate's heading broadcast.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub enum FlockMsg {
    /// The simulated world's message: the sender's flock and heading (the id is the frame's
    /// sender).
    Heading {
        /// The sender's flock (its start group).
        flock: u8,
        /// Its heading estimate in radians.
        heading: f32,
    },
    /// The real e-puck's message: [`encode_byte`] of id and heading.
    Byte(u8),
}

/// Heading steps in one byte: 5 bits.
pub const BYTE_ANGLES: u8 = 32;

/// One byte: the low 3 bits of `id` in the top bits, `heading` rounded to the nearest of 32
/// directions (11.25 degrees, at most 5.625 degrees off) in the low 5 (section II-E).
pub fn encode_byte(id: u32, heading: f64) -> u8 {
    let step = TAU / BYTE_ANGLES as f64;
    let k = (heading.rem_euclid(TAU) / step).round() as u32 % BYTE_ANGLES as u32;
    (((id & 7) as u8) << 5) | k as u8
}

/// `(id, heading)` from [`encode_byte`]'s byte; the heading in [0, 2 pi).
pub fn decode_byte(b: u8) -> (u32, f64) {
    let step = TAU / BYTE_ANGLES as f64;
    ((b >> 5) as u32, (b & 31) as f64 * step)
}
