//! Multi-process mode: spawn the world and one process per robot, watch them, tell the world
//! when a robot dies, stop everything cleanly on completion, Ctrl-C or a crashed child, and
//! remove the run's iceoryx2 resources on every path.
//!
//! Threads feed one channel the main loop sleeps on: the world's stdout reader (reports), one
//! small reaper per child (`waitpid` on exactly that child, so iceoryx2 never sees zombies)
//! and the Ctrl-C relay. No polling. Every process of the run (the world, this host's robots,
//! the remote hosts' launchers) is one entry of the runtime's `Supervisor`, whose orders the
//! one `launch::carry_out` performs.
//!
//! - [`local`]: the run's main loop over the process table, from the world's first report
//!   to the last process seen out.
//! - [`phase`]: where the run is (starting, running, stopping, done), its transitions.
//! - [`shell`]: the orchestrator's side of the supervisor's orders: spawns, and what a
//!   robot's or a host's end tells the world.
//! - [`world`]: the `swarm-world` process: its command, start, reports and controls.
//! - [`remote`]: the robots of remote hosts: their orders and their processes' records.

mod local;
mod phase;
mod remote;
mod shell;
mod world;

use std::collections::BTreeMap;
use std::path::Path;
use std::time::{Duration, Instant};
use swarmrt_scenario::safe_fs::OutDir;

use anyhow::Context;
use crossbeam_channel::{Receiver, Sender};
use swarmrt_protocol::control::WorldReport;
use swarmrt_protocol::services::RunServices;
use swarmrt_scenario::Config;

use crate::hosts::{HostMsg, RunHosts};
use swarmrt_ipc::cleanup;
use swarmrt_runtime::supervisor::Pid;
use swarmrt_runtime::supervisor::launch::Launch;

use local::LocalRun;
pub use swarmrt_scenario::process::{child_command, describe, signal_all};

/// How long robots get to exit on the world's shutdown sample before they are sent SIGTERM
/// (a robot that subscribed after that sample never sees it). The wait ends as soon as all
/// have gone, so only a robot that missed the sample pays it: 10 s leaves a loaded 2-core
/// machine room (a thawed robot once took more than 1 s there, `tests/tests/e2e/faults.rs`).
const SHUTDOWN_GRACE: Duration = Duration::from_secs(10);
/// How long a host launcher's exit waits for the end of its stdout, which a process it
/// started may still hold open.
const LAUNCHER_EOF_WAIT: Duration = Duration::from_secs(2);
/// How long children get after SIGTERM before they are killed.
const EXIT_GRACE: Duration = Duration::from_secs(10);

/// How `describe` renders a robot's clean exit after the world's shutdown sample.
const CLEAN_EXIT: &str = "exited with code 0";

/// What the supervisor learned about a run.
#[derive(Debug, Default)]
pub struct ProcessOutcome {
    /// The world's final report, if it made one.
    pub world_metrics: Option<serde_json::Value>,
    /// True when the run ended early (Ctrl-C or a Stop).
    pub interrupted: bool,
    /// Set when the world itself failed; the run's records stop at its last tick.
    pub world_failure: Option<String>,
    /// Robots whose process ended before the run did, with how.
    pub unscheduled_deaths: BTreeMap<u32, String>,
    /// Milliseconds from the world listening until every robot said hello.
    pub startup_ms: Option<u64>,
    /// The run id naming the run's iceoryx2 resources.
    pub run_id: String,
    /// Every robot process started, in start order, with how it ended.
    pub processes: Vec<RobotProcess>,
    /// Each remote host's counters (`--hosts` runs).
    pub hosts: Option<serde_json::Value>,
}

/// One robot process of a run (`metrics.json` → `processes`).
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct RobotProcess {
    /// The robot it ran.
    pub robot: u32,
    /// 0 for the robot's first process, then one more per scheduled restart.
    pub incarnation: u32,
    /// Its pid.
    pub pid: i32,
    /// How it ended ("exited with code 0" after the world's shutdown sample).
    pub end: String,
    /// True when the fault schedule killed it (a kill or a restart).
    pub scheduled_kill: bool,
    /// The remote host it ran on (`--hosts` runs; its pid is that host's).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub host: Option<String>,
}

enum Msg {
    Report(WorldReport),
    Host(usize, HostMsg),
    WorldEof,
    Exited { pid: i32, how: String },
    Interrupt,
}

/// A fresh run id: random, used only in names (never in a decision).
pub fn new_run_id() -> String {
    use std::hash::{BuildHasher, RandomState};
    let h = RandomState::new().hash_one((std::process::id(), Instant::now()));
    format!("{:012x}", h & 0xffff_ffff_ffff)
}

pub use crate::binaries::sibling_binary;

/// The reaper's report of `pid`'s end, as a message on `tx`.
fn exited(tx: &Sender<Msg>) -> impl FnOnce(Pid, String) + Send + 'static {
    let tx = tx.clone();
    move |pid, how| {
        let _ = tx.send(Msg::Exited { pid, how });
    }
}

/// Runs `cfg` as processes; records go to `dir`. `progress` sees completed ticks.
pub fn run(
    cfg: &Config,
    config_path: &Path,
    dir: &OutDir,
    interrupt: Receiver<()>,
    progress: impl FnMut(u64),
) -> anyhow::Result<ProcessOutcome> {
    let opts = RunOptions::default();
    run_on_hosts(cfg, config_path, dir, &opts, interrupt, progress)
}

/// How a multi-process run differs from the default lock-step run on one host.
#[derive(Debug, Default)]
pub struct RunOptions<'a> {
    /// The robots a hosts file names run on other hosts (`swarm run --hosts`).
    pub hosts: Option<&'a RunHosts>,
    /// The world ticks by the wall clock and applies whatever commands arrived
    /// (`swarm run --realtime`).
    pub realtime: bool,
    /// The hosts file's `tcp/` endpoints are allowed (`swarm run --insecure-link`).
    pub insecure_link: bool,
}

/// [`run`] with `opts`.
pub fn run_on_hosts(
    cfg: &Config,
    config_path: &Path,
    dir: &OutDir,
    opts: &RunOptions,
    interrupt: Receiver<()>,
    mut progress: impl FnMut(u64),
) -> anyhow::Result<ProcessOutcome> {
    let run_id = new_run_id();
    let run = RunServices::new(&run_id);
    if let Err(e) = cleanup::claim(&run_id) {
        // A base swarm refuses is the user's to fix: its one line, typed for exit 2.
        if let Some(r) = cleanup::BaseRefused::of(&e) {
            return Err(r.clone().into());
        }
        return Err(anyhow::Error::new(e).context("cannot create the run's iceoryx2 directory"));
    }
    let result = supervise(cfg, config_path, dir, opts, &run, interrupt, &mut progress);
    let removed = cleanup::remove_run(&run_id);
    tracing::debug!(run_id, removed, "run resources removed");
    result.map(|mut o| {
        o.run_id = run_id;
        o
    })
}

/// The run's phases: the world starts and listens, the remote hosts and this host's robots
/// start, the world's reports drive the run until its end, then everything is seen out.
fn supervise(
    cfg: &Config,
    config_path: &Path,
    dir: &OutDir,
    opts: &RunOptions,
    run: &RunServices,
    interrupt: Receiver<()>,
    progress: &mut impl FnMut(u64),
) -> anyhow::Result<ProcessOutcome> {
    let world_bin = sibling_binary("swarm-world")?;
    let agent_bin = sibling_binary("swarm-agent")?;
    // iceoryx2's tools read `config/iceoryx2.toml` from their working directory, so
    // `cd <run dir> && iox2 service list` sees this run; robot programs load it too.
    let ipc_config = dir.join(crate::run_dir::IPC_CONFIG);
    swarmrt_ipc::config_file_text(run)
        .map_err(|e| anyhow::anyhow!("{e}"))
        .and_then(|text| {
            let sub = dir.create_subdir(crate::run_dir::IPC_CONFIG_DIR)?;
            Ok(sub.write("iceoryx2.toml", text)?)
        })
        .with_context(|| format!("cannot write {}", ipc_config.display()))?;
    let (tx, rx) = crossbeam_channel::unbounded::<Msg>();
    // Dropped when this function returns: the relay thread ends with the run, so it never
    // swallows a Ctrl-C meant for a later run in the same process.
    let _run_over = relay_interrupts(interrupt, &tx);
    let world = world::start_world(&world_bin, run, config_path, dir, opts, &tx)?;
    let launch = Launch {
        agent: agent_bin,
        run: run.clone(),
        config: config_path.to_path_buf(),
        // Stable storage of the robots' persistent Raft state, for restarts.
        storage: dir.join(crate::run_dir::STORAGE_DIR),
        first: 0,
        cfg: cfg.clone(),
        ipc_config,
        quiet: false,
    };
    let mut local = LocalRun::new(launch, tx, rx, world);

    // Robots start once the world's services exist.
    if !local.await_listening()? {
        return Ok(local.into_outcome());
    }
    // Remote hosts start now too: the world's Zenoh session is listening.
    local.launch_remotes(opts.hosts, run.run_id(), config_path)?;
    local.start_robots(cfg.robots.count, progress);

    // Supervise until the world reports the end. The world's exit (from the reaper) and its
    // last report (from the stdout reader) race on the channel, so its end is judged only
    // once both its exit and the EOF of its stdout have arrived.
    local.supervise(progress)?;
    local.finish(run.run_id())
}

/// Relays Ctrl-C from `interrupt` to `tx` until the returned sender is dropped.
fn relay_interrupts(interrupt: Receiver<()>, tx: &Sender<Msg>) -> Sender<()> {
    let (run_over_tx, run_over) = crossbeam_channel::bounded::<()>(0);
    let tx = tx.clone();
    std::thread::spawn(move || {
        loop {
            crossbeam_channel::select! {
                recv(interrupt) -> r => {
                    if r.is_err() || tx.send(Msg::Interrupt).is_err() {
                        return;
                    }
                }
                recv(run_over) -> _ => return,
            }
        }
    });
    run_over_tx
}
