//! `swarm`: thin entry point; see `cli.rs` for the commands.

use clap::Parser;
use swarmrt_orchestrator::cli::{Cli, Cmd};
use swarmrt_orchestrator::commands;
use swarmrt_orchestrator::error::exit;

fn main() -> std::process::ExitCode {
    let cli = Cli::parse();
    swarmrt_scenario::process::init_logging();
    if let Cmd::Bench(args) = &cli.command {
        // This process becomes `swarm-bench`, which installs its own Ctrl-C handler: none
        // here. Returns only if it could not be started.
        return exit(commands::bench::bench(args));
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
        Cmd::Plan(args) => commands::plan::plan(args),
        Cmd::Clean => commands::clean::clean(),
        Cmd::Certs(args) => commands::certs::certs(args),
        Cmd::Sweep(args) => commands::sweep::sweep(args, rx),
        Cmd::Tune(args) => commands::tune::tune(args, rx),
        // Dispatched above, before the handler exists; here only to keep the match whole.
        Cmd::Bench(args) => commands::bench::bench(args),
        Cmd::View(args) => commands::view::view(args, rx),
        Cmd::Export(args) => commands::export::export(args),
        Cmd::Fuzz(cmd) => commands::fuzz::fuzz(cmd, rx),
    };
    exit(result)
}
