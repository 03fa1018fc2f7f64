//! `swarm sweep`: a scenario over the cross product of varied keys and seeds.

use crate::error::{SwarmError, SwarmResult};
use clap::Parser;
use std::path::PathBuf;

/// `swarm sweep`.
#[derive(Parser, Debug, Clone)]
pub struct SweepArgs {
    /// The scenario file.
    pub config: PathBuf,
}

/// Runs the sweep.
pub fn sweep(_args: &SweepArgs, _interrupt: crossbeam_channel::Receiver<()>) -> SwarmResult<()> {
    Err(SwarmError::User("swarm sweep is not built yet".into()))
}
