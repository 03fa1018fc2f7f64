//! `swarm check`: validate a config (including building its map) and print it resolved.

use crate::cli::CheckArgs;
use crate::config::load_config;
use crate::error::SwarmResult;

/// Prints the resolved config as TOML.
pub fn check(args: &CheckArgs) -> SwarmResult<()> {
    let cfg = load_config(&args.config, &args.set)?;
    print!("{}", cfg.to_toml());
    Ok(())
}
