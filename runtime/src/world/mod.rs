//! The world process (`swarm-world`): its command line, its shell, its ticks and their timing.

mod answers;
pub mod cli;
mod collect;
mod control;
pub mod mode;
mod realtime;
mod remote;
pub mod shell;
pub mod stats;
mod ticks;
pub mod timing;

pub use mode::Mode;
pub use stats::{RealtimeStats, ShellStats};
