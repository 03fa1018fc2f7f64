//! `swarm-bench`: thin entry point; see `cli.rs` for the commands. `swarm bench <args>` runs
//! this binary with the same arguments.

use clap::Parser;
use swarmrt_benchmarks::cli::{BenchCmd, Cli};
use swarmrt_benchmarks::{child, interruptible, ipc, swarm};
use swarmrt_orchestrator::error::exit;

fn main() -> std::process::ExitCode {
    let cli = Cli::parse();
    swarmrt_scenario::process::init_logging();
    if let BenchCmd::Child(args) = &cli.command {
        // Benchmark children keep the default SIGTERM/SIGINT actions (no Ctrl-C handler), so
        // a parent-death signal ends them at once.
        return match child::main(&args.spec) {
            Ok(()) => std::process::ExitCode::SUCCESS,
            Err(e) => {
                eprintln!("error: bench child: {e}");
                std::process::ExitCode::from(e.exit_code())
            }
        };
    }
    let (tx, rx) = crossbeam_channel::unbounded::<()>();
    if let Err(e) = ctrlc::set_handler(move || {
        let _ = tx.send(());
    }) {
        tracing::warn!("cannot install the Ctrl-C handler: {e}");
    }
    let result = interruptible(rx, |interrupt| match &cli.command {
        BenchCmd::Ipc(args) => ipc::run(&args.into(), interrupt),
        BenchCmd::Swarm(args) => swarm::run(&args.into(), interrupt),
        BenchCmd::Child(args) => child::main(&args.spec),
    });
    exit(result)
}
