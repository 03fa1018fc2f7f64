//! Where a sweep's or a tune's runs are made: on this machine or on hosts reached by ssh
//! ([`super::runner`]'s pool), or as Slurm job arrays ([`super::slurm`]). Resolved once from the command line and an optional
//! `[executor]` file, the command line winning, so every later step sees one plain value.

use std::path::Path;
use std::time::Duration;

use serde::Deserialize;

use crate::cli::{ExecutorKind, PoolArgs};
use crate::error::{SwarmError, SwarmResult};
use crate::sweep::runner::PoolHost;

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
    /// Child `swarm run`s on the hosts of a hosts file, through their launchers.
    Ssh(Vec<PoolHost>),
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
    /// The ssh executor's hosts file, relative to the executor file.
    hosts: Option<std::path::PathBuf>,
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
    let mut file = match &pool.executor_config {
        Some(path) => read_section(path)?,
        None => ExecutorSection::default(),
    };
    if let (Some(h), Some(cfg)) = (&mut file.hosts, &pool.executor_config) {
        *h = cfg.parent().unwrap_or(Path::new(".")).join(&*h);
    }
    let hosts_file = pool.hosts.clone().or(file.hosts.take());
    let kind = pool.executor.or(file.kind).unwrap_or(ExecutorKind::Local);
    let jobs = pool.jobs.or(file.jobs);
    if hosts_file.is_some() && kind != ExecutorKind::Ssh {
        return Err(SwarmError::User(
            "--hosts names the hosts of the ssh executor; add --executor ssh".into(),
        ));
    }
    match kind {
        ExecutorKind::Ssh => {
            let Some(path) = &hosts_file else {
                return Err(SwarmError::User(
                    "--executor ssh needs --hosts <hosts.toml> (its [[host]] names and launchers)"
                        .into(),
                ));
            };
            let jobs = jobs.unwrap_or(1);
            if jobs > MAX_LOCAL_JOBS {
                return Err(SwarmError::User(format!(
                    "--jobs {jobs}: at most {MAX_LOCAL_JOBS} runs at once per host"
                )));
            }
            Ok(Executor::Ssh(read_hosts(path, jobs as usize)?))
        }
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

/// A `[[host]]` of a hosts file as the ssh executor reads it: the keys of `swarm run --hosts`
/// are accepted (the same file serves both), `jobs` and `swarm` are the executor's.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct SweepHost {
    name: String,
    launcher: Vec<String>,
    jobs: Option<u64>,
    swarm: Option<std::path::PathBuf>,
    #[allow(dead_code)]
    robots: Option<toml::Value>,
    #[allow(dead_code)]
    connect: Option<String>,
    #[allow(dead_code)]
    program: Option<std::path::PathBuf>,
    #[allow(dead_code)]
    certs: Option<std::path::PathBuf>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct SweepHosts {
    #[allow(dead_code)]
    world: Option<toml::Value>,
    #[serde(default)]
    host: Vec<SweepHost>,
}

/// The hosts of `--executor ssh`, `jobs` runs at once on each unless its `jobs` says otherwise.
fn read_hosts(path: &Path, jobs: usize) -> SwarmResult<Vec<PoolHost>> {
    let name = path.display();
    let text = std::fs::read_to_string(path)
        .map_err(|e| SwarmError::User(format!("--hosts {name}: cannot read: {e}")))?;
    let value: toml::Value = toml::from_str(&text).map_err(|e| {
        SwarmError::User(format!(
            "{name}: not valid TOML: {}",
            e.message().replace('\n', " ")
        ))
    })?;
    let file: SweepHosts = serde_path_to_error::deserialize(value).map_err(|e| {
        SwarmError::User(format!(
            "{name}: key `{}`: {}",
            e.path(),
            e.inner().to_string().replace('\n', " ")
        ))
    })?;
    if file.host.is_empty() {
        return Err(SwarmError::User(format!(
            "{name}: no [[host]]; the ssh executor needs at least one"
        )));
    }
    let mut hosts = Vec::new();
    for (i, h) in file.host.into_iter().enumerate() {
        let ok_name = !h.name.is_empty()
            && h.name.len() <= 32
            && h.name
                .bytes()
                .all(|b| b.is_ascii_lowercase() || b.is_ascii_digit() || b == b'-');
        if !ok_name {
            return Err(SwarmError::User(format!(
                "{name}: key `host[{i}].name`: {:?} is not 1-32 of a-z 0-9 -",
                h.name
            )));
        }
        if hosts.iter().any(|p: &PoolHost| p.name == h.name) {
            return Err(SwarmError::User(format!(
                "{name}: key `host[{i}].name`: {:?} is given twice",
                h.name
            )));
        }
        if h.launcher.is_empty() || h.launcher[0].is_empty() {
            return Err(SwarmError::User(format!(
                "{name}: key `host[{i}].launcher`: expected a command, e.g. [\"ssh\", \"{}\"]",
                h.name
            )));
        }
        let slots = h.jobs.unwrap_or(jobs as u64);
        if !(1..=MAX_LOCAL_JOBS).contains(&slots) {
            return Err(SwarmError::User(format!(
                "{name}: key `host[{i}].jobs`: {slots} is out of range; expected 1 to {MAX_LOCAL_JOBS}"
            )));
        }
        hosts.push(PoolHost {
            name: h.name,
            launcher: h.launcher,
            slots: slots as usize,
            swarm: h.swarm,
        });
    }
    Ok(hosts)
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
            Executor::Ssh(hosts) => format!(
                "on {} hosts ({})",
                hosts.len(),
                hosts
                    .iter()
                    .map(|h| format!("{} x{}", h.name, h.slots))
                    .collect::<Vec<_>>()
                    .join(", ")
            ),
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
    fn hosts_files_of_swarm_run_serve_the_ssh_executor() {
        let dir = tempfile::tempdir().unwrap();
        let f = dir.path().join("hosts.toml");
        std::fs::write(
            &f,
            "[world]\nlisten = \"quic/10.0.0.1:7447\"\n[[host]]\nname = \"a\"\nlauncher = [\"ssh\", \"a\"]\nrobots = 4\n[[host]]\nname = \"b\"\nlauncher = [\"ssh\", \"b\"]\njobs = 3\nswarm = \"/opt/swarm\"\n",
        )
        .unwrap();
        let fs = f.to_str().unwrap();
        let e = resolve(&pool(&["--executor", "ssh", "--hosts", fs, "--jobs", "2"])).unwrap();
        let Executor::Ssh(h) = e else { panic!("{e:?}") };
        assert_eq!(h.len(), 2);
        assert_eq!((h[0].name.as_str(), h[0].slots), ("a", 2));
        assert_eq!(h[0].launcher, ["ssh", "a"]);
        assert_eq!((h[1].name.as_str(), h[1].slots), ("b", 3));
        assert_eq!(h[1].swarm.as_deref(), Some(Path::new("/opt/swarm")));
        // The same hosts from an executor file, found beside it.
        let cluster = dir.path().join("cluster.toml");
        std::fs::write(
            &cluster,
            "[executor]\nkind = \"ssh\"\nhosts = \"hosts.toml\"\njobs = 2\n",
        )
        .unwrap();
        let from_file = resolve(&pool(&["--executor-config", cluster.to_str().unwrap()])).unwrap();
        assert_eq!(from_file, Executor::Ssh(h.clone()));
        let e = resolve(&pool(&["--executor", "ssh"]))
            .unwrap_err()
            .to_string();
        assert!(e.contains("needs --hosts"), "{e}");
        let e = resolve(&pool(&["--hosts", fs])).unwrap_err().to_string();
        assert!(e.contains("add --executor ssh"), "{e}");
        std::fs::write(&f, "[[host]]\nname = \"a\"\nlauncher = []\n").unwrap();
        let e = resolve(&pool(&["--executor", "ssh", "--hosts", fs]))
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("key `host[0].launcher`: expected a command"),
            "{e}"
        );
        std::fs::write(
            &f,
            "[[host]]\nname = \"a\"\nlauncher = [\"ssh\"]\njbos = 2\n",
        )
        .unwrap();
        let e = resolve(&pool(&["--executor", "ssh", "--hosts", fs]))
            .unwrap_err()
            .to_string();
        assert!(e.contains("key `host[0].jbos`: unknown field"), "{e}");
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
