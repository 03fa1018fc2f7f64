//! Where a sweep's or a tune's runs are made: on this machine ([`super::runner`]'s pool) or as
//! Slurm job arrays ([`super::slurm`]). Resolved once from the command line and an optional
//! `[executor]` file, the command line winning, so every later step sees one plain value.

use std::path::Path;
use std::time::Duration;

use serde::Deserialize;

use crate::cli::{ExecutorKind, PoolArgs};
use crate::error::{SwarmError, SwarmResult};

/// Most local runs at once: each is a thread of the pool and a child process.
pub const MAX_LOCAL_JOBS: u64 = 256;

/// Most runs one Slurm task makes.
pub const MAX_RUNS_PER_TASK: u64 = 10_000;

/// Where the runs go.
#[derive(Debug, Clone, PartialEq)]
pub enum Executor {
    /// Child `swarm run`s on this machine, `jobs` at a time.
    Local {
        /// Runs at once.
        jobs: usize,
    },
    /// Job arrays on a Slurm cluster.
    Slurm(SlurmOptions),
}

/// How runs are submitted to Slurm.
#[derive(Debug, Clone, PartialEq)]
pub struct SlurmOptions {
    /// `sbatch --partition`.
    pub partition: Option<String>,
    /// `sbatch --time`.
    pub time: Option<String>,
    /// `sbatch --mem`.
    pub mem: Option<String>,
    /// Further `sbatch` arguments, passed as given.
    pub sbatch_args: Vec<String>,
    /// Tasks of one array running at once (`--array=0-N%jobs`); `None`: the cluster decides.
    pub jobs: Option<u64>,
    /// Runs one task makes, one after the other: Slurm's cost of starting a task (about 0.6 s
    /// on a one-node cluster, docs/cluster.md) is paid once for them.
    pub runs_per_task: usize,
    /// How often the queue is asked how the tasks are doing.
    pub poll: Duration,
}

/// The `[executor]` section of an `--executor-config` file.
#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
struct ExecutorSection {
    kind: Option<ExecutorKind>,
    partition: Option<String>,
    time: Option<String>,
    mem: Option<String>,
    #[serde(default)]
    sbatch_args: Vec<String>,
    jobs: Option<u64>,
    runs_per_task: Option<u64>,
    poll_seconds: Option<f64>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct ExecutorFile {
    executor: ExecutorSection,
}

/// Default time between two looks at the queue: a run of a sweep takes seconds to hours, so
/// a second's delay in noticing its end costs nothing, and `squeue` stays cheap for the
/// controller.
const DEFAULT_POLL: f64 = 1.0;

/// The executor the command line and its `--executor-config` file ask for.
pub fn resolve(pool: &PoolArgs) -> SwarmResult<Executor> {
    let file = match &pool.executor_config {
        Some(path) => read_section(path)?,
        None => ExecutorSection::default(),
    };
    let kind = pool.executor.or(file.kind).unwrap_or(ExecutorKind::Local);
    let jobs = pool.jobs.or(file.jobs);
    match kind {
        ExecutorKind::Local => {
            let slurm_flag = [
                ("--partition", pool.partition.is_some()),
                ("--time", pool.time.is_some()),
                ("--mem", pool.mem.is_some()),
                ("--sbatch-arg", !pool.sbatch_args.is_empty()),
                ("--runs-per-task", pool.runs_per_task.is_some()),
            ]
            .into_iter()
            .find(|(_, given)| *given);
            if let Some((flag, _)) = slurm_flag {
                return Err(SwarmError::User(format!(
                    "{flag} is a Slurm option; add --executor slurm"
                )));
            }
            let jobs = jobs.unwrap_or(1);
            if jobs > MAX_LOCAL_JOBS {
                return Err(SwarmError::User(format!(
                    "--jobs {jobs}: at most {MAX_LOCAL_JOBS} runs at once on this machine"
                )));
            }
            Ok(Executor::Local {
                jobs: jobs as usize,
            })
        }
        ExecutorKind::Slurm => {
            let poll = file.poll_seconds.unwrap_or(DEFAULT_POLL);
            if !(0.05..=600.0).contains(&poll) {
                return Err(SwarmError::User(format!(
                    "{}: key `executor.poll_seconds`: {poll} is out of range; expected 0.05 to 600",
                    pool.executor_config
                        .as_deref()
                        .map_or("--executor-config".into(), |p| p.display().to_string())
                )));
            }
            let per_task = pool.runs_per_task.or(file.runs_per_task).unwrap_or(1);
            if !(1..=MAX_RUNS_PER_TASK).contains(&per_task) {
                return Err(SwarmError::User(format!(
                    "runs per task {per_task} is out of range; expected 1 to {MAX_RUNS_PER_TASK}"
                )));
            }
            let mut sbatch_args = file.sbatch_args;
            sbatch_args.extend(pool.sbatch_args.iter().cloned());
            Ok(Executor::Slurm(SlurmOptions {
                partition: pool.partition.clone().or(file.partition),
                time: pool.time.clone().or(file.time),
                mem: pool.mem.clone().or(file.mem),
                sbatch_args,
                jobs,
                runs_per_task: per_task as usize,
                poll: Duration::from_secs_f64(poll),
            }))
        }
    }
}

/// Reads and checks an `--executor-config` file; a typo names the file and the key.
fn read_section(path: &Path) -> SwarmResult<ExecutorSection> {
    let name = path.display();
    let text = std::fs::read_to_string(path)
        .map_err(|e| SwarmError::User(format!("--executor-config {name}: cannot read: {e}")))?;
    let value: toml::Value = toml::from_str(&text).map_err(|e| {
        SwarmError::User(format!(
            "{name}: not valid TOML: {}",
            e.message().replace('\n', " ")
        ))
    })?;
    let file: ExecutorFile = serde_path_to_error::deserialize(value).map_err(|e| {
        let key = e.path().to_string();
        let msg = e.inner().to_string().replace('\n', " ");
        if key == "." || key.is_empty() {
            SwarmError::User(format!("{name}: {msg}"))
        } else {
            SwarmError::User(format!("{name}: key `{key}`: {msg}"))
        }
    })?;
    if let Some(0) = file.executor.jobs {
        return Err(SwarmError::User(format!(
            "{name}: key `executor.jobs`: 0 is out of range; expected at least 1"
        )));
    }
    Ok(file.executor)
}

impl Executor {
    /// Says how the runs are made, for the progress line.
    pub fn describe(&self, runs: usize) -> String {
        match self {
            Executor::Local { jobs } => format!("{} at a time", (*jobs).min(runs.max(1))),
            Executor::Slurm(s) => {
                let mut d = String::from("as a Slurm job array");
                if s.runs_per_task > 1 {
                    d.push_str(&format!(", {} runs per task", s.runs_per_task));
                }
                if let Some(j) = s.jobs {
                    d.push_str(&format!(", {j} tasks at a time"));
                }
                d
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::Parser;

    #[derive(Parser)]
    struct P {
        #[command(flatten)]
        pool: PoolArgs,
    }

    fn pool(args: &[&str]) -> PoolArgs {
        P::parse_from(std::iter::once("x").chain(args.iter().copied())).pool
    }

    #[test]
    fn command_line_wins_over_the_file_and_local_is_the_default() {
        assert_eq!(resolve(&pool(&[])).unwrap(), Executor::Local { jobs: 1 });
        let dir = tempfile::tempdir().unwrap();
        let f = dir.path().join("cluster.toml");
        std::fs::write(
            &f,
            "[executor]\nkind = \"slurm\"\npartition = \"a\"\ntime = \"1:00\"\nsbatch_args = [\"--qos=x\"]\njobs = 4\nruns_per_task = 5\n",
        )
        .unwrap();
        let fs = f.to_str().unwrap();
        let e = resolve(&pool(&[
            "--executor-config",
            fs,
            "--partition",
            "b",
            "--sbatch-arg=--exclusive",
        ]))
        .unwrap();
        let Executor::Slurm(s) = e else {
            panic!("{e:?}")
        };
        assert_eq!(s.partition.as_deref(), Some("b"));
        assert_eq!(s.time.as_deref(), Some("1:00"));
        assert_eq!(s.sbatch_args, ["--qos=x", "--exclusive"]);
        assert_eq!(s.jobs, Some(4));
        assert_eq!(s.runs_per_task, 5);
        // The command line's executor wins over the file's kind.
        assert_eq!(
            resolve(&pool(&["--executor-config", fs, "--executor", "local"])).unwrap(),
            Executor::Local { jobs: 4 }
        );
    }

    #[test]
    fn mistakes_are_named() {
        let e = resolve(&pool(&["--partition", "x"]))
            .unwrap_err()
            .to_string();
        assert_eq!(e, "--partition is a Slurm option; add --executor slurm");
        let e = resolve(&pool(&["--jobs", "300"])).unwrap_err().to_string();
        assert!(e.contains("at most 256"), "{e}");
        let dir = tempfile::tempdir().unwrap();
        let f = dir.path().join("cluster.toml");
        std::fs::write(&f, "[executor]\nkind = \"slurm\"\npartiton = \"a\"\n").unwrap();
        let e = resolve(&pool(&["--executor-config", f.to_str().unwrap()]))
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("cluster.toml: key `executor.partiton`: unknown field"),
            "{e}"
        );
        std::fs::write(&f, "[executor]\nkind = \"pbs\"\n").unwrap();
        let e = resolve(&pool(&["--executor-config", f.to_str().unwrap()]))
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("key `executor.kind`: unknown variant `pbs`"),
            "{e}"
        );
        std::fs::write(&f, "[executor]\nkind = \"slurm\"\npoll_seconds = 0\n").unwrap();
        let e = resolve(&pool(&["--executor-config", f.to_str().unwrap()]))
            .unwrap_err()
            .to_string();
        assert!(e.contains("expected 0.05 to 600"), "{e}");
        let e = resolve(&pool(&["--executor", "slurm", "--runs-per-task", "0"]))
            .unwrap_err()
            .to_string();
        assert!(e.contains("expected 1 to 10000"), "{e}");
    }
}
