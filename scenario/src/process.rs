//! What every child process (world, robot, benchmark child) does before its loop: set up
//! logging, check the run id it was given and load the resolved config the orchestrator wrote.

use std::path::Path;

use swarmrt_protocol::services::{RunServices, valid_run_id};

use crate::config::Config;

/// The run's names and config, or a one-line reason (the caller exits with code 2). The
/// config was resolved by the orchestrator; `[behaviour]` stays opaque here.
pub fn load_run(run_id: &str, config: &Path) -> Result<(RunServices, Config), String> {
    if !valid_run_id(run_id) {
        return Err(format!(
            "invalid run id {run_id:?}: expected 1-32 lower-case hex digits"
        ));
    }
    let cfg = Config::load(config, &[]).map_err(|e| e.to_string())?;
    Ok((RunServices::new(run_id), cfg))
}

/// One logging setup for every binary: `tracing` to stderr, filtered by `RUST_LOG` (default
/// `warn`), so the world's stdout stays free for its reports to the orchestrator. Call once at
/// the start of `main`.
pub fn init_logging() {
    tracing_subscriber::fmt()
        .with_env_filter(
            tracing_subscriber::EnvFilter::try_from_default_env()
                .unwrap_or_else(|_| tracing_subscriber::EnvFilter::new("warn")),
        )
        .with_writer(std::io::stderr)
        .init();
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
