//! Loading a scenario as a run needs it: the config with `--set`, the behaviour's own
//! parameters resolved by the behaviour, and the map and start layout built once, so a bad
//! obstacle or a crowded start is a user error before any process starts.

use std::path::Path;

use swarmrt_scenario::{Config, ConfigError};
use swarmrt_world::World;

use crate::error::SwarmResult;

/// Loads and validates a config, applying `--set` overrides.
pub fn load_config(path: &Path, set: &[String]) -> SwarmResult<Config> {
    let cfg = swarmrt_agent::registry::load(path, set)?;
    // Through ConfigError, so the line looks (and is escaped) like every other config error.
    World::new(&cfg, swarmrt_agent::registry::VOCABULARY).map_err(|e| ConfigError {
        file: path.display().to_string(),
        key: e.key,
        message: e.message,
    })?;
    Ok(cfg)
}
