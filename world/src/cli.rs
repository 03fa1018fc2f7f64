//! Command line of the `swarm-world` process: the world process of one run. Started by `swarm run`, not by hand.

use crate::shell;
use clap::Parser;
use swarmrt_protocol::config::Config;
use swarmrt_protocol::services::{RunServices, valid_run_id};

/// The world process of a swarmrt run.
#[derive(Parser, Debug)]
#[command(name = "swarm-world")]
#[command(version, about)]
struct Args {
    /// Run id (lower-case hex) naming the run's iceoryx2 services.
    #[arg(long)]
    run_id: String,
    /// The resolved config of the run.
    #[arg(long)]
    config: std::path::PathBuf,
    /// The run directory to write trajectory.csv and events.jsonl into.
    #[arg(long)]
    out: std::path::PathBuf,
}

/// Entry point of the process (the `swarm-world` binary in the orchestrator package).
pub fn main() -> std::process::ExitCode {
    let args = Args::parse();
    swarmrt_protocol::logging::init();
    let span = tracing::info_span!("world", run_id = %args.run_id);
    let _enter = span.enter();
    if !valid_run_id(&args.run_id) {
        tracing::error!(run_id = %args.run_id, "invalid run id");
        return std::process::ExitCode::from(2);
    }
    let cfg = match Config::load(&args.config, &[]) {
        Ok(c) => c,
        Err(e) => {
            tracing::error!("{e}");
            return std::process::ExitCode::from(2);
        }
    };
    match shell::run(&RunServices::new(&args.run_id), &cfg, &args.out) {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            tracing::error!("world failed: {e}");
            std::process::ExitCode::from(1)
        }
    }
}
