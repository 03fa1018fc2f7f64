//! Command-line definitions of `swarm-bench` (what `swarm bench <args>` runs; DESIGN
//! section 6).

use std::path::PathBuf;

use clap::{Args, Parser, Subcommand};

use crate::ipc::IpcOptions;
use crate::peers::{Fault, Peer, parse_peers};
use crate::swarm::SwarmOptions;

/// The value of `--peers`: the floors to run, in table order.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct PeerList(pub Vec<Peer>);

fn peer_list(s: &str) -> Result<PeerList, String> {
    parse_peers(&[s.to_string()]).map(PeerList)
}

/// Measure the IPC and the lock-step swarm against their alternatives.
#[derive(Parser, Debug)]
#[command(name = "swarm-bench", version)]
pub struct Cli {
    /// What to measure.
    #[command(subcommand)]
    pub command: BenchCmd,
}

/// `swarm bench <what>`.
#[derive(Subcommand, Debug, Clone)]
pub enum BenchCmd {
    /// iceoryx2 against Unix sockets, TCP and a crossbeam channel; fan-out; loss accounting.
    Ipc(IpcArgs),
    /// Lock-step ticks/s against robot process count, against a bare iceoryx2 floor.
    Swarm(SwarmArgs),
    /// One process of a benchmark (started by `swarm bench`, not by hand).
    #[command(hide = true)]
    Child(ChildArgs),
}

/// `swarm bench ipc`.
#[derive(Args, Debug, Clone)]
pub struct IpcArgs {
    /// Payload sizes in bytes (each at least 64).
    #[arg(
        long,
        value_delimiter = ',',
        default_value = "64,1024,4096,65536,1048576"
    )]
    pub payload: Vec<usize>,
    /// Seconds of measurement per transport and payload (half round trips, half throughput).
    #[arg(long, default_value_t = 1.0)]
    pub secs: f64,
    /// Subscriber process counts for the fan-out measurement.
    #[arg(long, value_delimiter = ',', default_value = "1,10,100,500")]
    pub fanout: Vec<usize>,
    /// Print the results as one JSON document instead of tables.
    #[arg(long)]
    pub json: bool,
    /// Write results.json and the plots here instead of bench/ipc-<time>/.
    #[arg(long)]
    pub out: Option<PathBuf>,
}

/// `swarm bench swarm`.
#[derive(Args, Debug, Clone)]
pub struct SwarmArgs {
    /// Robot process counts to run.
    #[arg(long, value_delimiter = ',', default_value = "10,50,100,200,500")]
    pub agents: Vec<u32>,
    /// Lock-step ticks per run (the runtime and the floor alike).
    #[arg(long, default_value_t = 300)]
    pub ticks: u64,
    /// Robot counts for the in-process measurement (same cores, no IPC).
    #[arg(long, value_delimiter = ',', default_value = "100,1000,10000")]
    pub in_process_agents: Vec<u32>,
    /// Ticks per in-process measurement (it also stops after 20 s).
    #[arg(long, default_value_t = 100)]
    pub in_process_ticks: u64,
    /// Rounds of runtime and floor runs, alternated; the ratio is the median over rounds
    /// (the floor's tick varies by up to 2x between runs on a shared VM).
    #[arg(long, default_value_t = 1)]
    pub rounds: u32,
    /// The floors each round runs after the runtime: the same lock-step with empty cores over
    /// iceoryx2 (`iox2`, the runtime's services), Unix domain sockets (`uds`) and Zenoh peers
    /// (`zenoh`); a comma-separated list, `all` or `none`.
    #[arg(long, default_value = "all", value_parser = peer_list)]
    pub peers: PeerList,
    /// Test only: peer robot ROBOT kills itself at tick TICK (`ROBOT@TICK`).
    #[arg(long, hide = true, value_parser = Fault::parse)]
    pub peer_fault: Option<Fault>,
    /// The scenario the runtime runs (robots.count and the map are set per N).
    #[arg(long, default_value = "configs/goto_simple.toml")]
    pub config: PathBuf,
    /// Print the results as one JSON document instead of tables.
    #[arg(long)]
    pub json: bool,
    /// Write results.json, the runs and the plots here instead of bench/swarm-<time>/.
    #[arg(long)]
    pub out: Option<PathBuf>,
}

impl From<&IpcArgs> for IpcOptions {
    fn from(a: &IpcArgs) -> IpcOptions {
        IpcOptions {
            payload: a.payload.clone(),
            secs: a.secs,
            fanout: a.fanout.clone(),
            json: a.json,
            out: a.out.clone(),
        }
    }
}

impl From<&SwarmArgs> for SwarmOptions {
    fn from(a: &SwarmArgs) -> SwarmOptions {
        SwarmOptions {
            agents: a.agents.clone(),
            ticks: a.ticks,
            in_process_agents: a.in_process_agents.clone(),
            in_process_ticks: a.in_process_ticks,
            rounds: a.rounds,
            peers: a.peers.0.clone(),
            peer_fault: a.peer_fault,
            config: a.config.clone(),
            json: a.json,
            out: a.out.clone(),
        }
    }
}

/// The hidden child subcommand: what this process is to do, as JSON.
#[derive(Args, Debug, Clone)]
pub struct ChildArgs {
    /// A `child::ChildSpec` as JSON.
    #[arg(long)]
    pub spec: String,
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::CommandFactory;

    #[test]
    fn command_line_is_consistent() {
        Cli::command().debug_assert();
    }

    #[test]
    fn options_carry_the_arguments_and_defaults() {
        let cli =
            Cli::try_parse_from(["swarm-bench", "ipc", "--payload", "64,128", "--json"]).unwrap();
        let BenchCmd::Ipc(args) = &cli.command else {
            panic!("{cli:?}");
        };
        let o = IpcOptions::from(args);
        assert_eq!(o.payload, vec![64, 128]);
        assert_eq!(o.secs, 1.0);
        assert_eq!(o.fanout, vec![1, 10, 100, 500]);
        assert!(o.json);
        assert_eq!(o.out, None);

        let cli =
            Cli::try_parse_from(["swarm-bench", "swarm", "--agents", "3", "--out", "x"]).unwrap();
        let BenchCmd::Swarm(args) = &cli.command else {
            panic!("{cli:?}");
        };
        let o = SwarmOptions::from(args);
        assert_eq!(o.agents, vec![3]);
        assert_eq!(o.ticks, 300);
        assert_eq!(o.in_process_agents, vec![100, 1000, 10000]);
        assert_eq!(o.in_process_ticks, 100);
        assert_eq!(o.rounds, 1);
        assert_eq!(o.peers, Peer::ALL.to_vec());
        assert_eq!(o.peer_fault, None);
        assert_eq!(o.config, PathBuf::from("configs/goto_simple.toml"));
        assert_eq!(o.out, Some(PathBuf::from("x")));

        let cli = Cli::try_parse_from([
            "swarm-bench",
            "swarm",
            "--peers",
            "zenoh,uds",
            "--peer-fault",
            "1@5",
        ])
        .unwrap();
        let BenchCmd::Swarm(args) = &cli.command else {
            panic!("{cli:?}");
        };
        let o = SwarmOptions::from(args);
        assert_eq!(o.peers, vec![Peer::Uds, Peer::Zenoh]);
        assert_eq!(o.peer_fault, Some(Fault { robot: 1, tick: 5 }));
        let cli = Cli::try_parse_from(["swarm-bench", "swarm", "--peers", "none"]).unwrap();
        let BenchCmd::Swarm(args) = &cli.command else {
            panic!("{cli:?}");
        };
        assert!(SwarmOptions::from(args).peers.is_empty());
        assert!(Cli::try_parse_from(["swarm-bench", "swarm", "--peers", "tcp"]).is_err());
    }
}
