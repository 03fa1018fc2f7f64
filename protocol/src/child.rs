//! What both child processes (world and robot) do before their loop: check the run id they
//! were given and load the resolved config the orchestrator wrote.

use std::path::Path;

use crate::config::Config;
use crate::services::{RunServices, valid_run_id};

/// The run's names and config, or a one-line reason (the caller exits with code 2).
pub fn load_run(run_id: &str, config: &Path) -> Result<(RunServices, Config), String> {
    if !valid_run_id(run_id) {
        return Err(format!(
            "invalid run id {run_id:?}: expected 1-32 lower-case hex digits"
        ));
    }
    let cfg = Config::load(config, &[]).map_err(|e| e.to_string())?;
    Ok((RunServices::new(run_id), cfg))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn refuses_a_bad_run_id_and_a_missing_config() {
        assert!(
            load_run("../etc", Path::new("x.toml"))
                .unwrap_err()
                .contains("run id")
        );
        assert!(
            load_run("00ab", Path::new("/nonexistent.toml"))
                .unwrap_err()
                .contains("nonexistent")
        );
    }
}
