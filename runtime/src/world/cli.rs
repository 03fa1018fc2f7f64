//! Command line of the `swarm-world` process: the world process of one run. Started by `swarm run`, not by hand.

use super::shell;
use clap::Parser;

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
    /// Which directory `--out` must be (`DEV:INO`, as `swarm run` checked it): any other,
    /// such as a link swapped in at its path, is refused before a record is written.
    #[arg(long)]
    out_id: Option<swarmrt_scenario::safe_fs::DirId>,
    /// The run's hosts.toml: the robots it names run on other hosts, reached over Zenoh.
    #[arg(long)]
    hosts: Option<std::path::PathBuf>,
    /// Tick by the wall clock, one tick every `scenario.dt`, applying whatever commands
    /// arrived; a robot that missed the tick keeps its last command.
    #[arg(long, conflicts_with = "hosts")]
    realtime: bool,
    /// The run's certificates (the hosts file's `world.certs`, resolved by `swarm run`; the
    /// copy of the hosts file in the run directory is not where they are).
    #[arg(long, requires = "hosts")]
    certs: Option<std::path::PathBuf>,
    /// Accept the hosts file's plain `tcp/` endpoints (`swarm run --insecure-link`).
    #[arg(long, requires = "hosts")]
    insecure_link: bool,
}

/// Entry point of the process (the `swarm-world` binary in the orchestrator package).
///
/// `vocabulary` is the robots' (the binary passes `swarmrt_agent::registry::VOCABULARY`; the
/// world crate does not depend on any behaviour).
pub fn main(vocabulary: swarmrt_protocol::Vocabulary) -> std::process::ExitCode {
    let args = Args::parse();
    swarmrt_scenario::process::init_logging();
    let span = tracing::info_span!("world", run_id = %args.run_id);
    let _enter = span.enter();
    let (run, cfg) = match swarmrt_scenario::process::load_run(&args.run_id, &args.config) {
        Ok(x) => x,
        Err(e) => {
            tracing::error!("{e}");
            return std::process::ExitCode::from(2);
        }
    };
    let hosts = match &args.hosts {
        None => None,
        Some(path) => {
            let file = swarmrt_hosts::HostsFile::load(path, cfg.robots.count);
            let text = std::fs::read_to_string(&args.config);
            match (file, text) {
                (Ok(mut f), Ok(t)) => {
                    if let Some(dir) = &args.certs {
                        f.certs = dir.clone();
                    }
                    if !f.is_secure() && !args.insecure_link {
                        tracing::error!("{}", f.insecure_refusal(path));
                        return std::process::ExitCode::from(2);
                    }
                    Some((f, swarmrt_hosts::link::layout(&t)))
                }
                (Err(e), _) => {
                    tracing::error!("{e}");
                    return std::process::ExitCode::from(2);
                }
                (_, Err(e)) => {
                    tracing::error!("{}: {e}", args.config.display());
                    return std::process::ExitCode::from(2);
                }
            }
        }
    };
    let hosts = hosts.as_ref().map(|(f, l)| (f, *l));
    let mode = if args.realtime {
        super::Mode::Realtime
    } else {
        super::Mode::LockStep
    };
    let opened = match args.out_id {
        Some(id) => swarmrt_scenario::safe_fs::OutDir::open_expected(&args.out, id),
        None => swarmrt_scenario::safe_fs::OutDir::open(&args.out),
    };
    let out = match opened {
        Ok(out) => out,
        Err(e) => {
            tracing::error!("--out {}: {e}", args.out.display());
            return std::process::ExitCode::from(2);
        }
    };
    match shell::run(&run, &cfg, &out, vocabulary, hosts, mode) {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            tracing::error!("world failed: {e}");
            std::process::ExitCode::from(1)
        }
    }
}
