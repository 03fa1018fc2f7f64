//! `swarm run`: resolve the config, run it (processes or in-process), write the run directory.

use std::io::IsTerminal;
use std::time::Instant;
use swarmrt_scenario::safe_fs::OutDir;

use anyhow::Context;
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};

use crate::cli::RunArgs;
use crate::config::load_config;
use crate::error::{SwarmError, SwarmResult};
use crate::metrics::{
    Ended, Link, Metrics, Mode, ProcessSection, RunHeader, UnscheduledDeath, WorldSection,
};
use crate::{processes, run_dir};

fn progress_bar(total: u64) -> ProgressBar {
    let pb = ProgressBar::with_draw_target(
        Some(total),
        if std::io::stderr().is_terminal() {
            ProgressDrawTarget::stderr()
        } else {
            ProgressDrawTarget::hidden()
        },
    );
    pb.set_style(
        ProgressStyle::with_template("{bar:40} {pos}/{len} ticks  {per_sec}  {elapsed_precise}")
            .expect("valid template"),
    );
    pb
}

/// Runs a scenario; returns the run directory. With `--view`, the page follows the run and,
/// once it is over, stays up as its replay until Ctrl-C.
pub fn run(
    args: &RunArgs,
    interrupt: crossbeam_channel::Receiver<()>,
) -> SwarmResult<std::path::PathBuf> {
    let mut viewer = None;
    let result = run_with(args, interrupt.clone(), &mut viewer);
    // A failed run says so at once (exit 1); its records stay viewable with `swarm view`.
    if let (Some(v), Ok(_)) = (viewer, &result) {
        // A Ctrl-C that stopped the run was spent on it; the replay waits for the next one.
        eprintln!(
            "the run is over: its replay stays at {} until Ctrl-C",
            v.url()
        );
        let _ = interrupt.recv();
        v.stop();
    }
    result
}

fn run_with(
    args: &RunArgs,
    interrupt: crossbeam_channel::Receiver<()>,
    viewer: &mut Option<swarmrt_viewer::Viewer>,
) -> SwarmResult<std::path::PathBuf> {
    let cfg = resolve(args)?;
    // The page's port first: a port in use is refused before the run writes anything.
    let socket = if args.view {
        Some(super::view::bind(&args.serve)?)
    } else {
        None
    };
    refuse_combinations(args, &cfg)?;
    // The directory is locked for the whole run (`_lock` lives until this returns): a second
    // run into it is refused, and so is an earlier run's directory unless --force.
    // Checked once here (no other user owns it, may write it, or could swap a directory on
    // the way to it) and written only through its handle from now on.
    let (out, _lock) = match &args.out {
        Some(path) => {
            let out = run_dir::open_out("--out", path)?;
            let lock = run_dir::claim(&out, args.force)?;
            (out, lock)
        }
        None => {
            let out = run_dir::default_dir(&cfg)?;
            let lock = run_dir::claim(&out, false)?;
            (out, lock)
        }
    };
    let hosts = load_hosts(args, &cfg)?;
    let config_path = run_dir::prepare(&out, &cfg)?;
    let hosts = copy_hosts(args, &out, hosts)?;
    run_dir::reserve_metrics_room(&out, cfg.robots.count);
    if let Some(socket) = socket {
        // Reads the records as the run writes them: attaching it changes no record byte.
        let v = super::view::start(out.path(), socket)?;
        eprintln!("watch the run at {}", v.url());
        *viewer = Some(v);
    }
    let pb = progress_bar(cfg.scenario.ticks);
    let ticks_done = args.ticks_done.clone();
    let bar = pb.clone();
    let progress = move |t: u64| {
        bar.set_position(t);
        if let Some(done) = &ticks_done {
            done.store(t, std::sync::atomic::Ordering::Relaxed);
        }
    };
    let started = Instant::now();
    let header = RunHeader {
        scenario: cfg.scenario.name.clone(),
        seed: cfg.scenario.seed,
        mode: mode(args),
        agents: cfg.robots.count,
    };
    let ran = if args.in_process {
        run_in_process(&cfg, &out, &interrupt, &progress)
    } else {
        let opts = processes::RunOptions {
            hosts: hosts.as_ref(),
            insecure_link: args.insecure_link,
            realtime: args.realtime,
        };
        run_processes(&cfg, &config_path, &out, &opts, interrupt, &progress)
    };
    pb.finish_and_clear();
    match ran {
        Ok(ran) => finish(&cfg, &out, header, ran, started),
        Err(e) => {
            // A bad or unreachable host is the user's to fix: one line, exit 2.
            // So is a shared-memory base that swarm refuses to use.
            let user_line = user_line(&e);
            let failed = failed_early(&out, &cfg, header, started, e);
            Err(user_line.map_or(failed, SwarmError::User))
        }
    }
}

/// The config with `--seed`, `--ticks` and `--set` applied.
fn resolve(args: &RunArgs) -> SwarmResult<swarmrt_scenario::Config> {
    let mut set = args.set.clone();
    if let Some(seed) = args.seed {
        set.push(format!("scenario.seed={seed}"));
    }
    if let Some(ticks) = args.ticks {
        set.push(format!("scenario.ticks={ticks}"));
    }
    load_config(&args.config, &set)
}

/// What `--in-process`, `--realtime`, `--hosts` and the config cannot do together.
fn refuse_combinations(args: &RunArgs, cfg: &swarmrt_scenario::Config) -> SwarmResult<()> {
    if args.in_process {
        crate::config::refuse_foreign_in_process(cfg, &args.config, "--in-process")?;
    }
    use swarmrt_runtime::world::{Mode as Pace, mode::refuse_combination};
    let pace = if args.realtime {
        Pace::Realtime
    } else {
        Pace::LockStep
    };
    // Decided where the world process decides it too (`runtime/src/world/mode.rs`).
    refuse_combination(cfg, pace, args.hosts.is_some())
        .map_err(|r| SwarmError::User(format!("{}: {r}", args.config.display())))?;
    Ok(())
}

/// The `--hosts` file, checked (an insecure link must be asked for).
fn load_hosts(
    args: &RunArgs,
    cfg: &swarmrt_scenario::Config,
) -> SwarmResult<Option<swarmrt_hosts::HostsFile>> {
    let Some(path) = &args.hosts else {
        return Ok(None);
    };
    let file = swarmrt_hosts::HostsFile::load(path, cfg.robots.count)?;
    if !file.is_secure() && !args.insecure_link {
        return Err(SwarmError::User(file.insecure_refusal(path)));
    }
    Ok(Some(file))
}

/// Copies the hosts file into the run directory: the world reads it from there, which also
/// keeps it with the records.
fn copy_hosts(
    args: &RunArgs,
    out: &OutDir,
    hosts: Option<swarmrt_hosts::HostsFile>,
) -> SwarmResult<Option<crate::hosts::RunHosts>> {
    let (Some(file), Some(path)) = (hosts, &args.hosts) else {
        return Ok(None);
    };
    // Never through a link planted at the copy's name.
    std::fs::read(path)
        .and_then(|text| out.write("hosts.toml", text))
        .map_err(|e| {
            SwarmError::Internal(anyhow::anyhow!("cannot copy {}: {e}", path.display()))
        })?;
    let copy = out.path().join("hosts.toml");
    Ok(Some(crate::hosts::RunHosts { file, path: copy }))
}

fn mode(args: &RunArgs) -> Mode {
    if args.in_process {
        Mode::InProcess
    } else if args.realtime {
        Mode::Realtime
    } else {
        Mode::Processes
    }
}

/// What a run that ended (or was stopped) left for its metrics.
struct Ran {
    world: Option<WorldSection>,
    interrupted: bool,
    reproducible: bool,
    processes: Option<ProcessSection>,
    /// Why the world failed, when it did (the run ended without its final report).
    failure: Option<String>,
}

/// World and robots in this process.
fn run_in_process(
    cfg: &swarmrt_scenario::Config,
    out: &OutDir,
    interrupt: &crossbeam_channel::Receiver<()>,
    progress: &dyn Fn(u64),
) -> anyhow::Result<Ran> {
    let (world, interrupted) = swarmrt_harness::lockstep::run_recorded(
        cfg,
        out,
        || interrupt.try_recv().is_ok(),
        progress,
    )
    // A write failed (e.g. the disk is full): the records stop mid-tick.
    .map_err(|e| anyhow::Error::from(e).context("run failed writing its records"))?;
    Ok(Ran {
        world: Some(WorldSection {
            metrics: world,
            shell: None,
        }),
        interrupted,
        reproducible: !interrupted,
        processes: None,
        failure: None,
    })
}

/// A world process and one process per robot, on this host and the hosts of `opts`.
fn run_processes(
    cfg: &swarmrt_scenario::Config,
    config_path: &std::path::Path,
    out: &OutDir,
    opts: &processes::RunOptions,
    interrupt: crossbeam_channel::Receiver<()>,
    progress: &dyn Fn(u64),
) -> anyhow::Result<Ran> {
    let done = processes::run_on_hosts(cfg, config_path, out, opts, interrupt, progress)?;
    let world = match done.world_metrics {
        Some(report) => Some(
            serde_json::from_value::<WorldSection>(report)
                .context("the world's final report does not read as its metrics")?,
        ),
        None => None,
    };
    // An unscheduled death happens at a wall-clock moment: the run cannot be replayed.
    // A real-time run applies whatever arrived by the wall clock: never replayable.
    let reproducible = done.unscheduled_deaths.is_empty()
        && done.world_failure.is_none()
        && !done.interrupted
        && !opts.realtime;
    let link = done.hosts.as_ref().map(|_| match opts.insecure_link {
        true => Link::InsecureTcp,
        false => Link::MutualTls,
    });
    let unscheduled_deaths = (done.unscheduled_deaths.into_iter())
        .map(|(robot, how)| UnscheduledDeath { robot, how })
        .collect();
    Ok(Ran {
        world,
        interrupted: done.interrupted,
        reproducible,
        processes: Some(ProcessSection {
            run_id: done.run_id,
            startup_ms: done.startup_ms,
            processes: done.processes,
            unscheduled_deaths,
            hosts: done.hosts,
            link,
        }),
        failure: done.world_failure,
    })
}

/// The one line for the user when `e` is theirs to fix (a bad or unreachable host, a
/// shared-memory base swarm refuses).
fn user_line(e: &anyhow::Error) -> Option<String> {
    e.downcast_ref::<crate::hosts::HostFailure>()
        .map(|h| h.to_string())
        .or_else(|| {
            e.downcast_ref::<swarmrt_ipc::cleanup::BaseRefused>()
                .map(|r| r.to_string())
        })
}

/// After a run that ended: its metrics (world, records, consensus) written once, the
/// plots and the behaviour's tables, the run directory on stdout.
fn finish(
    cfg: &swarmrt_scenario::Config,
    out: &OutDir,
    header: RunHeader,
    ran: Ran,
    started: Instant,
) -> SwarmResult<std::path::PathBuf> {
    let dir = out.path().to_path_buf();
    let failure = ran.failure.clone();
    let metrics = ended_metrics(cfg, out, header, ran, started);
    if let Err(e) = write_metrics(out, &metrics) {
        if failure.is_none() {
            return Err(e.into());
        }
        // A failed run (e.g. a full disk) still reports its failure below.
        tracing::warn!("{e:#}");
    }
    if let Err(e) = run_dir::write_plots(out, cfg) {
        // Each plot is written whole or not at all (a temporary file renamed into place).
        tracing::warn!("could not draw the trajectory plot: {e:#}");
    }
    write_series(cfg, out);
    // A stalled run ended early with robots short of their goal: say so, not only in the file.
    if let Some(stalled) = metrics
        .world
        .as_ref()
        .and_then(|w| w.metrics.stalled.as_ref())
    {
        eprintln!("swarm: {}", stalled.line());
    }
    println!("{}", dir.display());
    if let Some(f) = failure {
        return Err(SwarmError::Internal(anyhow::anyhow!(
            "run failed: {f}; records up to the last tick are in {}",
            dir.display()
        )));
    }
    Ok(dir)
}

/// The metrics of a run that ended: what it ran, then (records trimmed to their last whole
/// tick if it failed) what its records say.
fn ended_metrics(
    cfg: &swarmrt_scenario::Config,
    out: &OutDir,
    header: RunHeader,
    ran: Ran,
    started: Instant,
) -> Metrics {
    let wall = started.elapsed().as_secs_f64();
    let ticks = ran.world.as_ref().map_or(0, |w| w.metrics.ticks);
    let ended = Ended {
        interrupted: ran.interrupted,
        reproducible: ran.reproducible,
        ticks_per_second: if wall > 0.0 { ticks as f64 / wall } else { 0.0 },
        robots_lost: ran.world.as_ref().map_or(0, |w| w.metrics.dead),
        processes: ran.processes,
        records: None,
        consensus: None,
    };
    let mut metrics = Metrics::ended(header, ran.world, ended, wall);
    if let Some(f) = ran.failure {
        metrics.failed = true;
        metrics.failure = Some(f);
        if let Some(last) = trimmed_ticks(out, cfg) {
            metrics.set_ticks(last);
        }
    }
    let ended = metrics.ended.as_mut().expect("an ended run");
    match swarmrt_analysis::metrics::from_records(cfg, out.path()) {
        Ok(m) => ended.records = Some(m),
        Err(e) => tracing::warn!("could not compute metrics from the records: {e:#}"),
    }
    if cfg.consensus.is_some() {
        // From the record alone, so both modes give the same numbers.
        let events = std::fs::read_to_string(out.join("events.jsonl")).unwrap_or_default();
        ended.consensus = Some(swarmrt_harness::consensus_check::consensus_metrics(&events));
    }
    metrics
}

/// The behaviour's per-tick tables and their plots, named in the mark so a later --force
/// knows them as swarm's.
fn write_series(cfg: &swarmrt_scenario::Config, out: &OutDir) {
    match swarmrt_analysis::series::write_all(cfg, out) {
        Ok(written) if !written.is_empty() => {
            if let Err(e) = run_dir::note_written(out, &written) {
                tracing::warn!("could not note the behaviour's tables in the mark: {e}");
            }
        }
        Ok(_) => {}
        Err(e) => tracing::warn!("could not write the behaviour's per-tick tables: {e:#}"),
    }
}

/// A run that ended without the world's final report (the supervisor failed, or an
/// in-process write failed): trims whatever records it left to the last whole tick, and
/// leaves a `metrics.json` saying why when there is room for one.
fn failed_early(
    dir: &OutDir,
    cfg: &swarmrt_scenario::Config,
    header: RunHeader,
    started: Instant,
    e: anyhow::Error,
) -> SwarmError {
    let ticks = trimmed_ticks(dir, cfg).unwrap_or(0);
    let wall = started.elapsed().as_secs_f64();
    let metrics = Metrics::failed_early(header, format!("{e:#}"), ticks, wall);
    if let Err(w) = write_metrics(dir, &metrics) {
        tracing::warn!("{w:#}");
    }
    println!("{}", dir.path().display());
    SwarmError::Internal(anyhow::anyhow!(
        "{e:#}; records up to the last whole tick are in {}",
        dir.path().display()
    ))
}

/// Writes `metrics.json` (atomically, into the room set aside for it).
fn write_metrics(out: &OutDir, metrics: &Metrics) -> anyhow::Result<()> {
    run_dir::write_metrics(out, metrics.to_json()?)
}

/// Cuts the records back to their last whole tick and returns it (0 without a whole tick,
/// `None` if there are no records or they could not be trimmed).
fn trimmed_ticks(dir: &OutDir, cfg: &swarmrt_scenario::Config) -> Option<u64> {
    dir.stat("trajectory.csv")?;
    match run_dir::trim_torn_records(dir, cfg.robots.count as usize) {
        Ok(last) => Some(last.unwrap_or(0)),
        Err(e) => {
            tracing::warn!("could not trim the records: {e:#}");
            None
        }
    }
}
