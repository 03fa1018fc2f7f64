//! Where a robot decides. One module per behaviour; each is a plain struct fed the tick's
//! observation and decoded radio messages, returning a [`Command`]. No I/O, no clock.

use swarmrt_protocol::consensus::Decision;
use swarmrt_protocol::{Command, Observation};

use crate::agent::Decoded;

pub mod formation;
pub mod goto;

/// A robot behaviour: a deterministic state machine.
pub trait Behaviour {
    /// The command for this tick. `inbox` holds this tick's decoded radio messages.
    fn step(&mut self, obs: &Observation, inbox: &[Decoded]) -> Command;

    /// Acts on a swarm decision the consensus layer committed and applied. Called before
    /// `step` in the tick it was applied; behaviours that have no use for it ignore it.
    fn apply(&mut self, _decision: &Decision) {}
}
