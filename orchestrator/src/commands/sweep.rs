//! `swarm sweep`: a scenario over the cross product of varied keys and seeds. Every run is an
//! ordinary run directory under `<out>/runs/`; `sweep.csv` gets a row as each run finishes;
//! plots and `summary.md` are drawn from all rows at the end. Re-running the same command
//! with the same `--out` runs only what is missing (or failed).

use std::collections::{BTreeMap, BTreeSet};
use std::io::IsTerminal;
use std::path::Path;

use clap::Parser;
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use swarmrt_scenario::Config;
use swarmrt_scenario::safe_fs::OutDir;
use swarmrt_world::WorldMetrics;

use crate::cli::SweepArgs;
use crate::config::load_config;
use crate::error::{SwarmError, SwarmResult};
use crate::run_dir;
use crate::sweep::executor::{self, Executor};
use crate::sweep::plan::{self, Plan, RunSpec};
use crate::sweep::report::{self, SummaryHead};
use crate::sweep::runner::{self, Event, Job, Outcome, PoolOptions};
use crate::sweep::slurm;
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

/// Runs the sweep, or (`--collect`) gathers the runs a detached one submitted.
pub fn sweep(args: &SweepArgs, interrupt: crossbeam_channel::Receiver<()>) -> SwarmResult<()> {
    match &args.collect {
        Some(dir) => {
            let args = detached_command(dir)?;
            sweep_with(&args, interrupt, true)
        }
        None => sweep_with(args, interrupt, false),
    }
}

/// File of a sweep directory holding the command of its detached submission.
const DETACHED_COMMAND: &str = "command.json";

fn sweep_with(
    args: &SweepArgs,
    interrupt: crossbeam_channel::Receiver<()>,
    collect_only: bool,
) -> SwarmResult<()> {
    let Some(config) = args.config.as_deref() else {
        return Err(SwarmError::User(
            "give the scenario file (or --collect <sweep dir>)".into(),
        ));
    };
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
    let executor = executor::resolve(&args.pool)?;
    if args.detach && !matches!(executor, Executor::Slurm(_)) {
        return Err(SwarmError::User(
            "--detach needs a cluster to leave the runs to: add --executor slurm".into(),
        ));
    }
    let base = load_config(config, &args.pool.set)?;
    let start = args.start_seed.unwrap_or(base.scenario.seed);
    let plan = Plan::new(&varies, start, args.seeds).map_err(SwarmError::User)?;

    // Every combination must resolve before anything runs.
    let mut configs: Vec<Config> = Vec::with_capacity(plan.combos.len());
    for c in 0..plan.combos.len() {
        let mut set = args.pool.set.clone();
        set.extend(plan.overrides(c));
        let cfg = load_config(config, &set).map_err(|e| match e {
            SwarmError::User(m) if plan.combos.len() > 1 => {
                SwarmError::User(format!("{m} (with {})", plan.describe(c)))
            }
            e => e,
        })?;
        configs.push(cfg);
    }

    // A --metric no run reports is refused before the directory is made; an existing
    // sweep's columns may add to what is known, so with one it is checked below instead.
    if args
        .out
        .as_ref()
        .is_none_or(|o| !o.join("sweep.csv").exists())
    {
        check_metrics(&args.metric, &configs[0], None)?;
    }
    // Checked once (no other user owns it, may write it, or could swap a directory on the
    // way to it); sweep.csv, the plots and summary.md are written through its handle.
    let out_dir = match &args.out {
        Some(out) => run_dir::open_out("--out", out)?,
        None => run_dir::unused_dir(
            Path::new("sweeps"),
            &format!("{}-{}", base.scenario.name, run_dir::timestamp()),
        )?,
    };
    let out = out_dir.path().to_path_buf();
    let csv_path = out.join("sweep.csv");
    check_out_dir(&out)?;
    let existing = if csv_path.exists() {
        Some(read_existing(
            &csv_path,
            &plan,
            &configs,
            &out,
            collect_only,
        )?)
    } else {
        None
    };
    if let Some(e) = &existing {
        check_metrics(&args.metric, &configs[0], Some(&e.table))?;
    }
    let all_runs = plan.runs();
    let spec_of_dir: BTreeMap<String, RunSpec> =
        all_runs.iter().map(|r| (plan.dir_name(*r), *r)).collect();
    let submitted = slurm::pending_arrays(&out)?;
    check_submitted(&submitted, &spec_of_dir, &configs, &out)?;

    let mut csv = SweepCsv::open(
        &out_dir,
        "sweep.csv",
        &plan.keys,
        existing.as_ref().map(|e| &e.table),
    )?;
    let mut done: BTreeSet<RunKey> = existing.map(|e| e.done).unwrap_or_default();
    let key_of = |r: &RunSpec| (plan.combos[r.combo].clone(), r.seed);
    let swarm = std::env::current_exe()
        .map_err(|e| anyhow::anyhow!("cannot locate the swarm executable: {e}"))?;
    let opts = PoolOptions {
        swarm,
        in_process: args.pool.in_process,
        executor: executor.clone(),
        state_dir: out.clone(),
    };
    let mut fold = Fold {
        plan: &plan,
        out: &out_dir,
        csv: &mut csv,
        pb: progress_bar(0),
        failures: Vec::new(),
        stopped_from_outside: Vec::new(),
        write_error: None,
        stopping: false,
        slurm: matches!(executor, Executor::Slurm(_)),
        hosts_lost: Vec::new(),
    };

    // Runs an earlier (detached or stopped) invocation left to Slurm come first: they are not
    // submitted again, only waited for.
    let mut interrupted = false;
    if !submitted.is_empty() {
        let specs: Vec<Option<RunSpec>> = submitted
            .iter()
            .flat_map(|a| &a.runs)
            .map(|r| {
                let name = r.file_name()?.to_string_lossy().into_owned();
                let spec = spec_of_dir.get(&name).copied()?;
                (!done.contains(&key_of(&spec))).then_some(spec)
            })
            .collect();
        let ids: Vec<&str> = submitted.iter().map(|a| a.job_id.as_str()).collect();
        fold.pb = progress_bar(specs.iter().flatten().count() as u64);
        fold.say(format!(
            "sweep: waiting for {} runs already submitted to Slurm (job {}); Ctrl-C stops \
             waiting and leaves them queued",
            specs.iter().flatten().count(),
            ids.join(", ")
        ));
        let poll = match &executor {
            Executor::Slurm(s) => s.poll,
            Executor::Local { .. } | Executor::Ssh(_) => std::time::Duration::from_secs(1),
        };
        interrupted = slurm::wait(&submitted, poll, false, &interrupt, &mut |ev| {
            if let Event::Finished(i, o) = &ev
                && let Some(spec) = specs[*i]
            {
                // Collected, failed or not: a failed one has its row and is run again by the
                // next command, as on any resume.
                if matches!(o, Outcome::Done(_) | Outcome::Failed { .. }) {
                    done.insert(key_of(&spec));
                }
                fold.event(spec, ev);
            } else if let Event::Interrupt(_) = ev {
                fold.stopping = true;
            }
        });
        fold.pb.finish_and_clear();
    }

    let todo: Vec<RunSpec> = all_runs
        .iter()
        .copied()
        .filter(|r| !done.contains(&key_of(r)))
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

    let command = command_line(&out, args.out.is_none());
    if !interrupted && !collect_only && !jobs.is_empty() {
        fold.pb = progress_bar(jobs.len() as u64);
        fold.say(format!(
            "sweep: {} runs ({} combinations x {} seeds); {} done already, {} to run, {}, {}",
            all_runs.len(),
            plan.combos.len(),
            plan.seeds.len(),
            all_runs.len() - todo.len(),
            todo.len(),
            executor.describe(todo.len()),
            mode(args.pool.in_process),
        ));
        if args.detach {
            let Executor::Slurm(s) = &executor else {
                unreachable!("checked above")
            };
            let (arrays, index) = slurm::prepare_and_submit(&jobs, &opts, s, &mut |ev| {
                if let Event::Finished(i, _) = &ev {
                    fold.event(todo[*i], ev);
                }
            });
            write_detached_command(&out_dir)?;
            let ids: Vec<&str> = arrays.iter().map(|a| a.job_id.as_str()).collect();
            fold.pb.finish_and_clear();
            fold.csv.finish()?;
            println!("{}", out.display());
            if !ids.is_empty() {
                eprintln!(
                    "submitted {} runs as Slurm job {}; gather them with: swarm sweep --collect {}",
                    index.len(),
                    ids.join(", "),
                    out.display()
                );
            }
            return fold.result(all_runs.len(), &csv_path);
        }
        interrupted = runner::run_all(&jobs, &opts, interrupt, |ev| match ev {
            Event::Finished(i, _) => fold.event(todo[i], ev),
            ev => fold.interrupt(ev),
        });
        fold.pb.finish_and_clear();
    } else if collect_only && !todo.is_empty() && !interrupted {
        eprintln!(
            "{} runs of this sweep were not submitted (or failed); the sweep's command runs them: {command}",
            todo.len()
        );
    }
    fold.csv.finish()?;
    if !fold.csv.ignored.is_empty() {
        eprintln!(
            "warning: metrics missing from sweep.csv's columns were left out: {}",
            fold.csv
                .ignored
                .iter()
                .cloned()
                .collect::<Vec<_>>()
                .join(", ")
        );
    }

    let finished = write_reports(&out_dir, &plan, &base, args, &command, &all_runs)?;
    println!("{}", out.display());

    if let Some(e) = fold.write_error.take() {
        return Err(SwarmError::Internal(e.context("writing the sweep")));
    }
    if interrupted {
        let resume = if submitted.is_empty() {
            command
        } else {
            format!("{command} (runs still queued in Slurm are waited for, not run again)")
        };
        return Err(SwarmError::Interrupted(format!(
            "sweep interrupted: {finished} of {} runs finished; resume with: {resume}",
            all_runs.len()
        )));
    }
    fold.result(all_runs.len(), &csv_path)
}

/// Folds finished runs into `sweep.csv` and keeps what the end of the sweep reports.
struct Fold<'a> {
    plan: &'a Plan,
    out: &'a OutDir,
    csv: &'a mut SweepCsv,
    pb: ProgressBar,
    /// `runs/<dir>: reason` of each failed run.
    failures: Vec<String>,
    /// Runs a signal from outside stopped (not rows).
    stopped_from_outside: Vec<String>,
    write_error: Option<anyhow::Error>,
    /// Ctrl-C arrived: an interrupted run is the sweep's doing.
    stopping: bool,
    /// The runs go to Slurm: Ctrl-C cancels them there.
    slurm: bool,
    /// Hosts of the ssh executor lost on the way (their runs went to the others).
    hosts_lost: Vec<String>,
}

impl Fold<'_> {
    fn say(&self, line: String) {
        if !self.pb.is_hidden() {
            self.pb.println(line);
        }
    }

    fn interrupt(&mut self, ev: Event) {
        if let Event::HostLost(line) = &ev {
            self.pb.suspend(|| eprintln!("warning: {line}"));
            self.hosts_lost.push(line.clone());
        }
        if let Event::Interrupt(n) = ev {
            self.stopping = true;
            let slurm = self.slurm;
            self.pb.suspend(|| {
                if slurm && n == 1 {
                    eprintln!(
                        "stopping the sweep: cancelling its Slurm jobs; finished runs are kept \
                         (Ctrl-C again to stop waiting for the cancelled ones)"
                    );
                } else if n == 1 {
                    eprintln!(
                        "stopping the sweep: no new runs; running ones stop after their current \
                         tick (Ctrl-C again to kill them)"
                    );
                } else {
                    eprintln!("killing the running runs");
                }
            });
        }
    }

    fn event(&mut self, spec: RunSpec, ev: Event) {
        let Event::Finished(_, outcome) = ev else {
            return self.interrupt(ev);
        };
        let rel = format!("runs/{}", self.plan.dir_name(spec));
        let row = |metrics| Row {
            values: self.plan.combos[spec.combo].clone(),
            seed: spec.seed,
            metrics,
            run_dir: rel.clone(),
        };
        let pushed = match outcome {
            Outcome::Done(m) => {
                self.pb.inc(1);
                self.csv.push(row(table::flatten(&m)))
            }
            Outcome::Failed { metrics, reason } => {
                self.pb.inc(1);
                self.pb
                    .suspend(|| eprintln!("warning: run {rel} failed: {reason}"));
                self.failures.push(format!("{rel}: {reason}"));
                let mut flat = metrics.map(|m| table::flatten(&m)).unwrap_or_default();
                flat.insert(FAILED.into(), "true".into());
                self.csv.push(row(flat))
            }
            Outcome::Interrupted => {
                // Not a row: its directory goes, and resume runs it again.
                if !self.stopping {
                    self.stopped_from_outside.push(rel.clone());
                }
                remove_run_dir(self.out, &rel).map_err(anyhow::Error::from)
            }
            Outcome::NotStarted => Ok(()),
        };
        if let Err(e) = pushed
            && self.write_error.is_none()
        {
            self.write_error = Some(e);
        }
    }

    /// Exit 1 when a run failed or was stopped from outside, naming the first.
    fn result(&mut self, runs: usize, csv_path: &Path) -> SwarmResult<()> {
        if !self.hosts_lost.is_empty() {
            eprintln!(
                "{} host(s) lost during the sweep; their runs were made on the others: {}",
                self.hosts_lost.len(),
                self.hosts_lost.join("; ")
            );
        }
        if let Some(e) = self.write_error.take() {
            return Err(SwarmError::Internal(e.context("writing the sweep")));
        }
        if !self.failures.is_empty() {
            return Err(SwarmError::Internal(anyhow::anyhow!(
                "{} of {} runs failed (rows with failed=true in {}; the same command runs them again); first: {}",
                self.failures.len(),
                runs,
                csv_path.display(),
                self.failures[0]
            )));
        }
        if !self.stopped_from_outside.is_empty() {
            return Err(SwarmError::Internal(anyhow::anyhow!(
                "{} runs were stopped by a signal from outside the sweep and are not in sweep.csv \
                 (first: {}); the same command runs them again",
                self.stopped_from_outside.len(),
                self.stopped_from_outside[0]
            )));
        }
        Ok(())
    }
}

/// Runs an earlier invocation submitted to Slurm must be runs of this command, with its
/// configs: otherwise their rows would mix two sweeps.
fn check_submitted(
    arrays: &[slurm::Array],
    spec_of_dir: &BTreeMap<String, RunSpec>,
    configs: &[Config],
    out: &Path,
) -> SwarmResult<()> {
    for run in arrays.iter().flat_map(|a| &a.runs) {
        let name = run
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default();
        let Some(spec) = spec_of_dir.get(&name) else {
            return Err(SwarmError::User(format!(
                "{}: Slurm runs of another sweep command are still to collect ({} is not a run of \
                 this one); gather them with `swarm sweep --collect {}` or give another --out",
                out.display(),
                run.display(),
                out.display()
            )));
        };
        let mut expected = configs[spec.combo].clone();
        expected.scenario.seed = spec.seed;
        check_same_config(run, &expected, &out.join(slurm::SLURM_DIR))?;
    }
    Ok(())
}

/// Removes the run directory `rel` (`runs/<name>`) of the sweep in `out`, through its handle.
fn remove_run_dir(out: &OutDir, rel: &str) -> std::io::Result<()> {
    match rel.split_once('/') {
        Some((runs, name)) => out.subdir(runs)?.remove_dir_all(name),
        None => out.remove_dir_all(rel),
    }
}

/// Keeps the detached sweep's command (as it would resume, without --detach) for `--collect`.
fn write_detached_command(out: &OutDir) -> SwarmResult<()> {
    let argv: Vec<String> = std::env::args()
        .skip(1)
        .filter(|a| a != "--detach")
        .collect();
    let cwd = std::env::current_dir()?;
    let text = serde_json::to_string_pretty(&Detached {
        cwd: cwd.display().to_string(),
        argv,
    })
    .map_err(anyhow::Error::from)?;
    out.create_subdir(slurm::SLURM_DIR)?
        .write_replace(DETACHED_COMMAND, text)?;
    Ok(())
}

/// What `--detach` keeps for `--collect`: the command and the directory it was given in.
#[derive(serde::Serialize, serde::Deserialize)]
struct Detached {
    cwd: String,
    argv: Vec<String>,
}

/// The sweep command a detached sweep in `dir` was started with, to collect it.
fn detached_command(dir: &Path) -> SwarmResult<SweepArgs> {
    let path = dir.join(slurm::SLURM_DIR).join(DETACHED_COMMAND);
    let text = std::fs::read_to_string(&path).map_err(|e| {
        SwarmError::User(format!(
            "--collect {}: no detached sweep there ({}: {e})",
            dir.display(),
            path.display()
        ))
    })?;
    let detached: Detached = serde_json::from_str(&text)
        .map_err(|e| SwarmError::User(format!("{}: not a sweep command: {e}", path.display())))?;
    let dir = std::path::absolute(dir)?;
    // Relative paths of the command (its config, robot programs) are the submitter's.
    std::env::set_current_dir(&detached.cwd).map_err(|e| {
        SwarmError::User(format!(
            "{}: the sweep was submitted from {}, which is gone: {e}",
            path.display(),
            detached.cwd
        ))
    })?;
    let cli =
        crate::cli::Cli::try_parse_from(std::iter::once("swarm".to_string()).chain(detached.argv))
            .map_err(|e| {
                SwarmError::User(format!(
                    "{}: not a sweep command: {}",
                    path.display(),
                    e.to_string().lines().next().unwrap_or("")
                ))
            })?;
    match cli.command {
        crate::cli::Cmd::Sweep(mut args) => {
            args.detach = false;
            args.out = Some(dir);
            Ok(args)
        }
        _ => Err(SwarmError::User(format!(
            "{}: not a sweep command",
            path.display()
        ))),
    }
}

/// `--out` must be new, empty, or a sweep directory (it has `sweep.csv`, or only `runs/` and
/// `slurm/` when no run had finished yet): the sweep replaces its `plots/` and run directories.
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
    if names.iter().any(|n| n == "sweep.csv")
        || names.iter().all(|n| n == "runs" || n == slurm::SLURM_DIR)
    {
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
/// Failed runs of this plan, duplicates and cut lines are dropped (to run again); with
/// `keep_failed` (`--collect`, which runs nothing) failed rows stay.
fn read_existing(
    path: &Path,
    plan: &Plan,
    configs: &[Config],
    out: &Path,
    keep_failed: bool,
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
        if seen.contains(&key) || (planned && failed && !keep_failed) {
            dropped += 1;
            continue;
        }
        if let Some(c) = combo.filter(|_| planned && !failed) {
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
    out_dir: &OutDir,
    plan: &Plan,
    base: &Config,
    args: &SweepArgs,
    command: &str,
    all_runs: &[RunSpec],
) -> SwarmResult<usize> {
    let out = out_dir.path();
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
    if out_dir.stat("plots").is_some() {
        out_dir.remove_dir_all("plots")?;
    }
    let plots_dir = out_dir.create_subdir("plots")?;
    let plots = report::write_plots(&plots_dir, &groups, &base.scenario.name, &metrics)
        .map_err(|e| SwarmError::Internal(e.context("drawing the sweep plots")))?;
    let head = SummaryHead {
        scenario: &base.scenario.name,
        command,
        mode: mode(args.pool.in_process),
    };
    let md = report::summary_md(&head, &table, &groups, &metrics, &plots);
    out_dir.write_replace("summary.md", md)?;
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
