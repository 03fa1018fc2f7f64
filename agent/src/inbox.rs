//! A radio message as a robot's core sees it. A leaf: the behaviours, the consensus layer and
//! the agent all use it, and it uses none of them.

/// A message heard this tick: who sent it, when, and what it says (already decoded, and
/// already filtered to the receiver: a behaviour only sees its own kind of message).
#[derive(Debug, Clone, PartialEq)]
pub struct Heard<M> {
    /// Sender id (set by the world, not by the sender).
    pub src: u32,
    /// Tick at which it was sent.
    pub sent_tick: u64,
    /// The message.
    pub msg: M,
}
