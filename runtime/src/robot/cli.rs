//! Command line of the `swarm-agent` process: one robot process. Started by `swarm run`, not by hand.

use super::shell;
use clap::Parser;
use swarmrt_agent::consensus::storage::StoreError;

/// One robot of a swarmrt run.
#[derive(Parser, Debug)]
#[command(name = "swarm-agent")]
#[command(version, about)]
struct Args {
    /// Run id (lower-case hex) naming the run's iceoryx2 services.
    #[arg(long)]
    run_id: String,
    /// The robot id, 0..robots.count.
    #[arg(long)]
    robot: u32,
    /// The resolved config of the run.
    #[arg(long)]
    config: std::path::PathBuf,
    /// How many times the fault schedule restarted this robot before this process.
    #[arg(long, default_value_t = 0)]
    incarnation: u32,
    /// Stable storage directory for the robot's persistent Raft state (with
    /// `consensus.storage` on).
    #[arg(long)]
    storage: Option<std::path::PathBuf>,
    /// The id of the first robot in this host's observation sample: a host running robots
    /// 40..80 of a run publishes only their 40 slots, so robot 45 reads slot 5.
    #[arg(long, default_value_t = 0)]
    slot_offset: u32,
}

/// Entry point of the process (the `swarm-agent` binary in the orchestrator package).
pub fn main() -> std::process::ExitCode {
    let args = Args::parse();
    swarmrt_scenario::process::init_logging();
    let span = tracing::info_span!("robot", agent_id = args.robot);
    let _enter = span.enter();
    let (run, mut cfg) = match swarmrt_scenario::process::load_run(&args.run_id, &args.config) {
        Ok(x) => x,
        Err(e) => {
            tracing::error!("{e}");
            return std::process::ExitCode::from(2);
        }
    };
    // The orchestrator resolved `[behaviour]` already; a hand-edited config is refused here
    // with its key rather than found out by a panic in the first tick.
    if let Err(e) = swarmrt_agent::registry::resolve(&mut cfg, &args.config.display().to_string()) {
        tracing::error!("{e}");
        return std::process::ExitCode::from(2);
    }
    if args.robot >= cfg.robots.count || args.slot_offset > args.robot {
        tracing::error!(
            robots = cfg.robots.count,
            slot_offset = args.slot_offset,
            "robot id out of range"
        );
        return std::process::ExitCode::from(2);
    }
    match shell::run(
        &run,
        &cfg,
        args.robot,
        args.incarnation,
        args.storage.as_deref(),
        args.slot_offset,
    ) {
        // Exit code 0 means exactly "the world ended the run", so the orchestrator can tell a
        // clean end from a robot that vanished mid-run.
        Ok(shell::Exit::Shutdown) => std::process::ExitCode::SUCCESS,
        Ok(shell::Exit::Terminated) => std::process::ExitCode::from(143),
        Err(e) => {
            // Corrupt stable storage: one plain line saying where and what to do, exit 2.
            if let Some(StoreError::Corrupt(c)) = e.downcast_ref::<StoreError>() {
                eprintln!("{c}");
                return std::process::ExitCode::from(2);
            }
            tracing::error!("robot failed: {e}");
            std::process::ExitCode::from(1)
        }
    }
}
