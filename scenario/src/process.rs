//! What every child process (world, robot, benchmark child) does before its loop: set up
//! logging, check the run id it was given and load the resolved config the orchestrator wrote.

use std::os::unix::process::CommandExt;
use std::path::Path;
use std::process::Command;

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

/// A command for a child process (of the orchestrator, or of `swarm-host`): its own
/// process group, SIGTERM if the spawning thread dies. The spawning thread must outlive the child (`PR_SET_PDEATHSIG` follows
/// the thread, not the process).
pub fn child_command(bin: &Path) -> Command {
    let mut cmd = Command::new(bin);
    // Own process group: a terminal's Ctrl-C reaches only the orchestrator, which then stops
    // the run in order. If the orchestrator dies, the child gets SIGTERM and exits cleanly.
    cmd.process_group(0);
    let parent = std::process::id() as libc::pid_t;
    unsafe {
        cmd.pre_exec(move || {
            if libc::prctl(libc::PR_SET_PDEATHSIG, libc::SIGTERM) != 0 {
                return Err(std::io::Error::last_os_error());
            }
            // The orchestrator may have died between fork and prctl; then no signal will
            // ever come. Only async-signal-safe calls here (the parent has threads).
            if libc::getppid() != parent {
                libc::_exit(1);
            }
            Ok(())
        });
    }
    cmd
}

/// How a `waitpid` status ended, in words ("exited with code 0", "killed by signal 9").
pub fn describe(status: i32) -> String {
    if libc::WIFSIGNALED(status) {
        format!("killed by signal {}", libc::WTERMSIG(status))
    } else if libc::WIFEXITED(status) {
        format!("exited with code {}", libc::WEXITSTATUS(status))
    } else {
        format!("ended with status {status}")
    }
}

/// Sends `sig` to every pid (children spawned and not yet reaped, so never reused).
pub fn signal_all(pids: &[i32], sig: i32) {
    for &p in pids {
        // SAFETY: kill(2) on pids the caller spawned and have not reaped (so not reused).
        unsafe {
            libc::kill(p, sig);
        }
    }
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
