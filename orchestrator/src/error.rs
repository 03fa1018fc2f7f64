//! User errors (exit 2, one line) versus internal failures (exit 1).

use thiserror::Error;

/// A failure of a `swarm` command.
#[derive(Debug, Error)]
pub enum SwarmError {
    /// The user asked for something invalid: a bad config, value or path.
    #[error("{0}")]
    User(String),
    /// Something broke that is not the user's fault.
    #[error(transparent)]
    Internal(#[from] anyhow::Error),
    /// Ctrl-C stopped work that can be resumed (a sweep); the message says how.
    #[error("{0}")]
    Interrupted(String),
}

impl SwarmError {
    /// The process exit code DESIGN section 6 promises.
    pub fn exit_code(&self) -> u8 {
        match self {
            SwarmError::User(_) => 2,
            SwarmError::Internal(_) => 1,
            // 128 + SIGINT, as shells report a process stopped by Ctrl-C.
            SwarmError::Interrupted(_) => 130,
        }
    }
}

impl From<swarmrt_scenario::ConfigError> for SwarmError {
    fn from(e: swarmrt_scenario::ConfigError) -> Self {
        SwarmError::User(e.to_string())
    }
}

impl From<std::io::Error> for SwarmError {
    fn from(e: std::io::Error) -> Self {
        SwarmError::Internal(e.into())
    }
}

/// Result of a `swarm` command.
pub type SwarmResult<T> = Result<T, SwarmError>;

/// Prints a failure (one line for a user error) and turns it into the exit code DESIGN
/// section 6 promises; shared by `swarm` and `swarm-bench`.
pub fn exit(result: SwarmResult<()>) -> std::process::ExitCode {
    match result {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            match &e {
                SwarmError::User(msg) => eprintln!("error: {msg}"),
                SwarmError::Internal(err) => eprintln!("error: {err:#}"),
                SwarmError::Interrupted(msg) => eprintln!("{msg}"),
            }
            std::process::ExitCode::from(e.exit_code())
        }
    }
}
