//! `swarm`: thin entry point; see `cli.rs` for the commands.

use clap::Parser;
use swarmrt_orchestrator::cli::{Cli, Cmd};
use swarmrt_orchestrator::commands;
use swarmrt_orchestrator::error::SwarmError;

fn main() -> std::process::ExitCode {
    let cli = Cli::parse();
    swarmrt_scenario::process::init_logging();
    if let Cmd::Bench(commands::bench::BenchCmd::Child(args)) = &cli.command {
        // Benchmark children keep the default SIGTERM/SIGINT actions (no Ctrl-C handler).
        return commands::bench::child(args);
    }
    let (tx, rx) = crossbeam_channel::unbounded::<()>();
    if let Err(e) = ctrlc::set_handler(move || {
        let _ = tx.send(());
    }) {
        tracing::warn!("cannot install the Ctrl-C handler: {e}");
    }
    let result = match &cli.command {
        Cmd::Run(args) => commands::run::run(args, rx).map(|_| ()),
        Cmd::Check(args) => commands::check::check(args),
        Cmd::Clean => commands::clean::clean(),
        Cmd::Sweep(args) => commands::sweep::sweep(args, rx),
        Cmd::Bench(cmd) => commands::bench::bench(cmd, rx),
        Cmd::Fuzz(cmd) => commands::fuzz::fuzz(cmd),
    };
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
