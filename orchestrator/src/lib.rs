//! The `swarm` orchestrator: spawns a world and one process per robot, watches them,
//! writes run directories. Also runs the same cores in-process.
#![warn(missing_docs)]

pub use swarmrt_ipc::cleanup;
pub mod binaries;
pub mod cli;
pub mod commands;
pub mod config;
pub mod error;
pub mod hosts;
pub mod metrics;
pub mod processes;
pub mod run_dir;
pub mod sweep;
pub mod tune;
