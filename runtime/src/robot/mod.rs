//! The robot process (`swarm-agent`): its command line, its loop, and (in test builds only)
//! the hooks that make it misbehave on purpose.

pub mod cli;
#[cfg(feature = "misbehave")]
mod misbehave;
pub mod shell;

#[cfg(feature = "misbehave")]
pub use misbehave::MISBEHAVE_ENV;
