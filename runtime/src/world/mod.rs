//! The world process (`swarm-world`): its command line, its loop and its tick timing.

pub mod cli;
pub mod shell;
pub mod timing;
