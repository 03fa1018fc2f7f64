//! `swarm-bench` (run as `swarm bench`): measurements of the IPC and of the lock-step swarm.
//!
//! Every measurement that crosses processes re-executes this binary with the hidden
//! `swarm-bench child --spec <json>` subcommand ([`child`]). The parent holds no iceoryx2
//! node (so children never inherit its descriptors); it only spawns, reads one JSON line of
//! results per child over a pipe, and reaps. Each measurement claims its own run id, so its
//! iceoryx2 root (`/dev/shm/swarmrt-<euid>/<id>/`) and shared-memory prefix are its own, and
//! removing them afterwards is exact; `swarm clean` finds them if the parent was killed.
//!
//! - [`cli`]: the command line; the only module that knows clap.
//! - [`ipc`]: `swarm bench ipc` (transports, fan-out, loss accounting, the runtime's path).
//! - [`swarm`]: `swarm bench swarm` (the real runtime, the bare floor, in-process).
//! - [`transports`], [`fanout`], [`loss`], [`floor`]: what the child processes do.
//! - [`procs`], [`stats`], [`plot`]: child processes, summaries, figures.
#![warn(missing_docs)]

pub mod child;
pub mod cli;
pub mod fanout;
pub mod floor;
pub mod ipc;
pub mod loss;
pub mod peers;
pub mod procs;
pub mod stats;
pub mod swarm;
pub mod transports;

use std::io::IsTerminal;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::time::Duration;

use anyhow::Context;
use crossbeam_channel::{Receiver, Sender};
use iceoryx2::prelude::*;
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use swarmrt_ipc as proto_ipc;
use swarmrt_protocol::services::RunServices;

use swarmrt_orchestrator::cleanup;
use swarmrt_orchestrator::error::{SwarmError, SwarmResult};

/// Shortcut for the iceoryx2 service flavour.
pub type Svc = proto_ipc::Svc;

/// Ctrl-C for a benchmark: a flag, and a fresh receiver for each consumer, so a stale
/// consumer (e.g. the interrupt thread of a finished `processes::run`) never swallows it.
#[derive(Clone)]
pub struct Interrupt {
    flag: Arc<AtomicBool>,
    subscribers: Arc<Mutex<Vec<Sender<()>>>>,
}

impl Interrupt {
    /// Forwards every message of `source` (main's Ctrl-C channel) to all receivers.
    pub fn new(source: Receiver<()>) -> Interrupt {
        let me = Interrupt {
            flag: Arc::new(AtomicBool::new(false)),
            subscribers: Arc::new(Mutex::new(Vec::new())),
        };
        let fwd = me.clone();
        std::thread::spawn(move || {
            while source.recv().is_ok() {
                fwd.flag.store(true, Ordering::SeqCst);
                if let Ok(mut subs) = fwd.subscribers.lock() {
                    subs.retain(|s| {
                        !matches!(
                            s.try_send(()),
                            Err(crossbeam_channel::TrySendError::Disconnected(_))
                        )
                    });
                }
            }
        });
        me
    }

    /// A new receiver that gets every later Ctrl-C (and one at once if it already happened).
    pub fn receiver(&self) -> Receiver<()> {
        let (tx, rx) = crossbeam_channel::bounded(4);
        if self.fired() {
            let _ = tx.try_send(());
        }
        if let Ok(mut subs) = self.subscribers.lock() {
            subs.push(tx);
        }
        rx
    }

    /// True once Ctrl-C was pressed.
    pub fn fired(&self) -> bool {
        self.flag.load(Ordering::SeqCst)
    }

    /// `Err` once Ctrl-C was pressed.
    pub fn check(&self) -> anyhow::Result<()> {
        if self.fired() {
            anyhow::bail!("interrupted");
        }
        Ok(())
    }
}

/// Runs a benchmark; `interrupt` fires on Ctrl-C, which stops it with exit code 130 after
/// every child is reaped and every iceoryx2 resource removed (no results are written).
pub fn interruptible(
    interrupt: Receiver<()>,
    bench: impl FnOnce(&Interrupt) -> SwarmResult<()>,
) -> SwarmResult<()> {
    let interrupt = Interrupt::new(interrupt);
    match bench(&interrupt) {
        Err(SwarmError::Internal(_)) if interrupt.fired() => Err(SwarmError::Interrupted(
            "interrupted before the results were written".into(),
        )),
        r => r,
    }
}

/// The iceoryx2 names of one measurement: a claimed run id whose root and shared memory are
/// removed when this is dropped, on every path out of the measurement.
pub struct BenchRun {
    run: RunServices,
}

impl BenchRun {
    /// Claims a fresh run id (see `cleanup::claim`).
    pub fn claim() -> anyhow::Result<BenchRun> {
        let id = swarmrt_orchestrator::processes::new_run_id();
        cleanup::claim(&id).context("cannot create the benchmark's iceoryx2 directory")?;
        Ok(BenchRun {
            run: RunServices::new(&id),
        })
    }

    /// The run's names.
    pub fn services(&self) -> &RunServices {
        &self.run
    }

    /// The run id.
    pub fn id(&self) -> &str {
        self.run.run_id()
    }
}

impl Drop for BenchRun {
    fn drop(&mut self) {
        let removed = cleanup::remove_run(self.run.run_id());
        tracing::debug!(
            run_id = self.run.run_id(),
            removed,
            "bench resources removed"
        );
    }
}

/// A node of run `run` for a benchmark child: the run's config (own root and prefix, no
/// dead-node scans) and no signal handler, so SIGTERM ends the process at once.
pub fn bench_node(run: &RunServices, name: &str) -> anyhow::Result<Node<Svc>> {
    let cfg = proto_ipc::ipc_config(run).map_err(|e| anyhow::anyhow!("{e}"))?;
    let name = NodeName::new(name).map_err(|e| anyhow::anyhow!("node name {name}: {e:?}"))?;
    NodeBuilder::new()
        .name(&name)
        .config(&cfg)
        .signal_handling_mode(SignalHandlingMode::Disabled)
        .create::<Svc>()
        .map_err(|e| anyhow::anyhow!("cannot create node: {e:?}"))
}

/// A service name inside the run's namespace: `swarmrt/<run>/bench/<what>`.
pub fn service_name(run: &RunServices, what: &str) -> anyhow::Result<ServiceName> {
    let s = format!("swarmrt/{}/bench/{what}", run.run_id());
    ServiceName::new(&s).map_err(|e| anyhow::anyhow!("service name {s}: {e:?}"))
}

/// Turns any iceoryx2 error (they are many distinct types) into anyhow with context.
pub fn iox<T, E: std::fmt::Debug>(r: Result<T, E>, what: &str) -> anyhow::Result<T> {
    r.map_err(|e| anyhow::anyhow!("{what}: {e:?}"))
}

pub use proto_ipc::{RobotPorts, WorldPorts};

/// [`WorldPorts::open`] with the benchmarks' error type.
pub fn world_ports(
    services: &proto_ipc::WorldServices,
    slots: usize,
) -> anyhow::Result<WorldPorts> {
    WorldPorts::open(services, slots, 0).map_err(|e| anyhow::anyhow!("world ports: {e}"))
}

/// [`RobotPorts::open`] with the benchmarks' error type: the robot sleeps on the run's bell,
/// as a runtime robot does.
pub fn robot_ports(
    node: &iceoryx2::node::Node<Svc>,
    run: &swarmrt_protocol::services::RunServices,
    id: u32,
) -> anyhow::Result<RobotPorts> {
    RobotPorts::open(node, run, id).map_err(|e| anyhow::anyhow!("robot ports: {e}"))
}

/// [`RobotPorts::open_listening`] with the benchmarks' error type: the robot sleeps in its own
/// listener, one notification per robot per tick (the floor).
pub fn listening_robot_ports(
    node: &iceoryx2::node::Node<Svc>,
    run: &swarmrt_protocol::services::RunServices,
    id: u32,
) -> anyhow::Result<RobotPorts> {
    RobotPorts::open_listening(node, run, id).map_err(|e| anyhow::anyhow!("robot ports: {e}"))
}

/// CLOCK_MONOTONIC in nanoseconds: the same clock in every process of this machine, so
/// timestamps taken in different processes can be subtracted.
pub fn monotonic_ns() -> u64 {
    let mut ts = libc::timespec {
        tv_sec: 0,
        tv_nsec: 0,
    };
    // SAFETY: clock_gettime only writes the struct we pass.
    unsafe {
        libc::clock_gettime(libc::CLOCK_MONOTONIC, &mut ts);
    }
    ts.tv_sec as u64 * 1_000_000_000 + ts.tv_nsec as u64
}

/// Spins (burns CPU) for `d`: simulated work that must not give the CPU away.
pub fn spin_for(d: Duration) {
    let start = std::time::Instant::now();
    while start.elapsed() < d {
        std::hint::spin_loop();
    }
}

/// `bench/<kind>-<yyyymmdd-hhmmss>/`, with a numeric suffix if that exists already.
pub fn default_out(kind: &str) -> PathBuf {
    let secs = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map(|d| d.as_secs())
        .unwrap_or(0);
    let (h, m, s) = ((secs / 3600) % 24, (secs / 60) % 60, secs % 60);
    let (y, mo, d) = swarmrt_orchestrator::run_dir::civil_from_days((secs / 86_400) as i64);
    let base = format!("bench/{kind}-{y:04}{mo:02}{d:02}-{h:02}{m:02}{s:02}");
    let mut dir = PathBuf::from(&base);
    let mut k = 1;
    while dir.exists() {
        dir = PathBuf::from(format!("{base}-{k}"));
        k += 1;
    }
    dir
}

/// Creates `dir` (and parents); a failure is the user's (a bad `--out`).
pub fn make_out_dir(dir: &Path) -> Result<(), SwarmError> {
    std::fs::create_dir_all(dir)
        .map_err(|e| SwarmError::User(format!("cannot create {}: {e}", dir.display())))
}

/// What the machine is, for the record (`nproc`, CPU model, kernel, load, fd limit).
pub fn machine() -> serde_json::Value {
    let cpu = std::fs::read_to_string("/proc/cpuinfo")
        .ok()
        .and_then(|t| {
            t.lines()
                .find(|l| l.starts_with("model name"))
                .and_then(|l| l.split_once(':'))
                .map(|(_, v)| v.trim().to_string())
        })
        .unwrap_or_default();
    let kernel = std::fs::read_to_string("/proc/sys/kernel/osrelease")
        .map(|s| s.trim().to_string())
        .unwrap_or_default();
    let load = std::fs::read_to_string("/proc/loadavg")
        .map(|s| s.split_whitespace().take(3).collect::<Vec<_>>().join(" "))
        .unwrap_or_default();
    let mem_mb = std::fs::read_to_string("/proc/meminfo")
        .ok()
        .and_then(|t| {
            t.lines()
                .find(|l| l.starts_with("MemTotal:"))
                .and_then(|l| l.split_whitespace().nth(1))
                .and_then(|v| v.parse::<u64>().ok())
        })
        .map(|kb| kb / 1024)
        .unwrap_or(0);
    let mut lim = libc::rlimit {
        rlim_cur: 0,
        rlim_max: 0,
    };
    // SAFETY: getrlimit only writes the struct we pass.
    unsafe {
        libc::getrlimit(libc::RLIMIT_NOFILE, &mut lim);
    }
    serde_json::json!({
        "nproc": std::thread::available_parallelism().map(|n| n.get()).unwrap_or(0),
        "cpu": cpu,
        "kernel": kernel,
        "mem_mb": mem_mb,
        "loadavg_at_start": load,
        "nofile_soft": lim.rlim_cur,
        "nofile_hard": lim.rlim_max,
    })
}

/// A progress bar over `total` steps on a terminal; hidden otherwise (CI, pipes).
pub fn progress(total: u64) -> ProgressBar {
    let pb = ProgressBar::with_draw_target(
        Some(total),
        if std::io::stderr().is_terminal() {
            ProgressDrawTarget::stderr()
        } else {
            ProgressDrawTarget::hidden()
        },
    );
    pb.set_style(
        ProgressStyle::with_template("{bar:30} {pos}/{len}  {elapsed_precise}  {msg}")
            .expect("valid template"),
    );
    pb
}

/// Writes `value` as pretty JSON to `path`.
pub fn write_json(path: &Path, value: &serde_json::Value) -> anyhow::Result<()> {
    let text = serde_json::to_string_pretty(value)?;
    std::fs::write(path, text + "\n").with_context(|| format!("writing {}", path.display()))
}

/// Human-readable duration from nanoseconds.
pub fn fmt_ns(ns: f64) -> String {
    if !ns.is_finite() {
        "-".into()
    } else if ns < 1_000.0 {
        format!("{ns:.0} ns")
    } else if ns < 1_000_000.0 {
        format!("{:.1} us", ns / 1e3)
    } else if ns < 1_000_000_000.0 {
        format!("{:.2} ms", ns / 1e6)
    } else {
        format!("{:.2} s", ns / 1e9)
    }
}

/// Human-readable rate (1.2 k, 3.4 M).
pub fn fmt_rate(v: f64) -> String {
    if !v.is_finite() {
        "-".into()
    } else if v >= 1e9 {
        format!("{:.2} G", v / 1e9)
    } else if v >= 1e6 {
        format!("{:.2} M", v / 1e6)
    } else if v >= 1e3 {
        format!("{:.1} k", v / 1e3)
    } else {
        format!("{v:.0}")
    }
}

/// Human-readable byte count (binary units).
pub fn fmt_bytes(b: f64) -> String {
    if b >= 1024.0 * 1024.0 * 1024.0 {
        format!("{:.1} GiB", b / (1024.0 * 1024.0 * 1024.0))
    } else if b >= 1024.0 * 1024.0 {
        format!("{:.1} MiB", b / (1024.0 * 1024.0))
    } else if b >= 1024.0 {
        format!("{:.0} KiB", b / 1024.0)
    } else {
        format!("{b:.0} B")
    }
}

/// A watchdog interval for child processes: long enough for a loaded 2-core machine, short
/// enough that a lost peer ends the child instead of leaving it hanging.
pub const PEER_TIMEOUT: Duration = Duration::from_secs(20);
