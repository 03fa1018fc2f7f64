//! `swarm sweep`: a scenario over the cross product of varied keys and seeds. Every run is an
//! ordinary run directory under `<out>/runs/`; `sweep.csv` gets a row as each run finishes;
//! plots and `summary.md` are drawn from all rows at the end. Re-running the same command
//! with the same `--out` runs only what is missing (or failed).

use std::collections::BTreeSet;
use std::io::IsTerminal;
use std::path::Path;

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use swarmrt_scenario::Config;
use swarmrt_world::WorldMetrics;

use crate::cli::SweepArgs;
use crate::config::load_config;
use crate::error::{SwarmError, SwarmResult};
use crate::run_dir;
use crate::sweep::plan::{self, Plan, RunSpec};
use crate::sweep::report::{self, SummaryHead};
use crate::sweep::runner::{self, Event, Job, Outcome, PoolOptions};
use swarmrt_analysis::stats::Groups;
use swarmrt_analysis::sweep_csv::{self as table, FAILED, Row, SEED, SweepCsv, Table};

/// Scalar keys `swarm run` adds around the world's own metrics (commands/run.rs); `shell.*`
/// and `startup_ms` only in processes mode.
const RUN_METRICS: [&str; 12] = [
    "agents",
    "seed",
    "wall_seconds",
    "ticks_per_second",
    "failed",
    "interrupted",
    "reproducible",
    "startup_ms",
    "shell.late",
    "shell.unknown_sender",
    "shell.extra_commands",
    "shell.bad_hello",
];

/// A finished row's identity: varied values and seed.
type RunKey = (Vec<String>, u64);

/// What an existing `sweep.csv` holds for this command.
struct Existing {
    /// Its rows minus those to run again.
    table: Table,
    /// Runs of this plan already finished.
    done: BTreeSet<RunKey>,
}

/// Runs the sweep.
pub fn sweep(args: &SweepArgs, interrupt: crossbeam_channel::Receiver<()>) -> SwarmResult<()> {
    let varies = args
        .vary
        .iter()
        .map(|v| plan::parse_vary(v))
        .collect::<Result<Vec<_>, _>>()
        .map_err(SwarmError::User)?;
    for s in &args.pool.set {
        let key = s.split_once('=').map_or(s.as_str(), |(k, _)| k).trim();
        if varies.iter().any(|v| v.key == key) {
            return Err(SwarmError::User(format!(
                "key `{key}` is given both to --set and to --vary"
            )));
        }
    }
    let base = load_config(&args.config, &args.pool.set)?;
    let start = args.start_seed.unwrap_or(base.scenario.seed);
    let plan = Plan::new(&varies, start, args.seeds).map_err(SwarmError::User)?;

    // Every combination must resolve before anything runs.
    let mut configs: Vec<Config> = Vec::with_capacity(plan.combos.len());
    for c in 0..plan.combos.len() {
        let mut set = args.pool.set.clone();
        set.extend(plan.overrides(c));
        let cfg = load_config(&args.config, &set).map_err(|e| match e {
            SwarmError::User(m) if plan.combos.len() > 1 => {
                SwarmError::User(format!("{m} (with {})", plan.describe(c)))
            }
            e => e,
        })?;
        configs.push(cfg);
    }

    let out = match args.out.clone() {
        Some(out) => out,
        None => run_dir::unused_dir(&format!(
            "sweeps/{}-{}",
            base.scenario.name,
            run_dir::timestamp()
        ))?,
    };
    let csv_path = out.join("sweep.csv");
    check_out_dir(&out)?;
    let existing = if csv_path.exists() {
        Some(read_existing(&csv_path, &plan, &configs, &out)?)
    } else {
        None
    };
    check_metrics(
        &args.metric,
        &configs[0],
        existing.as_ref().map(|e| &e.table),
    )?;

    let all_runs = plan.runs();
    let todo: Vec<RunSpec> = all_runs
        .iter()
        .copied()
        .filter(|r| {
            !existing
                .as_ref()
                .is_some_and(|e| e.done.contains(&(plan.combos[r.combo].clone(), r.seed)))
        })
        .collect();
    let jobs: Vec<Job> = todo
        .iter()
        .map(|r| {
            let mut cfg = configs[r.combo].clone();
            cfg.scenario.seed = r.seed;
            Job {
                dir: out.join("runs").join(plan.dir_name(*r)),
                config_toml: cfg.to_toml(),
            }
        })
        .collect();

    std::fs::create_dir_all(&out)
        .map_err(|e| SwarmError::User(format!("cannot create {}: {e}", out.display())))?;
    let mut csv = SweepCsv::open(&csv_path, &plan.keys, existing.as_ref().map(|e| &e.table))?;
    let pb = progress_bar(jobs.len() as u64);
    if !pb.is_hidden() {
        pb.println(format!(
            "sweep: {} runs ({} combinations x {} seeds); {} done already, {} to run, {} at a time, {}",
            all_runs.len(),
            plan.combos.len(),
            plan.seeds.len(),
            all_runs.len() - todo.len(),
            todo.len(),
            args.pool.jobs.min(todo.len().max(1) as u64),
            mode(args.pool.in_process),
        ));
    }

    let opts = PoolOptions {
        swarm: std::env::current_exe()
            .map_err(|e| anyhow::anyhow!("cannot locate the swarm executable: {e}"))?,
        in_process: args.pool.in_process,
        jobs: args.pool.jobs as usize,
    };
    let mut failures: Vec<String> = Vec::new();
    let mut stopped_from_outside: Vec<String> = Vec::new();
    let mut write_error: Option<anyhow::Error> = None;
    let mut stopping = false;
    let interrupted = runner::run_all(&jobs, &opts, interrupt, |ev| match ev {
        Event::Interrupt(n) => {
            stopping = true;
            pb.suspend(|| {
                if n == 1 {
                    eprintln!(
                        "stopping the sweep: no new runs; running ones stop after their current \
                         tick (Ctrl-C again to kill them)"
                    );
                } else {
                    eprintln!("killing the running runs");
                }
            });
        }
        Event::Finished(i, outcome) => {
            let spec = todo[i];
            let rel = format!("runs/{}", plan.dir_name(spec));
            let row = |metrics| Row {
                values: plan.combos[spec.combo].clone(),
                seed: spec.seed,
                metrics,
                run_dir: rel.clone(),
            };
            let pushed = match outcome {
                Outcome::Done(m) => {
                    pb.inc(1);
                    csv.push(row(table::flatten(&m)))
                }
                Outcome::Failed { metrics, reason } => {
                    pb.inc(1);
                    pb.suspend(|| eprintln!("warning: run {rel} failed: {reason}"));
                    failures.push(format!("{rel}: {reason}"));
                    let mut flat = metrics.map(|m| table::flatten(&m)).unwrap_or_default();
                    flat.insert(FAILED.into(), "true".into());
                    csv.push(row(flat))
                }
                Outcome::Interrupted => {
                    // Not a row: its directory goes, and resume runs it again.
                    if !stopping {
                        stopped_from_outside.push(rel.clone());
                    }
                    std::fs::remove_dir_all(out.join(&rel)).map_err(anyhow::Error::from)
                }
                Outcome::NotStarted => Ok(()),
            };
            if let Err(e) = pushed
                && write_error.is_none()
            {
                write_error = Some(e);
            }
        }
    });
    pb.finish_and_clear();
    csv.finish()?;
    if !csv.ignored.is_empty() {
        eprintln!(
            "warning: metrics missing from sweep.csv's columns were left out: {}",
            csv.ignored.iter().cloned().collect::<Vec<_>>().join(", ")
        );
    }

    let command = command_line(&out, args.out.is_none());
    let finished = write_reports(&out, &plan, &base, args, &command, &all_runs)?;
    println!("{}", out.display());

    if let Some(e) = write_error {
        return Err(SwarmError::Internal(e.context("writing the sweep")));
    }
    if interrupted {
        return Err(SwarmError::Interrupted(format!(
            "sweep interrupted: {finished} of {} runs finished; resume with: {command}",
            all_runs.len()
        )));
    }
    if !failures.is_empty() {
        return Err(SwarmError::Internal(anyhow::anyhow!(
            "{} of {} runs failed (rows with failed=true in {}; the same command runs them again); first: {}",
            failures.len(),
            all_runs.len(),
            csv_path.display(),
            failures[0]
        )));
    }
    if !stopped_from_outside.is_empty() {
        return Err(SwarmError::Internal(anyhow::anyhow!(
            "{} runs were stopped by a signal from outside the sweep and are not in sweep.csv \
             (first: {}); the same command runs them again",
            stopped_from_outside.len(),
            stopped_from_outside[0]
        )));
    }
    Ok(())
}

/// `--out` must be new, empty, or a sweep directory (it has `sweep.csv`, or only `runs/` when
/// no run had finished yet): the sweep replaces its `plots/` and run directories.
fn check_out_dir(out: &Path) -> SwarmResult<()> {
    let Ok(entries) = std::fs::read_dir(out) else {
        if out.exists() {
            return Err(SwarmError::User(format!(
                "--out {}: not a directory",
                out.display()
            )));
        }
        return Ok(());
    };
    let names: Vec<String> = entries
        .flatten()
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .collect();
    if names.iter().any(|n| n == "sweep.csv") || names.iter().all(|n| n == "runs") {
        return Ok(());
    }
    Err(SwarmError::User(format!(
        "--out {}: exists and is not a sweep directory (no sweep.csv); give a new or empty directory",
        out.display()
    )))
}

pub(crate) fn mode(in_process: bool) -> &'static str {
    if in_process {
        "in-process"
    } else {
        "processes"
    }
}

/// The sweep's (and the tune's) bar: runs done, elapsed, ETA. Hidden when stderr is not a
/// terminal.
pub(crate) fn progress_bar(total: u64) -> ProgressBar {
    let pb = ProgressBar::with_draw_target(
        Some(total),
        if std::io::stderr().is_terminal() {
            ProgressDrawTarget::stderr()
        } else {
            ProgressDrawTarget::hidden()
        },
    );
    pb.set_style(
        ProgressStyle::with_template("{bar:40} {pos}/{len} runs  {elapsed_precise}  ETA {eta}")
            .expect("valid template"),
    );
    pb
}

/// Reads an existing `sweep.csv` for resume: its varied keys must be this command's, and
/// every finished run of this plan must have been made with the config this command would use.
/// Failed runs of this plan, duplicates and cut lines are dropped (to run again).
fn read_existing(
    path: &Path,
    plan: &Plan,
    configs: &[Config],
    out: &Path,
) -> SwarmResult<Existing> {
    let (table, skipped) = Table::read(path).map_err(SwarmError::User)?;
    let k = plan.keys.len();
    let seed_col = table.col(SEED).unwrap_or(0);
    if table.header[..seed_col] != plan.keys[..] {
        return Err(SwarmError::User(format!(
            "{}: its rows vary [{}], this command varies [{}]; give another --out",
            path.display(),
            table.header[..seed_col].join(", "),
            plan.keys.join(", ")
        )));
    }
    let dir_col = table.header.len() - 1;
    let failed_col = table.col(FAILED);
    let mut seen: BTreeSet<RunKey> = BTreeSet::new();
    let mut done: BTreeSet<RunKey> = BTreeSet::new();
    let mut rows = Vec::with_capacity(table.rows.len());
    let mut dropped = skipped;
    for row in table.rows {
        let Ok(seed) = row[k].parse::<u64>() else {
            dropped += 1;
            continue;
        };
        let key: RunKey = (row[..k].to_vec(), seed);
        let combo = plan.combos.iter().position(|c| c[..] == row[..k]);
        let planned = combo.is_some() && plan.seeds.contains(&seed);
        let failed = failed_col.is_some_and(|c| row[c] != "false");
        if seen.contains(&key) || (planned && failed) {
            dropped += 1;
            continue;
        }
        if let Some(c) = combo.filter(|_| planned) {
            let mut expected = configs[c].clone();
            expected.scenario.seed = seed;
            check_same_config(&out.join(&row[dir_col]), &expected, path)?;
            done.insert(key.clone());
        }
        seen.insert(key);
        rows.push(row);
    }
    if dropped > 0 {
        tracing::info!(dropped, "sweep.csv rows to run again");
    }
    Ok(Existing {
        table: Table {
            header: table.header,
            rows,
        },
        done,
    })
}

/// Refuses to resume into rows made with another config (another `--set`, an edited file).
/// A run directory the user deleted is not checked.
fn check_same_config(run_dir: &Path, expected: &Config, csv: &Path) -> SwarmResult<()> {
    let path = run_dir.join("config.toml");
    let Ok(text) = std::fs::read_to_string(&path) else {
        return Ok(());
    };
    let want = expected.to_toml();
    let found = Config::from_toml_str(&path.display().to_string(), &text, &[])
        .map(|c| c.to_toml())
        .unwrap_or(text);
    if found == want {
        return Ok(());
    }
    Err(SwarmError::User(format!(
        "{}: the finished run {} used another config than this command ({}); \
         give another --out, or the same config and --set as before",
        csv.display(),
        run_dir.display(),
        first_difference(&want, &found)
    )))
}

/// The first differing line of two TOML texts, with its section: `[radio] loss = 0.1 here, loss = 0.2 there`.
pub(crate) fn first_difference(want: &str, found: &str) -> String {
    let mut section = String::new();
    let mut w = want.lines();
    let mut f = found.lines();
    loop {
        match (w.next(), f.next()) {
            (None, None) => return "same text".into(),
            (a, b) if a == b => {
                if let Some(l) = a.filter(|l| l.starts_with('[')) {
                    section = format!("{l} ");
                }
            }
            (a, b) => {
                return format!(
                    "{section}`{}` now, `{}` then",
                    a.unwrap_or("(nothing)"),
                    b.unwrap_or("(nothing)")
                );
            }
        }
    }
}

/// The scalar metrics a run of this scenario reports, known before anything runs: what
/// `swarm run` adds, the world's, and the metrics registry's for its behaviour (also used by
/// `swarm tune` to check `--fitness`).
pub(crate) fn known_metrics(cfg: &Config) -> BTreeSet<String> {
    let mut known: BTreeSet<String> = RUN_METRICS.iter().map(|s| s.to_string()).collect();
    known.extend(
        swarmrt_analysis::metrics::names(cfg)
            .iter()
            .map(|s| s.to_string()),
    );
    // The world's metrics have the same keys in every run.
    if let Ok(v) = serde_json::to_value(WorldMetrics::default()) {
        known.extend(table::flatten(&v).into_keys());
    }
    known.remove("mode");
    known
}

/// Refuses a `--metric` no run of this scenario reports, before anything runs.
fn check_metrics(requested: &[String], cfg: &Config, existing: Option<&Table>) -> SwarmResult<()> {
    if requested.is_empty() {
        return Ok(());
    }
    let mut known = known_metrics(cfg);
    if let Some(t) = existing {
        known.extend(t.metric_columns().iter().cloned());
    }
    known.remove("mode");
    for m in requested {
        if !known.contains(m) {
            return Err(SwarmError::User(format!(
                "--metric `{m}`: not a metric of this scenario; known: {}",
                known.into_iter().collect::<Vec<_>>().join(", ")
            )));
        }
    }
    Ok(())
}

/// Draws the plots and writes `summary.md` from every row of `sweep.csv`; returns how many
/// runs of this plan are finished.
fn write_reports(
    out: &Path,
    plan: &Plan,
    base: &Config,
    args: &SweepArgs,
    command: &str,
    all_runs: &[RunSpec],
) -> SwarmResult<usize> {
    let csv_path = out.join("sweep.csv");
    if !csv_path.exists() {
        return Ok(0);
    }
    let (table, _) = Table::read(&csv_path).map_err(SwarmError::User)?;
    let k = plan.keys.len();
    let failed_col = table.col(FAILED);
    let finished: BTreeSet<RunKey> = table
        .rows
        .iter()
        .filter(|r| failed_col.is_some_and(|c| r[c] == "false"))
        .filter_map(|r| Some((r[..k].to_vec(), r[k].parse().ok()?)))
        .collect();
    let finished = all_runs
        .iter()
        .filter(|r| finished.contains(&(plan.combos[r.combo].clone(), r.seed)))
        .count();

    let order: Vec<Vec<String>> = (0..k)
        .map(|i| {
            let mut vals: Vec<String> = Vec::new();
            for c in &plan.combos {
                if !vals.contains(&c[i]) {
                    vals.push(c[i].clone());
                }
            }
            vals
        })
        .collect();
    let groups = Groups::new(&table, &plan.keys, &order);
    let mut metrics = report::chosen_metrics(&args.metric, &table);
    metrics.retain(|m| {
        let present = table.metric_columns().contains(m);
        if !present {
            eprintln!("warning: no run in sweep.csv reports `{m}`; it is not plotted");
        }
        present
    });
    let plots_dir = out.join("plots");
    if plots_dir.exists() {
        std::fs::remove_dir_all(&plots_dir)?;
    }
    let plots = report::write_plots(&plots_dir, &groups, &base.scenario.name, &metrics)
        .map_err(|e| SwarmError::Internal(e.context("drawing the sweep plots")))?;
    let head = SummaryHead {
        scenario: &base.scenario.name,
        command,
        mode: mode(args.pool.in_process),
    };
    let md = report::summary_md(&head, &table, &groups, &metrics, &plots);
    swarmrt_scenario::safe_fs::write_replace_nofollow(&out.join("summary.md"), md)?;
    Ok(finished)
}

/// This invocation as a shell command, with `--out` added when it was defaulted, so it
/// resumes the same sweep (or tune).
pub(crate) fn command_line(out: &Path, add_out: bool) -> String {
    let mut args: Vec<String> = std::env::args().collect();
    if let Some(first) = args.first_mut() {
        *first = "swarm".into();
    }
    if add_out {
        args.push("--out".into());
        args.push(out.display().to_string());
    }
    args.iter()
        .map(|a| shell_quote(a))
        .collect::<Vec<_>>()
        .join(" ")
}

/// `a` as one shell word.
fn shell_quote(a: &str) -> String {
    let safe = |c: char| c.is_ascii_alphanumeric() || "-_./=,:+@%".contains(c);
    if !a.is_empty() && a.chars().all(safe) {
        a.to_string()
    } else {
        format!("'{}'", a.replace('\'', "'\\''"))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shell_words() {
        assert_eq!(shell_quote("radio.loss=0,0.1"), "radio.loss=0,0.1");
        assert_eq!(shell_quote("a b"), "'a b'");
        assert_eq!(shell_quote("it's"), "'it'\\''s'");
        assert_eq!(shell_quote(""), "''");
    }

    #[test]
    fn config_differences_name_the_line() {
        let a = "[scenario]\nname = \"x\"\nticks = 60\n[radio]\nloss = 0.1\n";
        let b = "[scenario]\nname = \"x\"\nticks = 900\n[radio]\nloss = 0.1\n";
        assert_eq!(
            first_difference(a, b),
            "[scenario] `ticks = 60` now, `ticks = 900` then"
        );
        assert_eq!(first_difference(a, a), "same text");
    }
}
