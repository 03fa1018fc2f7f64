//! `swarm run`: resolve the config, run it (processes or in-process), write the run directory.

use std::io::IsTerminal;
use std::path::Path;
use std::time::Instant;

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

/// Runs a scenario; returns the run directory.
pub fn run(
    args: &RunArgs,
    interrupt: crossbeam_channel::Receiver<()>,
) -> SwarmResult<std::path::PathBuf> {
    let mut set = args.set.clone();
    if let Some(seed) = args.seed {
        set.push(format!("scenario.seed={seed}"));
    }
    if let Some(ticks) = args.ticks {
        set.push(format!("scenario.ticks={ticks}"));
    }
    let cfg = load_config(&args.config, &set)?;
    let dir = args
        .out
        .clone()
        .unwrap_or_else(|| run_dir::default_dir(&cfg));
    let config_path = run_dir::prepare(&dir, &cfg)?;
    let pb = progress_bar(cfg.scenario.ticks);
    let started = Instant::now();
    let mut metrics = json!({
        "scenario": cfg.scenario.name,
        "seed": cfg.scenario.seed,
        "mode": if args.in_process { "in-process" } else { "processes" },
        "agents": cfg.robots.count,
    });

    let failure: Option<String>;
    if args.in_process {
        let (world, interrupted) = swarmrt_harness::lockstep::run_recorded(
            &cfg,
            &dir,
            || interrupt.try_recv().is_ok(),
            |t| pb.set_position(t),
        )
        .map_err(anyhow::Error::from)?;
        merge(
            &mut metrics,
            serde_json::to_value(world).map_err(anyhow::Error::from)?,
        );
        metrics["interrupted"] = json!(interrupted);
        metrics["reproducible"] = json!(!interrupted);
        failure = None;
    } else {
        let out = match processes::run(&cfg, &config_path, &dir, interrupt, |t| pb.set_position(t))
        {
            Ok(out) => out,
            Err(e) => {
                // Even a run that never started leaves a metrics.json saying why.
                pb.finish_and_clear();
                metrics["failed"] = json!(true);
                metrics["failure"] = json!(format!("{e:#}"));
                metrics["ticks"] = json!(recorded_ticks(&dir));
                metrics["wall_seconds"] = json!(started.elapsed().as_secs_f64());
                run_dir::write_metrics(&dir, &metrics)?;
                println!("{}", dir.display());
                return Err(SwarmError::Internal(e));
            }
        };
        if let Some(w) = out.world_metrics {
            merge(&mut metrics, w);
        }
        metrics["run_id"] = json!(out.run_id);
        metrics["interrupted"] = json!(out.interrupted);
        metrics["startup_ms"] = json!(out.startup_ms);
        metrics["processes"] = json!(out.processes);
        metrics["unscheduled_deaths"] = json!(
            out.unscheduled_deaths
                .iter()
                .map(|(id, how)| json!({"robot": id, "how": how}))
                .collect::<Vec<_>>()
        );
        // An unscheduled death happens at a wall-clock moment: the run cannot be replayed.
        metrics["reproducible"] = json!(
            out.unscheduled_deaths.is_empty() && out.world_failure.is_none() && !out.interrupted
        );
        failure = out.world_failure;
    }
    pb.finish_and_clear();
    let wall = started.elapsed().as_secs_f64();
    metrics["wall_seconds"] = json!(wall);
    let ticks = metrics["ticks"].as_u64().unwrap_or(0);
    metrics["ticks_per_second"] = json!(if wall > 0.0 { ticks as f64 / wall } else { 0.0 });
    metrics["failed"] = json!(failure.is_some());
    if let Some(f) = &failure {
        metrics["failure"] = json!(f);
        match run_dir::trim_torn_records(&dir, cfg.robots.count as usize) {
            Ok(last) => metrics["ticks"] = json!(last.unwrap_or(0)),
            Err(e) => tracing::warn!("could not trim the records: {e:#}"),
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
    run_dir::write_metrics(&dir, &metrics)?;
    if let Err(e) = run_dir::write_plots(&dir, &cfg) {
        tracing::warn!("could not draw the trajectory plot: {e:#}");
    }
    if let Err(e) = swarmrt_analysis::series::write_all(&cfg, &dir) {
        tracing::warn!("could not write the behaviour's per-tick tables: {e:#}");
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

/// Last tick present in `trajectory.csv` (for runs whose world died).
fn recorded_ticks(dir: &Path) -> u64 {
    std::fs::read_to_string(dir.join("trajectory.csv"))
        .ok()
        .and_then(|t| {
            t.lines()
                .last()
                .and_then(|l| l.split(',').next()?.parse().ok())
        })
        .unwrap_or(0)
}

fn merge(into: &mut serde_json::Value, from: serde_json::Value) {
    if let (Some(a), serde_json::Value::Object(b)) = (into.as_object_mut(), from) {
        for (k, v) in b {
            a.insert(k, v);
        }
    }
}
