//! Loading a scenario for the CLI: [`swarmrt_harness::load_config`] with its errors as the
//! CLI reports them (one line, exit 2).

use std::path::Path;

use swarmrt_scenario::Config;

use crate::error::SwarmResult;

/// Loads and validates a config, applying `--set` overrides. Robot programs
/// (`robots.program`) must be runnable from here, and become absolute paths.
pub fn load_config(path: &Path, set: &[String]) -> SwarmResult<Config> {
    let mut cfg = swarmrt_harness::load_config(path, set)?;
    let cwd = std::env::current_dir().map_err(anyhow::Error::from)?;
    swarmrt_scenario::program::resolve(&mut cfg, &path.display().to_string(), &cwd)?;
    Ok(cfg)
}

/// Refuses a config whose robots include another program than the built-in one for a mode
/// that runs the robot cores in-process (`what`, e.g. `--in-process`).
pub fn refuse_foreign_in_process(cfg: &Config, path: &Path, what: &str) -> SwarmResult<()> {
    if let Some((key, _)) =
        (0..cfg.robots.count).find_map(|id| swarmrt_scenario::program::program_of(cfg, id))
    {
        return Err(crate::error::SwarmError::User(format!(
            "{}: key `{key}`: {what} runs the built-in robots in one process; a robot program runs only as a process (drop {what})",
            path.display()
        )));
    }
    Ok(())
}
