//! A scenario for the CLI: [`swarmrt_harness::config::load_run_config`] from the current
//! directory, its error a user error (one line, exit 2).

use std::path::Path;

use swarmrt_scenario::Config;

use crate::error::{SwarmError, SwarmResult};

/// [`swarmrt_harness::config::load_run_config`] with robot programs found from the current
/// directory; a bad config is a [`crate::error::SwarmError::User`], and so is a current
/// directory that is gone (removed under the shell): relative paths cannot be found from it.
pub fn load_config(path: &Path, set: &[String]) -> SwarmResult<Config> {
    let cwd = std::env::current_dir().map_err(|e| {
        SwarmError::User(format!(
            "{}: the current directory is gone ({e}); robot programs and relative paths are found from it, so cd to one that exists",
            path.display()
        ))
    })?;
    Ok(swarmrt_harness::config::load_run_config(path, set, &cwd)?)
}

/// Refuses a config whose robots include another program than the built-in one for a mode
/// that runs the robot cores in-process (`what`, e.g. `--in-process`).
pub fn refuse_foreign_in_process(cfg: &Config, path: &Path, what: &str) -> SwarmResult<()> {
    if let Some((key, _)) =
        (0..cfg.robots.count).find_map(|id| swarmrt_scenario::program::program_of(cfg, id))
    {
        return Err(SwarmError::User(format!(
            "{}: key `{key}`: {what} runs the built-in robots in one process; a robot program runs only as a process (drop {what})",
            path.display()
        )));
    }
    Ok(())
}
