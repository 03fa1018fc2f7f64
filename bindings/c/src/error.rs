//! The one error type of the library; C sees its text (`swarmrt_robot_error`, `err` buffers).

/// Why opening a robot, loading a config or a tick failed.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// An environment variable the orchestrator sets is missing or malformed.
    #[error("{var}: {message}")]
    Env {
        /// The variable (`SWARMRT_ROBOT`, ...).
        var: &'static str,
        /// What is wrong with it.
        message: String,
    },
    /// The config file could not be read or is not TOML.
    #[error("config {path}: {message}")]
    Config {
        /// The file (or `<text>` for a parsed string).
        path: String,
        /// What went wrong.
        message: String,
    },
    /// iceoryx2 failed: creating the node, opening the services or a port, sending, waiting.
    #[error("iceoryx2: {0}")]
    Ipc(String),
    /// The world speaks another protocol version, or its sample has no slot for this robot.
    #[error("{0}")]
    Protocol(String),
}

impl From<swarmrt_ipc::IpcError> for Error {
    fn from(e: swarmrt_ipc::IpcError) -> Self {
        Error::Ipc(e.to_string())
    }
}
