//! Command-line definitions (DESIGN section 6).

use clap::{Parser, Subcommand};
use std::path::PathBuf;

/// Robot swarms as real processes over iceoryx2: run, check and clean up scenarios.
#[derive(Parser, Debug)]
#[command(name = "swarm", version, about)]
pub struct Cli {
    /// What to do.
    #[command(subcommand)]
    pub command: Cmd,
}

/// The subcommands.
#[derive(Subcommand, Debug)]
pub enum Cmd {
    /// Run a scenario and write a run directory.
    Run(RunArgs),
    /// Validate a config and print it fully resolved.
    Check(CheckArgs),
    /// Remove the iceoryx2 files and shared memory of runs whose orchestrator is gone.
    Clean,
    /// Run a scenario over the cross product of varied keys and seeds; write sweep.csv and plots.
    Sweep(crate::commands::sweep::SweepArgs),
    /// Measure the IPC and the lock-step swarm against their alternatives (runs `swarm-bench`).
    #[command(disable_help_flag = true)]
    Bench(crate::commands::bench::BenchArgs),
    /// Seeded fault fuzzing of the consensus cores.
    #[command(subcommand)]
    Fuzz(crate::commands::fuzz::FuzzCmd),
}

/// `swarm run`.
#[derive(Parser, Debug, Clone)]
pub struct RunArgs {
    /// The scenario file.
    pub config: PathBuf,
    /// Override scenario.seed.
    #[arg(long)]
    pub seed: Option<u64>,
    /// Write the run directory here instead of runs/<scenario>-s<seed>-<time>/.
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Run the same cores in this process, no IPC (identical results).
    #[arg(long)]
    pub in_process: bool,
    /// Override scenario.ticks.
    #[arg(long)]
    pub ticks: Option<u64>,
    /// Override any config key, e.g. --set radio.loss=0.2 (repeatable).
    #[arg(long = "set", value_name = "KEY=VALUE")]
    pub set: Vec<String>,
}

/// `swarm check`.
#[derive(Parser, Debug)]
pub struct CheckArgs {
    /// The scenario file.
    pub config: PathBuf,
    /// Override any config key (repeatable).
    #[arg(long = "set", value_name = "KEY=VALUE")]
    pub set: Vec<String>,
}
