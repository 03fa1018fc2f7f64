//! `swarm run`: resolve the config, run it (processes or in-process), write the run directory.

use std::io::IsTerminal;
use std::time::Instant;
use swarmrt_scenario::safe_fs::OutDir;

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use serde_json::json;

use crate::cli::RunArgs;
use crate::config::load_config;
use crate::error::{SwarmError, SwarmResult};
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
    let mut set = args.set.clone();
    if let Some(seed) = args.seed {
        set.push(format!("scenario.seed={seed}"));
    }
    if let Some(ticks) = args.ticks {
        set.push(format!("scenario.ticks={ticks}"));
    }
    let cfg = load_config(&args.config, &set)?;
    // The page's port first: a port in use is refused before the run writes anything.
    let socket = if args.view {
        Some(super::view::bind(&args.serve)?)
    } else {
        None
    };
    if args.in_process {
        crate::config::refuse_foreign_in_process(&cfg, &args.config, "--in-process")?;
    }
    if cfg.radio.rounds > 0 && (args.realtime || args.hosts.is_some()) {
        let flag = if args.realtime {
            "--realtime"
        } else {
            "--hosts"
        };
        return Err(SwarmError::User(format!(
            "{}: key `radio.rounds`: expected 0 with {flag}, got {}: propagation rounds need \
             every robot's answer within the tick on this host (drop {flag}, or set radio.rounds = 0)",
            args.config.display(),
            cfg.radio.rounds
        )));
    }
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
    let dir = out.path().to_path_buf();
    let hosts = match &args.hosts {
        Some(path) => {
            let file = swarmrt_hosts::HostsFile::load(path, cfg.robots.count)?;
            if !file.is_secure() && !args.insecure_link {
                return Err(SwarmError::User(file.insecure_refusal(path)));
            }
            Some(file)
        }
        None => None,
    };
    let config_path = run_dir::prepare(&out, &cfg)?;
    let hosts = match (hosts, &args.hosts) {
        (Some(file), Some(path)) => {
            // The world reads it from the run directory, which also keeps it with the records.
            let copy = dir.join("hosts.toml");
            // Never through a link planted at the copy's name.
            std::fs::read(path)
                .and_then(|text| out.write("hosts.toml", text))
                .map_err(|e| {
                    SwarmError::Internal(anyhow::anyhow!("cannot copy {}: {e}", path.display()))
                })?;
            Some(crate::hosts::RunHosts { file, path: copy })
        }
        _ => None,
    };
    run_dir::reserve_metrics_room(&out, cfg.robots.count);
    if let Some(socket) = socket {
        // Reads the records as the run writes them: attaching it changes no record byte.
        let v = super::view::start(&dir, socket)?;
        eprintln!("watch the run at {}", v.url());
        *viewer = Some(v);
    }
    let pb = progress_bar(cfg.scenario.ticks);
    let started = Instant::now();
    let mut metrics = json!({
        "scenario": cfg.scenario.name,
        "seed": cfg.scenario.seed,
        "mode": if args.in_process {
            "in-process"
        } else if args.realtime {
            "realtime"
        } else {
            "processes"
        },
        "agents": cfg.robots.count,
    });

    let failure: Option<String>;
    if args.in_process {
        let (world, interrupted) = match swarmrt_harness::lockstep::run_recorded(
            &cfg,
            &out,
            || interrupt.try_recv().is_ok(),
            |t| pb.set_position(t),
        ) {
            Ok(r) => r,
            // A write failed (e.g. the disk is full): the records stop mid-tick.
            Err(e) => {
                pb.finish_and_clear();
                let e = anyhow::Error::from(e).context("run failed writing its records");
                return Err(failed_early(&out, &cfg, metrics, started, e));
            }
        };
        merge(
            &mut metrics,
            serde_json::to_value(world).map_err(anyhow::Error::from)?,
        );
        metrics["interrupted"] = json!(interrupted);
        metrics["reproducible"] = json!(!interrupted);
        failure = None;
    } else {
        let opts = processes::RunOptions {
            hosts: hosts.as_ref(),
            insecure_link: args.insecure_link,
            realtime: args.realtime,
        };
        let done = match processes::run_on_hosts(&cfg, &config_path, &out, &opts, interrupt, |t| {
            pb.set_position(t)
        }) {
            Ok(done) => done,
            Err(e) => {
                pb.finish_and_clear();
                // A bad or unreachable host is the user's to fix: one line, exit 2.
                // So is a shared-memory base that swarm refuses to use.
                let user_line = e
                    .downcast_ref::<crate::hosts::HostFailure>()
                    .map(|h| h.to_string())
                    .or_else(|| {
                        e.downcast_ref::<swarmrt_ipc::cleanup::BaseRefused>()
                            .map(|r| r.to_string())
                    });
                if let Some(line) = user_line {
                    let _ = failed_early(&out, &cfg, metrics, started, e);
                    return Err(SwarmError::User(line));
                }
                return Err(failed_early(&out, &cfg, metrics, started, e));
            }
        };
        if let Some(w) = done.world_metrics {
            merge(&mut metrics, w);
        }
        metrics["run_id"] = json!(done.run_id);
        metrics["interrupted"] = json!(done.interrupted);
        metrics["startup_ms"] = json!(done.startup_ms);
        metrics["processes"] = json!(done.processes);
        if let Some(h) = &done.hosts {
            metrics["hosts"] = h.clone();
            // What the link between hosts trusted (docs/security.md).
            metrics["link"] = serde_json::json!(if args.insecure_link {
                "tcp (insecure)"
            } else {
                "mutual tls"
            });
        }
        metrics["unscheduled_deaths"] = json!(
            done.unscheduled_deaths
                .iter()
                .map(|(id, how)| json!({"robot": id, "how": how}))
                .collect::<Vec<_>>()
        );
        // An unscheduled death happens at a wall-clock moment: the run cannot be replayed.
        // A real-time run applies whatever arrived by the wall clock: never replayable.
        metrics["reproducible"] = json!(
            done.unscheduled_deaths.is_empty()
                && done.world_failure.is_none()
                && !done.interrupted
                && !args.realtime
        );
        failure = done.world_failure;
    }
    pb.finish_and_clear();
    let wall = started.elapsed().as_secs_f64();
    metrics["wall_seconds"] = json!(wall);
    let ticks = metrics["ticks"].as_u64().unwrap_or(0);
    metrics["ticks_per_second"] = json!(if wall > 0.0 { ticks as f64 / wall } else { 0.0 });
    metrics["failed"] = json!(failure.is_some());
    if let Some(f) = &failure {
        metrics["failure"] = json!(f);
        if let Some(last) = trimmed_ticks(&out, &cfg) {
            metrics["ticks"] = json!(last);
        }
    }
    // Robots whose process is gone, by the schedule or by a crash.
    metrics["robots_lost"] = metrics.get("dead").cloned().unwrap_or(json!(0));
    match swarmrt_analysis::metrics::from_records(&cfg, &dir) {
        Ok(m) => merge(&mut metrics, m),
        Err(e) => tracing::warn!("could not compute metrics from the records: {e:#}"),
    }
    if cfg.consensus.is_some() {
        // From the record alone, so both modes give the same numbers.
        let events = std::fs::read_to_string(dir.join("events.jsonl")).unwrap_or_default();
        metrics["consensus"] = swarmrt_analysis::consensus_check::consensus_metrics(&events);
    }
    if let Err(e) = run_dir::write_metrics(&out, &metrics) {
        if failure.is_none() {
            return Err(e.into());
        }
        // A failed run (e.g. a full disk) still reports its failure below.
        tracing::warn!("{e:#}");
    }
    if let Err(e) = run_dir::write_plots(&out, &cfg) {
        // Each plot is written whole or not at all (a temporary file renamed into place).
        tracing::warn!("could not draw the trajectory plot: {e:#}");
    }
    match swarmrt_analysis::series::write_all(&cfg, &out) {
        // Named in the mark, so a later --force knows them as swarm's.
        Ok(written) if !written.is_empty() => {
            if let Err(e) = run_dir::note_written(&out, &written) {
                tracing::warn!("could not note the behaviour's tables in the mark: {e}");
            }
        }
        Ok(_) => {}
        Err(e) => tracing::warn!("could not write the behaviour's per-tick tables: {e:#}"),
    }
    // A stalled run ended early with robots short of their goal: say so, not only in the file.
    if let Some(stalled) = metrics
        .get("stalled")
        .and_then(|v| serde_json::from_value::<swarmrt_world::Stalled>(v.clone()).ok())
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

/// A run that ended without the world's final report (the supervisor failed, or an
/// in-process write failed): trims whatever records it left to the last whole tick, and
/// leaves a `metrics.json` saying why when there is room for one.
fn failed_early(
    dir: &OutDir,
    cfg: &swarmrt_scenario::Config,
    mut metrics: serde_json::Value,
    started: Instant,
    e: anyhow::Error,
) -> SwarmError {
    metrics["failed"] = json!(true);
    metrics["failure"] = json!(format!("{e:#}"));
    metrics["ticks"] = json!(trimmed_ticks(dir, cfg).unwrap_or(0));
    metrics["wall_seconds"] = json!(started.elapsed().as_secs_f64());
    if let Err(w) = run_dir::write_metrics(dir, &metrics) {
        tracing::warn!("{w:#}");
    }
    println!("{}", dir.path().display());
    SwarmError::Internal(anyhow::anyhow!(
        "{e:#}; records up to the last whole tick are in {}",
        dir.path().display()
    ))
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

fn merge(into: &mut serde_json::Value, from: serde_json::Value) {
    if let (Some(a), serde_json::Value::Object(b)) = (into.as_object_mut(), from) {
        for (k, v) in b {
            a.insert(k, v);
        }
    }
}
