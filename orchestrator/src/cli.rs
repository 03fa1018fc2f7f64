//! Command-line definitions (DESIGN section 6): every clap struct of `swarm` is here; each
//! verb's logic is one file in `commands/`.

use std::ffi::OsString;
use std::path::PathBuf;

use clap::{Args, Parser, Subcommand};

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
    /// Plan the routes of a `planner` scenario (seed 002) without flying them.
    Plan(PlanArgs),
    /// Remove the iceoryx2 files and shared memory of runs whose orchestrator is gone.
    Clean,
    /// Make the certificates of a multi-host run: a CA, the world's and every host's
    /// certificate and key (keys 0600), for `quic/` endpoints (docs/security.md).
    Certs(CertsArgs),
    /// Run a scenario over the cross product of varied keys and seeds; write sweep.csv and plots.
    Sweep(SweepArgs),
    /// Tune numeric config keys with noise-resistant PSO against a metric; write tune.csv,
    /// best.toml and plots.
    Tune(TuneArgs),
    /// Measure the IPC and the lock-step swarm against their alternatives (runs `swarm-bench`).
    #[command(disable_help_flag = true)]
    Bench(BenchArgs),
    /// Watch a run in the browser: replay a run directory, or follow one that is still going.
    View(ViewArgs),
    /// Write a run in another format (MCAP, for Foxglove and ROS 2 tooling).
    Export(ExportArgs),
    /// Seeded fault fuzzing of the consensus cores.
    #[command(subcommand)]
    Fuzz(FuzzCmd),
}

/// `swarm run`.
#[derive(Parser, Debug, Clone)]
pub struct RunArgs {
    /// The scenario file.
    pub config: PathBuf,
    /// Override scenario.seed.
    #[arg(long)]
    pub seed: Option<u64>,
    /// Write the run directory here instead of runs/<scenario>-s<seed>-<time>/; it must be
    /// new or empty (see --force).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Replace the earlier run in --out: its files are removed first. Only a run directory
    /// (a config.toml, no subdirectories) is cleared, and never one a running run holds.
    #[arg(long, requires = "out")]
    pub force: bool,
    /// Run the same cores in this process, no IPC (identical results).
    #[arg(long)]
    pub in_process: bool,
    /// Override scenario.ticks.
    #[arg(long)]
    pub ticks: Option<u64>,
    /// Override any config key, e.g. --set radio.loss=0.2 (repeatable).
    #[arg(long = "set", value_name = "KEY=VALUE")]
    pub set: Vec<String>,
    /// Run the robots a hosts file names on other hosts, over Zenoh (docs/multihost.md).
    #[arg(long, value_name = "HOSTS.TOML", conflicts_with = "in_process")]
    pub hosts: Option<PathBuf>,
    /// Allow a hosts file's plain `tcp/` endpoints: no authentication, no encryption, for a
    /// private lab network only (docs/security.md).
    #[arg(long, requires = "hosts")]
    pub insecure_link: bool,
    /// Tick by the wall clock (one tick every scenario.dt seconds) and apply whatever
    /// commands arrived; a robot that missed a tick keeps its last command. Not reproducible.
    #[arg(long, conflicts_with_all = ["in_process", "hosts"])]
    pub realtime: bool,
    /// Serve a live view of the run in the browser (prints its URL); when the run ends the
    /// page becomes its replay, served until Ctrl-C.
    #[arg(long)]
    pub view: bool,
    /// How the --view page is served.
    #[command(flatten)]
    pub serve: ServeArgs,
    /// The ticks done so far, for a caller that shows its own progress (the Python package).
    #[arg(skip)]
    pub ticks_done: Option<std::sync::Arc<std::sync::atomic::AtomicU64>>,
}

/// Where the viewer's page is served.
#[derive(Args, Debug, Clone)]
pub struct ServeArgs {
    /// Port of the page [default: a free one].
    #[arg(long, default_value_t = 0)]
    pub port: u16,
    /// Address to listen on. Beyond loopback every request must carry a random token, which
    /// the printed URL holds (http://ADDR:PORT/?token=...): share that URL to share the run.
    #[arg(long, default_value = "127.0.0.1")]
    pub listen: std::net::IpAddr,
}

/// `swarm view`.
#[derive(Args, Debug, Clone)]
pub struct ViewArgs {
    /// The run directory (finished, crashed or still running).
    pub run_dir: PathBuf,
    /// How the page is served.
    #[command(flatten)]
    pub serve: ServeArgs,
}

/// `swarm export`.
#[derive(Args, Debug, Clone)]
pub struct ExportArgs {
    /// The run directory.
    pub run_dir: PathBuf,
    /// Write the run as an MCAP file with Foxglove's schemas.
    #[arg(long, value_name = "FILE")]
    pub mcap: PathBuf,
}

/// `swarm check`.
#[derive(Parser, Debug)]
pub struct CheckArgs {
    /// The scenario file.
    pub config: PathBuf,
    /// Override any config key (repeatable).
    #[arg(long = "set", value_name = "KEY=VALUE")]
    pub set: Vec<String>,
    /// Also check a hosts file against the config and print which host runs which robots.
    #[arg(long, value_name = "HOSTS.TOML")]
    pub hosts: Option<PathBuf>,
}

/// `swarm certs`.
#[derive(Parser, Debug)]
pub struct CertsArgs {
    /// The hosts file whose world and hosts get certificates.
    pub hosts: PathBuf,
    /// Where to write them (default: the hosts file's `world.certs`, `certs/` beside it).
    #[arg(long)]
    pub out: Option<PathBuf>,
}

/// `swarm plan`.
#[derive(Parser, Debug)]
pub struct PlanArgs {
    /// The scenario file (`behaviour.kind = "planner"`).
    pub config: PathBuf,
    /// Override any config key (repeatable).
    #[arg(long = "set", value_name = "KEY=VALUE")]
    pub set: Vec<String>,
    /// Print JSON for scripts.
    #[arg(long)]
    pub json: bool,
}

/// `swarm sweep`.
#[derive(Parser, Debug, Clone)]
pub struct SweepArgs {
    /// The scenario file.
    #[arg(required_unless_present = "collect")]
    pub config: Option<PathBuf>,
    /// A config key and its values, e.g. --vary radio.loss=0,0.1,0.2 (repeatable). The first
    /// key is the plots' x axis, the second their lines, further ones one plot per value.
    #[arg(
        long = "vary",
        value_name = "KEY=V1,V2,...",
        required_unless_present = "collect"
    )]
    pub vary: Vec<String>,
    /// Seeds per combination: start-seed, start-seed + 1, ...
    #[arg(long, default_value_t = 1, value_parser = clap::value_parser!(u64).range(1..=1_000_000))]
    pub seeds: u64,
    /// First seed [default: the config's scenario.seed].
    #[arg(long)]
    pub start_seed: Option<u64>,
    /// How the runs are made.
    #[command(flatten)]
    pub pool: PoolArgs,
    /// The sweep directory [default: sweeps/<scenario>-<time>/]; an existing one is resumed.
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// With --executor slurm: submit the runs and return at once; `swarm sweep --collect
    /// <out>` (or the same command again) waits for them and writes the rows.
    #[arg(long)]
    pub detach: bool,
    /// Gather the runs a detached sweep submitted into its sweep.csv, plots and summary.md
    /// (waits for those still queued); no other argument is needed.
    #[arg(long, value_name = "SWEEP_DIR", exclusive = true)]
    pub collect: Option<PathBuf>,
    /// A metric to plot and summarise, e.g. radio.dropped (repeatable) [default:
    /// reached_target, down, collisions, and steps_to_target, radio.delivered when present].
    #[arg(long = "metric", value_name = "NAME")]
    pub metric: Vec<String>,
}

/// `swarm tune` (docs/tune.md).
#[derive(Parser, Debug, Clone)]
pub struct TuneArgs {
    /// The scenario file.
    pub config: PathBuf,
    /// A numeric config key and its bounds, e.g. --param behaviour.speed=0.1:1.5 (repeatable).
    #[arg(long = "param", value_name = "KEY=LO:HI", required = true)]
    pub param: Vec<String>,
    /// The metric of metrics.json to optimise, a dotted path: steps_to_target, radio.dropped,
    /// flocking.fitness.
    #[arg(long, value_name = "METRIC")]
    pub fitness: String,
    /// Maximise the fitness [default: minimise].
    #[arg(long)]
    pub maximize: bool,
    /// Particles P.
    #[arg(long, default_value_t = 7, value_parser = clap::value_parser!(u64).range(1..=10_000))]
    pub particles: u64,
    /// Iterations; a finished tune run again with more iterations goes on.
    #[arg(long, default_value_t = 25, value_parser = clap::value_parser!(u64).range(1..=1_000_000))]
    pub iterations: u64,
    /// Evaluations per iteration E: P new positions plus E - P personal-best re-evaluations
    /// spread evenly (a multiple of P, at least P) [default: 2P].
    #[arg(long)]
    pub evaluations: Option<u64>,
    /// Seed of the swarm and of the run seeds it derives for each evaluation.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Cycle the evaluations through N run seeds start-seed, start-seed + 1, ... instead of
    /// deriving one per evaluation from --seed.
    #[arg(long, value_parser = clap::value_parser!(u64).range(1..=1_000_000))]
    pub seeds: Option<u64>,
    /// First seed of --seeds [default: the config's scenario.seed].
    #[arg(long, requires = "seeds")]
    pub start_seed: Option<u64>,
    /// Inertia weight w.
    #[arg(long, default_value_t = 0.729)]
    pub inertia: f64,
    /// Weight c1 of the personal best.
    #[arg(long, default_value_t = 1.494)]
    pub c1: f64,
    /// Weight c2 of the neighbourhood best.
    #[arg(long, default_value_t = 1.494)]
    pub c2: f64,
    /// Largest velocity component, as a fraction of the parameter's bound width.
    #[arg(long, default_value_t = 1.0)]
    pub vmax: f64,
    /// How the runs are made.
    #[command(flatten)]
    pub pool: PoolArgs,
    /// The tune directory [default: runs/tune-<scenario>-<time>/]; an existing one is resumed.
    #[arg(long)]
    pub out: Option<PathBuf>,
}

/// The run pool of `swarm sweep` and `swarm tune`: how many runs at once, in which mode, with
/// which overrides.
#[derive(Args, Debug, Clone)]
pub struct PoolArgs {
    /// Runs at once [default: 1 on this machine (at most 256); per host with --executor ssh;
    /// with --executor slurm, as many as the cluster gives (the array's `%N` limit)].
    #[arg(long, value_parser = clap::value_parser!(u64).range(1..=1_000_000))]
    pub jobs: Option<u64>,
    /// Run every scenario with the same cores in one process each, no IPC (identical results).
    #[arg(long)]
    pub in_process: bool,
    /// Override a config key in every run, e.g. --set scenario.ticks=300 (repeatable).
    #[arg(long = "set", value_name = "KEY=VALUE")]
    pub set: Vec<String>,
    /// Where the runs are made [default: local, or the --executor-config file's `kind`]:
    /// `local` on this machine, `slurm` as job arrays of a Slurm cluster, `ssh` on the hosts
    /// of --hosts (docs/cluster.md).
    #[arg(long, value_enum)]
    pub executor: Option<ExecutorKind>,
    /// A TOML file with an `[executor]` section (kind, hosts, partition, time, mem,
    /// sbatch_args, jobs, runs_per_task, poll_seconds); the command line's flags win over it.
    #[arg(long, value_name = "FILE")]
    pub executor_config: Option<PathBuf>,
    /// The hosts of --executor ssh: a hosts file's `[[host]]` names and launchers (the file of
    /// `swarm run --hosts` serves), with an optional `jobs` and `swarm` path per host.
    #[arg(long, value_name = "HOSTS.TOML")]
    pub hosts: Option<PathBuf>,
    /// Slurm partition of the runs (`sbatch --partition`).
    #[arg(long, help_heading = "Slurm")]
    pub partition: Option<String>,
    /// Slurm time limit per run (`sbatch --time`), e.g. 00:10:00.
    #[arg(long, help_heading = "Slurm")]
    pub time: Option<String>,
    /// Slurm memory per run (`sbatch --mem`), e.g. 2G.
    #[arg(long, help_heading = "Slurm")]
    pub mem: Option<String>,
    /// Another `sbatch` argument, e.g. --sbatch-arg=--qos=short (repeatable).
    #[arg(
        long = "sbatch-arg",
        value_name = "ARG",
        allow_hyphen_values = true,
        help_heading = "Slurm"
    )]
    pub sbatch_args: Vec<String>,
    /// Runs one Slurm task makes one after the other [default: 1]: many short runs pay
    /// Slurm's start-up of a task once per N runs.
    #[arg(long, value_name = "N", help_heading = "Slurm")]
    pub runs_per_task: Option<u64>,
}

/// Where `swarm sweep` and `swarm tune` make their runs.
#[derive(clap::ValueEnum, serde::Deserialize, Debug, Clone, Copy, PartialEq, Eq)]
#[serde(rename_all = "lowercase")]
pub enum ExecutorKind {
    /// Child `swarm run` processes on this machine, --jobs at a time.
    Local,
    /// One Slurm job array per batch of runs (`sbatch --array`), on a filesystem the nodes share.
    Slurm,
    /// Child `swarm run`s on the hosts of --hosts, through their launchers (`ssh host`), --jobs
    /// per host, on a filesystem the hosts share.
    Ssh,
}

/// `swarm bench <what> [args]`: everything after `bench` goes to `swarm-bench` untouched,
/// `--help` included, so `swarm bench --help` lists what `swarm-bench` measures.
#[derive(Args, Debug, Clone)]
pub struct BenchArgs {
    /// `ipc` or `swarm` and their options (see `swarm bench --help`).
    #[arg(
        trailing_var_arg = true,
        allow_hyphen_values = true,
        value_name = "ARGS"
    )]
    pub args: Vec<OsString>,
}

/// `swarm fuzz <what>`.
#[derive(Subcommand, Debug, Clone)]
pub enum FuzzCmd {
    /// The Raft-style election and replicated log: seeded faults, safety checked every tick,
    /// liveness after the faults heal. Exit 0 when every seed holds.
    Consensus(ConsensusArgs),
    /// Measure ticks to the first leader and to re-election after the leader crashes.
    Election(ElectionArgs),
    /// Measure how often the quadrant leader choice leaves exactly one leader per group.
    Quadrant(QuadrantArgs),
}

/// `swarm fuzz consensus`.
#[derive(Args, Debug, Clone)]
pub struct ConsensusArgs {
    /// Number of seeds to run.
    #[arg(long)]
    pub seeds: u64,
    /// First seed.
    #[arg(long, default_value_t = 0)]
    pub start_seed: u64,
    /// Print every seed's case and outcome.
    #[arg(long)]
    pub verbose: bool,
    /// Write each failing seed's note stream to DIR/seed-<S>.events.jsonl.
    #[arg(long, value_name = "DIR")]
    pub dump: Option<PathBuf>,
    /// Run a known bug of the Raft core instead of the real one (vote-for-anyone,
    /// no-up-to-date-check, keep-conflicting-entries, commit-earlier-term,
    /// forget-vote-on-restart, accept-stale-append, no-step-down, apply-before-commit).
    #[arg(long, value_name = "NAME")]
    pub mutant: Option<String>,
}

/// `swarm fuzz election`.
#[derive(Args, Debug, Clone)]
pub struct ElectionArgs {
    /// Robot counts.
    #[arg(long, value_delimiter = ',', default_value = "9,50")]
    pub robots: Vec<u32>,
    /// Bernoulli loss probabilities.
    #[arg(long, value_delimiter = ',', default_value = "0,0.2,0.4")]
    pub loss: Vec<f64>,
    /// Runs (seeds) per combination.
    #[arg(long, default_value_t = 21)]
    pub runs: u64,
    /// First seed.
    #[arg(long, default_value_t = 0)]
    pub start_seed: u64,
    /// Ticks between the first leader and its crash.
    #[arg(long, default_value_t = 100)]
    pub leader_wait: u64,
}

/// `swarm fuzz quadrant`.
#[derive(Args, Debug, Clone)]
pub struct QuadrantArgs {
    /// Trials per group size (3 to 9 robots).
    #[arg(long, default_value_t = 200)]
    pub trials: u64,
    /// Bernoulli loss of the claims.
    #[arg(long, default_value_t = 0.0)]
    pub loss: f64,
    /// Square metres per robot of the disc the group is placed in (larger: sparser groups,
    /// robots that do not all see each other).
    #[arg(long, default_value_t = 1.0)]
    pub area_per_robot: f64,
    /// First seed.
    #[arg(long, default_value_t = 0)]
    pub start_seed: u64,
}
