//! `swarm bench`: IPC and lock-step swarm benchmarks.

use crate::error::{SwarmError, SwarmResult};
use clap::Subcommand;

/// `swarm bench <what>`.
#[derive(Subcommand, Debug, Clone)]
pub enum BenchCmd {
    /// iceoryx2 against Unix sockets, TCP and a crossbeam channel.
    Ipc,
    /// Lock-step ticks/s against robot process count, against a bare iceoryx2 floor.
    Swarm,
}

/// Runs a benchmark.
pub fn bench(_cmd: &BenchCmd) -> SwarmResult<()> {
    Err(SwarmError::User("swarm bench is not built yet".into()))
}
