//! The pieces of `swarm sweep` (the command itself is `commands/sweep.rs`): what to run
//! ([`plan`]), running it ([`runner`], on this machine or through [`slurm`] as the
//! [`executor`] says) and what is written from its rows ([`report`]). The
//! rows' file (`sweep.csv`), their statistics and the figures are `swarmrt_analysis`'s.

pub mod executor;
pub mod plan;
pub mod report;
pub mod runner;
pub mod slurm;
