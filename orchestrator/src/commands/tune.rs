//! `swarm tune`: noise-resistant PSO over numeric config keys against a metric of the runs
//! (docs/tune.md). The optimiser is a pure state machine (`tune::pso`); this file checks the
//! command, replays the swarm, takes the fitness of every evaluation `tune.csv` already holds
//! and runs the others, one iteration a batch, through the sweep's pool
//! (`sweep::runner::run_all`), and writes `tune.csv`, `best.toml`, `tune.json` and the plots.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use rand::Rng as _;
use serde_json::json;
use swarmrt_analysis::metrics::lookup;
use swarmrt_analysis::plot::tune::{History, write_tune_plots};
use swarmrt_scenario::Config;
use swarmrt_scenario::safe_fs::OutDir;

use crate::cli::TuneArgs;
use crate::commands::sweep::{command_line, known_metrics, mode, progress_bar};
use crate::config::load_config;
use crate::error::{SwarmError, SwarmResult};
use crate::run_dir;
use crate::sweep::runner::{self, Event, Job, Outcome, PoolOptions};
use crate::tune::pso::{Kind, Options, Pso};
use crate::tune::record::{self, EvalRow, Settings, Status, TuneCsv, write_atomic};
use crate::tune::space::{self, Param};

/// The checked command.
struct Tune<'a> {
    args: &'a TuneArgs,
    params: Vec<Param>,
    settings: Settings,
    out: PathBuf,
    scenario: String,
}

impl Tune<'_> {
    /// Evaluation `k`'s run seed: the next of `--seeds` in turn, or drawn from (`--seed`, k).
    fn run_seed(&self, k: u64) -> u64 {
        match &self.settings.seeds {
            Some(list) => list[(k % list.len() as u64) as usize],
            None => swarmrt_scenario::rng::stream(self.settings.seed, "tune-run-seed", k)
                .random::<u32>() as u64,
        }
    }

    /// The fitness the swarm minimises: the metric (negated to maximise); a failed or missing
    /// evaluation is the worst.
    fn internal(&self, row: &EvalRow) -> f64 {
        match (row.status, row.fitness) {
            (Status::Ok, Some(f)) if self.settings.maximize => -f,
            (Status::Ok, Some(f)) => f,
            _ => f64::INFINITY,
        }
    }

    /// Back from the swarm's sign to the metric's; `None` when not finite.
    fn external(&self, f: f64) -> Option<f64> {
        f.is_finite()
            .then_some(if self.settings.maximize { -f } else { f })
    }

    /// `--set` overrides putting the parameters at `position`.
    fn overrides(&self, position: &[f64]) -> Vec<String> {
        let mut set = self.args.pool.set.clone();
        set.extend(self.params.iter().zip(position).map(|(p, &x)| p.set(x)));
        set
    }
}

/// Where evaluation `k` runs, relative to the tune directory.
fn run_rel(k: u64) -> String {
    format!("runs/e{k:05}")
}

/// Runs the tune.
pub fn tune(args: &TuneArgs, interrupt: crossbeam_channel::Receiver<()>) -> SwarmResult<()> {
    let tune = check(args)?;
    let executor = crate::sweep::executor::resolve(&args.pool)?;
    let out = tune.out.clone();
    let cache = open_out(&out, &tune)?;
    // Checked once, then tune.csv, tune.json, best.toml and the plots go through its handle.
    let out_dir = run_dir::open_out("--out", &out)?;
    if out_dir.stat("tune.json").is_none() {
        write_atomic(
            &out_dir,
            "tune.json",
            &(serde_json::to_string_pretty(&summary(&tune, None, &[], false))
                .map_err(anyhow::Error::from)?
                + "\n"),
        )?;
    }
    let mut csv = TuneCsv::open(&out_dir, "tune.csv", &tune.params)?;
    // Only a tune that was killed leaves Slurm arrays behind (Ctrl-C cancels them): their
    // evaluations are not in tune.csv and run again, so the old tasks go first.
    let stale = crate::sweep::slurm::pending_arrays(&out)?;
    if !stale.is_empty() {
        let ids: Vec<&str> = stale.iter().map(|a| a.job_id.as_str()).collect();
        eprintln!(
            "cancelling Slurm job(s) {} an earlier run of this tune left behind",
            ids.join(", ")
        );
        crate::sweep::slurm::abandon(&stale, std::time::Duration::from_secs(1));
    }

    let s = &tune.settings;
    let e = s.evaluations;
    let total = args.iterations * e;
    let cached = cache
        .values()
        .filter(|r| r.eval < total && r.status != Status::Failed)
        .count() as u64;
    let pb = progress_bar(total - cached.min(total));
    if !pb.is_hidden() {
        pb.println(format!(
            "tune: {} iterations x {} evaluations ({} particles); {} done already, {} to run, {}, {}",
            args.iterations,
            e,
            s.particles,
            cached,
            total - cached.min(total),
            executor.describe(e as usize),
            mode(args.pool.in_process),
        ));
    }
    let opts = Options {
        particles: s.particles as usize,
        evaluations: e as usize,
        inertia: s.inertia,
        c1: s.c1,
        c2: s.c2,
        vmax: s.vmax,
    };
    let bounds: Vec<(f64, f64)> = tune.params.iter().map(|p| (p.lo, p.hi)).collect();
    let mut pso = Pso::new(bounds.clone(), opts, s.seed).map_err(SwarmError::User)?;
    let pool = PoolOptions {
        swarm: std::env::current_exe()
            .map_err(|e| anyhow::anyhow!("cannot locate the swarm executable: {e}"))?,
        in_process: args.pool.in_process,
        executor,
        state_dir: out.clone(),
    };
    let mut history = History {
        scenario: tune.scenario.clone(),
        params: tune.params.iter().map(|p| p.key.clone()).collect(),
        bounds,
        fitness: s.fitness.clone(),
        ..History::default()
    };
    let mut done: Vec<EvalRow> = Vec::new();
    let mut warnings: Vec<String> = Vec::new();
    let command = command_line(&out, args.out.is_none());

    for t in 0..args.iterations {
        let batch = pso.ask();
        let mut rows: Vec<Option<EvalRow>> = vec![None; batch.len()];
        let mut jobs: Vec<Job> = Vec::new();
        let mut pending: Vec<(usize, EvalRow)> = Vec::new();
        for (j, ev) in batch.iter().enumerate() {
            let k = t * e + j as u64;
            let row = EvalRow {
                eval: k,
                iteration: t,
                particle: ev.particle as u64,
                kind: ev.kind,
                values: tune
                    .params
                    .iter()
                    .zip(&ev.position)
                    .map(|(p, &x)| p.value(x))
                    .collect(),
                seed: tune.run_seed(k),
                fitness: None,
                status: Status::Failed,
            };
            if let Some(c) = cache.get(&k) {
                if !c.same_eval(&row) {
                    return Err(SwarmError::User(format!(
                        "{}: its row eval={k} ({} {} of particle {} at [{}], seed {}) is not what \
                         this tune evaluates there ([{}], seed {}); give another --out",
                        out.join("tune.csv").display(),
                        c.kind.as_str(),
                        c.iteration,
                        c.particle,
                        c.values.join(", "),
                        c.seed,
                        row.values.join(", "),
                        row.seed
                    )));
                }
                if c.status != Status::Failed {
                    rows[j] = Some(c.clone());
                    continue;
                }
            }
            match load_config(&args.config, &tune.overrides(&ev.position)) {
                Ok(mut cfg) => {
                    cfg.scenario.seed = row.seed;
                    jobs.push(Job {
                        dir: out.join(run_rel(k)),
                        config_toml: cfg.to_toml(),
                    });
                    pending.push((j, row));
                }
                Err(err) => {
                    let msg = format!("evaluation {k} [{}]: {err}", row.values.join(", "));
                    pb.suspend(|| eprintln!("warning: {msg}; counted as the worst fitness"));
                    warnings.push(msg);
                    csv.push(&row)?;
                    rows[j] = Some(row);
                    pb.inc(1);
                }
            }
        }

        let mut write_error: Option<anyhow::Error> = None;
        let mut stopping = false;
        let mut stopped_from_outside = 0usize;
        let interrupted = !jobs.is_empty()
            && runner::run_all(&jobs, &pool, interrupt.clone(), |ev| match ev {
                Event::HostLost(line) => pb.suspend(|| eprintln!("warning: {line}")),
                Event::Interrupt(n) => {
                    stopping = true;
                    pb.suspend(|| {
                        if n == 1 {
                            eprintln!(
                                "stopping the tune: no new runs; running ones stop after their \
                                 current tick (Ctrl-C again to kill them)"
                            );
                        } else {
                            eprintln!("killing the running runs");
                        }
                    });
                }
                Event::Finished(i, outcome) => {
                    let (j, mut row) = pending[i].clone();
                    let rel = run_rel(row.eval);
                    match outcome {
                        Outcome::Done(m) => {
                            match lookup(&m, &s.fitness).filter(|f| f.is_finite()) {
                                Some(f) => {
                                    row.fitness = Some(f);
                                    row.status = Status::Ok;
                                }
                                None => {
                                    row.status = Status::Missing;
                                    let msg = format!(
                                        "{rel}: metrics.json has no number at `{}`",
                                        s.fitness
                                    );
                                    pb.suspend(|| {
                                        eprintln!("warning: {msg}; counted as the worst fitness")
                                    });
                                    warnings.push(msg);
                                }
                            }
                        }
                        Outcome::Failed { reason, .. } => {
                            let msg = format!("{rel} failed: {reason}");
                            pb.suspend(|| {
                                eprintln!("warning: run {msg}; counted as the worst fitness")
                            });
                            warnings.push(msg);
                        }
                        Outcome::Interrupted => {
                            // Not a row: its directory goes, and resume runs it again.
                            if !stopping {
                                stopped_from_outside += 1;
                            }
                            if let Err(e) = std::fs::remove_dir_all(out.join(&rel))
                                && write_error.is_none()
                            {
                                write_error = Some(e.into());
                            }
                            return;
                        }
                        Outcome::NotStarted => return,
                    }
                    pb.inc(1);
                    if let Err(e) = csv.push(&row)
                        && write_error.is_none()
                    {
                        write_error = Some(e);
                    }
                    rows[j] = Some(row);
                }
            });
        if let Some(e) = write_error {
            pb.finish_and_clear();
            return Err(SwarmError::Internal(e.context("writing tune.csv")));
        }
        let complete = rows.iter().all(Option::is_some);
        if interrupted || !complete {
            pb.finish_and_clear();
            let finished = done.len() + rows.iter().flatten().count();
            if t > 0 {
                write_outputs(&tune, &out_dir, &pso, &history, &done, false)?;
            }
            println!("{}", out.display());
            if interrupted {
                return Err(SwarmError::Interrupted(format!(
                    "tune interrupted: {finished} of {total} evaluations finished; resume with: {command}"
                )));
            }
            return Err(SwarmError::Internal(anyhow::anyhow!(
                "{stopped_from_outside} runs were stopped by a signal from outside the tune and \
                 are not in tune.csv; the same command runs them again: {command}"
            )));
        }
        let rows: Vec<EvalRow> = rows.into_iter().flatten().collect();
        let fitness: Vec<f64> = rows.iter().map(|r| tune.internal(r)).collect();
        pso.tell(&fitness);
        let (_, best) = pso.best().expect("told once");
        history.best_params.push(
            tune.params
                .iter()
                .zip(&best.position)
                .map(|(p, &x)| p.normalise(x))
                .collect(),
        );
        history
            .best_fitness
            .push(tune.external(best.mean()).unwrap_or(f64::NAN));
        let new: Vec<f64> = rows
            .iter()
            .filter(|r| r.kind == Kind::New && r.status == Status::Ok)
            .filter_map(|r| r.fitness)
            .collect();
        history.mean_fitness.push(if new.is_empty() {
            f64::NAN
        } else {
            new.iter().sum::<f64>() / new.len() as f64
        });
        done.extend(rows);
        // Canonical order on disk; rows a longer tune left beyond this one are kept.
        let next = (t + 1) * e;
        csv.rewrite(done.iter().chain(cache.range(next..).map(|(_, r)| r)))?;
        // A replayed iteration changes nothing on disk but the last one's outputs.
        if !jobs.is_empty() || t + 1 == args.iterations {
            write_outputs(
                &tune,
                &out_dir,
                &pso,
                &history,
                &done,
                t + 1 == args.iterations,
            )?;
        }
    }
    pb.finish_and_clear();
    println!("{}", out.display());
    if let Some((_, best)) = pso.best() {
        let params: Vec<String> = tune
            .params
            .iter()
            .zip(&best.position)
            .map(|(p, &x)| p.set(x))
            .collect();
        eprintln!(
            "best: {} ({} {} over {} evaluations)",
            params.join(" "),
            tune.settings.fitness,
            tune.external(best.mean())
                .map_or("none: every evaluation failed".into(), |f| f.to_string()),
            best.count
        );
    }
    if !warnings.is_empty() {
        eprintln!(
            "warning: {} evaluations failed or lacked `{}` and counted as the worst fitness (status in tune.csv); first: {}",
            warnings.len(),
            tune.settings.fitness,
            warnings[0]
        );
    }
    Ok(())
}

/// Checks everything before anything runs or is written (exit 2 naming the flag or key).
fn check(args: &TuneArgs) -> SwarmResult<Tune<'_>> {
    let evaluations = args.evaluations.unwrap_or(2 * args.particles);
    let opts = Options {
        particles: args.particles as usize,
        evaluations: evaluations as usize,
        inertia: args.inertia,
        c1: args.c1,
        c2: args.c2,
        vmax: args.vmax,
    };
    opts.reevaluations().map_err(SwarmError::User)?;
    let base = load_config(&args.config, &args.pool.set)?;
    let params = space::resolve(&args.param, &args.config, &args.pool.set, &base)
        .map_err(SwarmError::User)?;
    check_fitness(&args.fitness, &base)?;
    let seeds = match args.seeds {
        None => None,
        Some(n) => {
            let start = args.start_seed.unwrap_or(base.scenario.seed);
            let last = start.checked_add(n - 1).filter(|&l| l <= i64::MAX as u64);
            if last.is_none() {
                return Err(SwarmError::User(format!(
                    "--start-seed {start} --seeds {n}: seeds past {}",
                    i64::MAX
                )));
            }
            Some((start..start + n).collect())
        }
    };
    let settings = Settings {
        params: params.clone(),
        fitness: args.fitness.clone(),
        maximize: args.maximize,
        particles: args.particles,
        evaluations,
        inertia: args.inertia,
        c1: args.c1,
        c2: args.c2,
        vmax: args.vmax,
        seed: args.seed,
        seeds,
        base_config: base.to_toml(),
    };
    let out = match args.out.clone() {
        Some(out) => out,
        None => run_dir::unused_dir(
            Path::new("runs"),
            &format!("tune-{}-{}", base.scenario.name, run_dir::timestamp()),
        )?
        .path()
        .to_path_buf(),
    };
    Ok(Tune {
        args,
        params,
        settings,
        out,
        scenario: base.scenario.name,
    })
}

/// Refuses a `--fitness` no run of this scenario reports: its full path or its first segment
/// (a behaviour's metrics may be an object) must be a known metric.
fn check_fitness(name: &str, cfg: &Config) -> SwarmResult<()> {
    let known = known_metrics(cfg);
    let first = name.split('.').next().unwrap_or(name);
    if known.contains(name) || known.contains(first) {
        return Ok(());
    }
    Err(SwarmError::User(format!(
        "--fitness `{name}`: not a metric of this scenario; known: {}",
        known.into_iter().collect::<Vec<_>>().join(", ")
    )))
}

/// `--out` must be new, empty, or a tune directory made with the same settings; returns the
/// rows its `tune.csv` holds.
fn open_out(out: &Path, tune: &Tune) -> SwarmResult<BTreeMap<u64, EvalRow>> {
    let Ok(mut entries) = std::fs::read_dir(out) else {
        if out.exists() {
            return Err(SwarmError::User(format!(
                "--out {}: not a directory",
                out.display()
            )));
        }
        return Ok(BTreeMap::new());
    };
    let json_path = out.join("tune.json");
    if !json_path.exists() {
        if entries.next().is_none() {
            return Ok(BTreeMap::new());
        }
        return Err(SwarmError::User(format!(
            "--out {}: exists and is not a tune directory (no tune.json); give a new or empty directory",
            out.display()
        )));
    }
    let then: Option<Settings> = std::fs::read_to_string(&json_path)
        .ok()
        .and_then(|t| serde_json::from_str::<serde_json::Value>(&t).ok())
        .and_then(|v| serde_json::from_value(v["settings"].clone()).ok());
    let Some(then) = then else {
        return Err(SwarmError::User(format!(
            "{}: unreadable settings; give another --out",
            json_path.display()
        )));
    };
    // Compare through the same JSON text both ways: serde_json's float parsing need not give
    // back the very bits it printed, but it gives the same bits for the same text.
    let now: Settings = serde_json::to_string(&tune.settings)
        .ok()
        .and_then(|t| serde_json::from_str(&t).ok())
        .unwrap_or_else(|| tune.settings.clone());
    if let Some(why) = now.difference(&then) {
        return Err(SwarmError::User(format!(
            "--out {}: a tune with other settings ({why}); give another --out, or the same \
             command as before (only --iterations, --jobs and --in-process may change)",
            out.display()
        )));
    }
    let csv = out.join("tune.csv");
    if !csv.exists() {
        return Ok(BTreeMap::new());
    }
    record::read(&csv, &tune.params).map_err(SwarmError::User)
}

/// `tune.json`: the settings, how far the tune got and its best personal best.
fn summary(tune: &Tune, pso: Option<&Pso>, done: &[EvalRow], complete: bool) -> serde_json::Value {
    let best = pso.and_then(Pso::best).map(|(i, b)| {
        let params: serde_json::Map<String, serde_json::Value> = tune
            .params
            .iter()
            .zip(&b.position)
            .map(|(p, &x)| {
                let v = p.value(x);
                let num = match v.parse::<i64>() {
                    Ok(i) if p.integer => i.into(),
                    _ => v.parse::<f64>().map_or(v.clone().into(), Into::into),
                };
                (p.key.clone(), num)
            })
            .collect();
        json!({
            "particle": i,
            "params": params,
            "fitness": tune.external(b.mean()),
            "evaluations": b.count,
        })
    });
    let count = |s: Status| done.iter().filter(|r| r.status == s).count();
    json!({
        "scenario": tune.scenario,
        "config": tune.args.config.display().to_string(),
        "settings": tune.settings,
        "iterations": tune.args.iterations,
        "iterations_done": pso.map_or(0, Pso::iteration),
        "evaluations_done": done.len(),
        "failed_evaluations": count(Status::Failed),
        "missing_evaluations": count(Status::Missing),
        "complete": complete,
        "mode": mode(tune.args.pool.in_process),
        "best": best,
    })
}

/// `best.toml`, `tune.json` and the plots, after an iteration.
fn write_outputs(
    tune: &Tune,
    out: &OutDir,
    pso: &Pso,
    history: &History,
    done: &[EvalRow],
    complete: bool,
) -> SwarmResult<()> {
    if let Some((_, best)) = pso.best() {
        let cfg = load_config(&tune.args.config, &tune.overrides(&best.position))?;
        let head = format!(
            "# swarm tune: the best parameters after {} iterations ({} {} over {} evaluations)\n",
            pso.iteration(),
            tune.settings.fitness,
            tune.external(best.mean())
                .map_or("none".into(), |f| f.to_string()),
            best.count
        );
        write_atomic(out, "best.toml", &(head + &cfg.to_toml()))?;
    }
    let s = summary(tune, Some(pso), done, complete);
    write_atomic(
        out,
        "tune.json",
        &(serde_json::to_string_pretty(&s).map_err(anyhow::Error::from)? + "\n"),
    )?;
    write_tune_plots(out, history)
        .map_err(|e| SwarmError::Internal(e.context("drawing the tune plots")))?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::Parser;

    fn tune_of<'a>(args: &'a TuneArgs, seeds: Option<Vec<u64>>) -> Tune<'a> {
        Tune {
            args,
            params: Vec::new(),
            settings: Settings {
                params: Vec::new(),
                fitness: args.fitness.clone(),
                maximize: args.maximize,
                particles: 2,
                evaluations: 4,
                inertia: 0.729,
                c1: 1.494,
                c2: 1.494,
                vmax: 1.0,
                seed: args.seed,
                seeds,
                base_config: String::new(),
            },
            out: PathBuf::from("unused"),
            scenario: "s".into(),
        }
    }

    fn args(extra: &[&str]) -> TuneArgs {
        let mut argv = vec!["tune", "c.toml", "--param", "a.b=0:1", "--fitness", "m"];
        argv.extend(extra);
        TuneArgs::try_parse_from(argv).unwrap()
    }

    fn row(status: Status, fitness: Option<f64>) -> EvalRow {
        EvalRow {
            eval: 0,
            iteration: 0,
            particle: 0,
            kind: Kind::New,
            values: Vec::new(),
            seed: 0,
            fitness,
            status,
        }
    }

    #[test]
    fn maximising_negates_and_failures_are_the_worst_either_way() {
        for (extra, sign) in [(&[][..], 1.0), (&["--maximize"][..], -1.0)] {
            let a = args(extra);
            let t = tune_of(&a, None);
            assert_eq!(t.internal(&row(Status::Ok, Some(3.0))), 3.0 * sign);
            assert_eq!(
                t.external(t.internal(&row(Status::Ok, Some(3.0)))),
                Some(3.0)
            );
            assert_eq!(t.internal(&row(Status::Missing, None)), f64::INFINITY);
            assert_eq!(t.internal(&row(Status::Failed, None)), f64::INFINITY);
            assert_eq!(t.external(f64::INFINITY), None);
        }
    }

    #[test]
    fn run_seeds_come_from_the_seed_or_cycle_through_the_list() {
        let a = args(&["--seed", "3"]);
        let derived = tune_of(&a, None);
        let seeds: Vec<u64> = (0..50).map(|k| derived.run_seed(k)).collect();
        assert_eq!(
            seeds,
            (0..50).map(|k| derived.run_seed(k)).collect::<Vec<_>>()
        );
        let distinct: std::collections::BTreeSet<_> = seeds.iter().collect();
        assert_eq!(distinct.len(), 50);
        assert!(seeds.iter().all(|&s| s <= u32::MAX as u64));
        let b = args(&["--seed", "4"]);
        assert_ne!(tune_of(&b, None).run_seed(0), seeds[0]);

        let listed = tune_of(&a, Some(vec![10, 11, 12]));
        let cycle: Vec<u64> = (0..7).map(|k| listed.run_seed(k)).collect();
        assert_eq!(cycle, [10, 11, 12, 10, 11, 12, 10]);
    }
}
