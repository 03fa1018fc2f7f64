//! Loading a scenario for the CLI: [`swarmrt_harness::load_config`] with its errors as the
//! CLI reports them (one line, exit 2).

use std::path::Path;

use swarmrt_scenario::Config;

use crate::error::SwarmResult;

/// Loads and validates a config, applying `--set` overrides.
pub fn load_config(path: &Path, set: &[String]) -> SwarmResult<Config> {
    Ok(swarmrt_harness::load_config(path, set)?)
}
