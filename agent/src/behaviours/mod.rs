//! Where a robot decides. One module per behaviour; each is a plain struct fed the tick's
//! observation and decoded radio messages, returning a [`Command`]. No I/O, no clock.

use swarmrt_protocol::{Command, Observation};

use crate::agent::Decoded;

pub mod formation;
pub mod goto;

/// A robot behaviour: a deterministic state machine.
pub trait Behaviour {
    /// The command for this tick. `inbox` holds this tick's decoded radio messages.
    fn step(&mut self, obs: &Observation, inbox: &[Decoded]) -> Command;
}
