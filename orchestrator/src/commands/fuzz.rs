//! `swarm fuzz`: seeded fault fuzzing of the consensus cores.

use crate::error::{SwarmError, SwarmResult};
use clap::Subcommand;

/// `swarm fuzz <what>`.
#[derive(Subcommand, Debug, Clone)]
pub enum FuzzCmd {
    /// The Raft-style election and replicated log.
    Consensus,
}

/// Runs a fuzzer.
pub fn fuzz(_cmd: &FuzzCmd) -> SwarmResult<()> {
    Err(SwarmError::User("swarm fuzz is not built yet".into()))
}
