//! The one way a user's scenario becomes a config a run can start from: every `swarm` command
//! that takes a config file (`run`, `check`, `sweep`, `tune`, `plan`) and `swarm-bench` call
//! [`load_run_config`].
//!
//! The world and robot processes read the config the orchestrator wrote into the run
//! directory, already resolved: they use `swarmrt_scenario::process::load_run` and
//! `swarmrt_agent::registry::resolve`, not this.

use std::path::Path;

use swarmrt_scenario::{Config, ConfigError};
use swarmrt_world::World;

/// Loads the scenario at `path` as a run needs it, every check in this order; the first
/// failure is the error, naming the file (`--set` for a bad override) and the key:
///
/// 1. the file read and parsed against the schema, the `--set` overrides (`set`, each
///    `key=value`) applied, every value checked against its bounds
///    (`swarmrt_scenario::Config::load`);
/// 2. the `[behaviour]` parameters parsed, defaulted and validated by the behaviour that owns
///    them (`swarmrt_agent::registry::resolve`), so `to_toml()` writes them all;
/// 3. the map and the start layout built once, so a bad obstacle or a crowded start is an
///    error before anything starts;
/// 4. every robot program (`robots.program`, `robots.programs`) checked runnable from `cwd`
///    and made an absolute path (`swarmrt_scenario::program::resolve`), so the resolved
///    config starts the same programs wherever it is run from.
pub fn load_run_config(path: &Path, set: &[String], cwd: &Path) -> Result<Config, ConfigError> {
    let file = path.display().to_string();
    let mut cfg = Config::load(path, set)?;
    swarmrt_agent::registry::resolve(&mut cfg, &file)?;
    World::new(&cfg, swarmrt_agent::registry::VOCABULARY)
        .map_err(|e| ConfigError::new(&file, e.key, e.message))?;
    swarmrt_scenario::program::resolve(&mut cfg, &file, cwd)?;
    Ok(cfg)
}
