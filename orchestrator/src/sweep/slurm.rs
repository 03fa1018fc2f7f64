//! Runs a sweep's (or a tune iteration's) jobs as Slurm job arrays: one `sbatch --array`
//! per batch of at most [`MAX_ARRAY`] tasks, each task ordinary `swarm run`s of one or more
//! (`runs_per_task`) prepared run directories, one after the other, on a filesystem the
//! nodes share.
//!
//! Why files rather than Slurm's accounting: a task writes each run's exit code next to its
//! log when its `swarm run` ends, so a finished run is known from the shared filesystem alone,
//! on clusters with or without `sacct`. The queue (`squeue --states=all`) is asked only to tell
//! a task still waiting or running from one that ended without writing (cancelled, timed out,
//! its node lost). Every array keeps its own directory under `<out>/slurm/array-<n>/`:
//! `runs.txt` (the run directories, run `i` on line `i + 1`), `per_task`, `run.sh`, `job_id`,
//! a `<i>.log` and a `<i>.exit` per run, a `task-<t>.log` per task, and `collected` once each
//! of its runs was reported.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::{Command, ExitStatus, Stdio};
use std::time::{Duration, Instant};

use crossbeam_channel::Receiver;

use super::executor::SlurmOptions;
use super::runner::{self, Event, Job, Outcome, PoolOptions};

/// Most tasks in one array: Slurm's default `MaxArraySize` is 1001 (task ids 0-1000).
pub const MAX_ARRAY: usize = 1000;

/// Where a sweep directory keeps its arrays.
pub const SLURM_DIR: &str = "slurm";

/// States of a task that has not ended yet (squeue's `%T`); any other state is an end.
const ACTIVE: [&str; 13] = [
    "PENDING",
    "RUNNING",
    "CONFIGURING",
    "COMPLETING",
    "SUSPENDED",
    "REQUEUED",
    "REQUEUE_HOLD",
    "REQUEUE_FED",
    "RESIZING",
    "SIGNALING",
    "STAGE_OUT",
    "STOPPED",
    "RESV_DEL_HOLD",
];

/// One submitted array: its job id, its directory and its run directories.
#[derive(Debug, Clone)]
pub struct Array {
    /// Slurm's job id of the array.
    pub job_id: String,
    /// `<out>/slurm/array-<n>/`.
    pub dir: PathBuf,
    /// Task `t` runs `runs[t * per_task ..][..per_task]`, in order.
    pub runs: Vec<PathBuf>,
    /// Runs per task (at least 1).
    pub per_task: usize,
}

/// Runs `jobs` through Slurm and hands every [`Event`] to `on_event`; on Ctrl-C cancels the
/// arrays (`scancel`) and keeps what finished. Returns whether it was interrupted.
pub fn run_all(
    jobs: &[Job],
    opts: &PoolOptions,
    slurm: &SlurmOptions,
    interrupt: Receiver<()>,
    mut on_event: impl FnMut(Event),
) -> bool {
    let (arrays, index) = prepare_and_submit(jobs, opts, slurm, &mut on_event);
    let mut wait_events = |ev: Event| match ev {
        Event::Finished(k, outcome) => on_event(Event::Finished(index[k], outcome)),
        ev => on_event(ev),
    };
    wait(&arrays, slurm.poll, true, &interrupt, &mut wait_events)
}

/// Prepares every job's directory and submits them; a job that cannot be prepared or
/// submitted is reported as failed at once. Returns the arrays and, for each of their runs in
/// order, its index in `jobs`.
pub fn prepare_and_submit(
    jobs: &[Job],
    opts: &PoolOptions,
    slurm: &SlurmOptions,
    on_event: &mut impl FnMut(Event),
) -> (Vec<Array>, Vec<usize>) {
    let mut ready: Vec<usize> = Vec::with_capacity(jobs.len());
    for (i, job) in jobs.iter().enumerate() {
        match runner::prepare(&job.dir, &job.config_toml) {
            Ok(()) => ready.push(i),
            Err(e) => on_event(Event::Finished(
                i,
                Outcome::Failed {
                    metrics: None,
                    reason: format!("cannot prepare {}: {e:#}", job.dir.display()),
                },
            )),
        }
    }
    let mut arrays = Vec::new();
    let mut index = Vec::new();
    let per_task = slurm.runs_per_task.max(1);
    for chunk in ready.chunks(MAX_ARRAY * per_task) {
        let runs: Vec<PathBuf> = chunk.iter().map(|&i| absolute(&jobs[i].dir)).collect();
        match submit(&runs, per_task, opts, slurm) {
            Ok(array) => {
                arrays.push(array);
                index.extend_from_slice(chunk);
            }
            Err(reason) => {
                for &i in chunk {
                    on_event(Event::Finished(
                        i,
                        Outcome::Failed {
                            metrics: None,
                            reason: reason.clone(),
                        },
                    ));
                }
            }
        }
    }
    (arrays, index)
}

/// Writes one array's directory and submits it with `sbatch`.
fn submit(
    runs: &[PathBuf],
    per_task: usize,
    opts: &PoolOptions,
    slurm: &SlurmOptions,
) -> Result<Array, String> {
    let root = absolute(&opts.state_dir.join(SLURM_DIR));
    let dir = new_array_dir(&root).map_err(|e| format!("cannot create {}: {e}", root.display()))?;
    let mut list = String::new();
    for r in runs {
        let text = r.to_str().filter(|t| !t.contains('\n')).ok_or_else(|| {
            format!(
                "run directory {} is not a one-line UTF-8 path; Slurm tasks cannot name it",
                r.display()
            )
        })?;
        list.push_str(text);
        list.push('\n');
    }
    let write = |name: &str, text: &str| {
        swarmrt_scenario::safe_fs::write_nofollow(&dir.join(name), text)
            .map_err(|e| format!("cannot write {}: {e}", dir.join(name).display()))
    };
    write("runs.txt", &list)?;
    write("per_task", &format!("{per_task}\n"))?;
    write(
        "run.sh",
        &task_script(&dir, &opts.swarm, opts.in_process, per_task),
    )?;

    let mut array = format!("--array=0-{}", runs.len().div_ceil(per_task) - 1);
    if let Some(j) = slurm.jobs {
        array.push_str(&format!("%{j}"));
    }
    let mut cmd = Command::new("sbatch");
    cmd.arg("--parsable")
        .arg(array)
        .arg("--job-name=swarm")
        .arg(format!("--output={}/task-%a.log", dir.display()))
        .arg(format!(
            "--chdir={}",
            std::env::current_dir()
                .map_err(|e| format!("no current directory: {e}"))?
                .display()
        ));
    for (flag, value) in [
        ("--partition", &slurm.partition),
        ("--time", &slurm.time),
        ("--mem", &slurm.mem),
    ] {
        if let Some(v) = value {
            cmd.arg(format!("{flag}={v}"));
        }
    }
    cmd.args(&slurm.sbatch_args)
        .arg(dir.join("run.sh"))
        .stdin(Stdio::null());
    let out = cmd.output().map_err(|e| {
        if e.kind() == std::io::ErrorKind::NotFound {
            "cannot submit to Slurm: `sbatch` is not on PATH (is this a Slurm submit host?)"
                .to_string()
        } else {
            format!("cannot run sbatch: {e}")
        }
    })?;
    if !out.status.success() {
        let said = String::from_utf8_lossy(&out.stderr);
        let said = said
            .lines()
            .rev()
            .find(|l| !l.trim().is_empty())
            .unwrap_or("");
        return Err(format!(
            "sbatch refused the array ({}): {}",
            describe(out.status),
            said.trim()
        ));
    }
    let stdout = String::from_utf8_lossy(&out.stdout);
    // `--parsable` prints `<job id>` or `<job id>;<cluster>`.
    let job_id = stdout
        .trim()
        .split(';')
        .next()
        .filter(|id| !id.is_empty() && id.bytes().all(|b| b.is_ascii_digit()))
        .ok_or_else(|| format!("sbatch printed no job id: `{}`", stdout.trim()))?
        .to_string();
    write("job_id", &format!("{job_id}\n"))?;
    tracing::info!(job_id, runs = runs.len(), dir = %dir.display(), "submitted a Slurm array");
    Ok(Array {
        job_id,
        dir,
        runs: runs.to_vec(),
        per_task,
    })
}

/// The task's shell: its runs one after the other with `swarm run`, each run's exit code
/// recorded as it ends (written aside and renamed, so a reader never sees half a number). A
/// run goes to the background and the shell waits, forwarding Slurm's SIGTERM (scancel, a time
/// limit) and starting no further run: were the shell killed first, the run would leave the
/// task's process tree and outlive the task.
fn task_script(dir: &Path, swarm: &Path, in_process: bool, per_task: usize) -> String {
    let q = |p: &Path| shell_word(&p.display().to_string());
    format!(
        "#!/bin/sh\n\
         # swarmrt: {per_task} run(s) of a sweep per task of this array (orchestrator/src/sweep/slurm.rs).\n\
         t=\"${{SLURM_ARRAY_TASK_ID:?not a task of a job array}}\"\n\
         stop=\n\
         pid=\n\
         trap 'stop=1; [ -n \"$pid\" ] && kill -TERM \"$pid\" 2>/dev/null' TERM INT\n\
         i=$((t * {per_task}))\n\
         end=$((i + {per_task}))\n\
         while [ \"$i\" -lt \"$end\" ] && [ -z \"$stop\" ]; do\n\
         \x20 run=$(sed -n \"$((i + 1))p\" {runs})\n\
         \x20 [ -n \"$run\" ] || break\n\
         \x20 {swarm} run \"$run/config.toml\" --out \"$run\" --force{mode} > /dev/null 2> {dir}/\"$i\".log &\n\
         \x20 pid=$!\n\
         \x20 wait \"$pid\"\n\
         \x20 code=$?\n\
         \x20 while kill -0 \"$pid\" 2>/dev/null; do wait \"$pid\"; code=$?; done\n\
         \x20 pid=\n\
         \x20 echo \"$code\" > {dir}/\"$i\".exit.part && mv {dir}/\"$i\".exit.part {dir}/\"$i\".exit\n\
         \x20 i=$((i + 1))\n\
         done\n\
         [ -z \"$stop\" ] || exit 143\n",
        runs = q(&dir.join("runs.txt")),
        swarm = q(swarm),
        mode = if in_process { " --in-process" } else { "" },
        dir = q(dir),
    )
}

/// The arrays of `out` that were submitted and not yet collected, oldest first.
pub fn pending_arrays(out: &Path) -> std::io::Result<Vec<Array>> {
    let root = out.join(SLURM_DIR);
    let Ok(entries) = std::fs::read_dir(&root) else {
        return Ok(Vec::new());
    };
    let mut found: Vec<(u64, PathBuf)> = entries
        .flatten()
        .filter_map(|e| {
            let name = e.file_name().to_string_lossy().into_owned();
            let n = name.strip_prefix("array-")?.parse().ok()?;
            Some((n, e.path()))
        })
        .collect();
    found.sort();
    let mut arrays = Vec::new();
    for (_, dir) in found {
        if dir.join("collected").exists() {
            continue;
        }
        let Ok(id) = std::fs::read_to_string(dir.join("job_id")) else {
            // Never submitted (sbatch refused it): nothing runs there.
            continue;
        };
        let runs = std::fs::read_to_string(dir.join("runs.txt"))?
            .lines()
            .map(PathBuf::from)
            .collect();
        let per_task = std::fs::read_to_string(dir.join("per_task"))
            .ok()
            .and_then(|t| t.trim().parse().ok())
            .unwrap_or(1usize)
            .max(1);
        arrays.push(Array {
            job_id: id.trim().to_string(),
            dir,
            runs,
            per_task,
        });
    }
    Ok(arrays)
}

/// Cancels arrays an earlier, killed invocation left running and waits until their tasks have
/// ended, so none of them still writes into a run directory that is about to be prepared again
/// (a tune resumes by running its unfinished evaluations afresh).
pub fn abandon(arrays: &[Array], poll: Duration) {
    scancel(arrays);
    let (_keep, never) = crossbeam_channel::bounded::<()>(0);
    wait(arrays, poll, false, &never, &mut |_| {});
}

/// A run still to report.
struct Waiting {
    array: usize,
    /// The run's index in its array.
    run: usize,
    /// Global index over all arrays' runs.
    index: usize,
    /// When the queue first showed it ended (or no longer knew it) without an exit file.
    gone_since: Option<Instant>,
}

/// Waits for every task of `arrays`, reporting each as it ends with its index over all the
/// arrays' runs in order. With `cancel`, the first Ctrl-C cancels the arrays and the wait goes
/// on until their tasks have ended (a second Ctrl-C stops waiting); without it, Ctrl-C stops
/// waiting at once and leaves the jobs to Slurm (their runs are reported `NotStarted`).
/// Returns whether it was interrupted.
pub fn wait(
    arrays: &[Array],
    poll: Duration,
    cancel: bool,
    interrupt: &Receiver<()>,
    on_event: &mut impl FnMut(Event),
) -> bool {
    let mut waiting: Vec<Waiting> = Vec::new();
    for (a, array) in arrays.iter().enumerate() {
        for run in 0..array.runs.len() {
            waiting.push(Waiting {
                array: a,
                run,
                index: waiting.len(),
                gone_since: None,
            });
        }
    }
    let mut left: Vec<usize> = arrays.iter().map(|a| a.runs.len()).collect();
    // A task's exit file may reach this machine a little after the queue says it ended.
    let grace = (poll * 3).max(Duration::from_secs(3));
    let mut interrupts = 0u32;
    let mut cancelled = false;
    let mut queue_error: Option<String> = None;
    let mut first = true;
    while !waiting.is_empty() {
        if !first {
            crossbeam_channel::select! {
                recv(interrupt) -> msg => {
                    if msg.is_ok() {
                        interrupts += 1;
                        on_event(Event::Interrupt(interrupts));
                        if cancel && interrupts == 1 {
                            scancel(arrays);
                            cancelled = true;
                        } else {
                            for w in waiting.drain(..) {
                                let outcome = if cancel { Outcome::Interrupted } else { Outcome::NotStarted };
                                on_event(Event::Finished(w.index, outcome));
                            }
                            break;
                        }
                    }
                }
                default(poll) => {}
            }
        }
        first = false;
        let states = match queue_states(arrays) {
            Ok(s) => {
                queue_error = None;
                Some(s)
            }
            Err(e) => {
                if queue_error.as_deref() != Some(&e) {
                    eprintln!("warning: cannot read the Slurm queue ({e}); still waiting");
                    queue_error = Some(e);
                }
                None
            }
        };
        let now = Instant::now();
        let mut i = 0;
        while i < waiting.len() {
            let w = &mut waiting[i];
            let array = &arrays[w.array];
            let task = w.run / array.per_task;
            let state = states
                .as_ref()
                .map(|s| s.get(&(array.job_id.clone(), task)).cloned());
            let outcome = if let Some(code) = exit_code(&array.dir, w.run) {
                let active = matches!(&state, Some(Some(s)) if ACTIVE.contains(&s.as_str()));
                let (o, outside) = finished(array, w.run, code, cancelled, state.flatten());
                // A stop from outside is named by the task's final state (CANCELLED,
                // TIMEOUT), which the queue shows once the task has ended (not COMPLETING).
                (!(outside && active)).then_some(o)
            } else {
                match state {
                    // The queue could not be read: nothing is known.
                    None => None,
                    Some(Some(s)) if ACTIVE.contains(&s.as_str()) => {
                        w.gone_since = None;
                        None
                    }
                    Some(s) => {
                        let since = *w.gone_since.get_or_insert(now);
                        (now - since >= grace).then(|| vanished(array, w.run, s, cancelled))
                    }
                }
            };
            match outcome {
                Some(o) => {
                    let w = waiting.remove(i);
                    left[w.array] -= 1;
                    if left[w.array] == 0 {
                        let _ = std::fs::write(arrays[w.array].dir.join("collected"), "");
                    }
                    on_event(Event::Finished(w.index, o));
                }
                None => i += 1,
            }
        }
    }
    interrupts > 0
}

/// The outcome of run `i` of an array, which wrote its exit code, and whether something
/// outside the sweep stopped it.
fn finished(
    array: &Array,
    i: usize,
    code: i32,
    cancelled: bool,
    state: Option<String>,
) -> (Outcome, bool) {
    let task = i / array.per_task;
    let tail = log_tail(&array.dir, i);
    let status = Ok(ExitStatus::from_raw_code(code));
    let stopped = |metrics, how: String| {
        let reason = format!(
            "Slurm task {}_{task} was stopped from outside the sweep{}{how}",
            array.job_id,
            state
                .as_ref()
                .map(|s| format!(" ({s})"))
                .unwrap_or_default()
        );
        (Outcome::Failed { metrics, reason }, true)
    };
    match runner::classify(&array.runs[i], status, cancelled, &tail) {
        // Stopped in order, but not by this sweep: someone cancelled the task (`scancel`).
        Outcome::Interrupted if !cancelled => stopped(None, String::new()),
        // Killed by a signal (128 + n) the sweep did not send: Slurm's, on a cancel or a
        // time limit (its SIGTERM reaches the run twice, from Slurm and from the task's shell).
        Outcome::Failed { metrics, reason } if !cancelled && code >= 128 => {
            stopped(metrics, format!(": {reason}"))
        }
        o => (o, false),
    }
}

/// The outcome of run `i`, whose task the queue says ended (or no longer knows) without the
/// run's exit code.
fn vanished(array: &Array, i: usize, state: Option<String>, cancelled: bool) -> Outcome {
    if cancelled {
        return Outcome::Interrupted;
    }
    let task = i / array.per_task;
    let log = array.dir.join(format!("{i}.log"));
    let how = match state {
        Some(s) => format!("ended {s}"),
        None => "left the queue (cancelled, timed out, or its node failed)".into(),
    };
    let said = log_tail(&array.dir, i)
        .iter()
        .rev()
        .find(|l| !l.trim().is_empty())
        .map(|l| format!("; its log ends: {}", l.trim()))
        .unwrap_or_default();
    Outcome::Failed {
        metrics: None,
        reason: format!(
            "Slurm task {}_{task} {how} before its run finished (log {}){said}",
            array.job_id,
            log.display()
        ),
    }
}

/// The state of every task the queue still knows: (job id, task) -> `%T`.
fn queue_states(arrays: &[Array]) -> Result<BTreeMap<(String, usize), String>, String> {
    let ids: Vec<&str> = arrays.iter().map(|a| a.job_id.as_str()).collect();
    let mut states = BTreeMap::new();
    // squeue refuses the whole list when one id is no longer known, so ask per array.
    for id in ids {
        let out = Command::new("squeue")
            .args(["--noheader", "--array", "--states=all", "--format=%F %K %T"])
            .arg(format!("--jobs={id}"))
            .stdin(Stdio::null())
            .output()
            .map_err(|e| format!("cannot run squeue: {e}"))?;
        if !out.status.success() {
            let err = String::from_utf8_lossy(&out.stderr);
            if err.contains("Invalid job id") {
                continue;
            }
            return Err(format!("squeue {}: {}", describe(out.status), err.trim()));
        }
        for line in String::from_utf8_lossy(&out.stdout).lines() {
            let mut f = line.split_whitespace();
            let (Some(job), Some(task), Some(state)) = (f.next(), f.next(), f.next()) else {
                continue;
            };
            if let Ok(t) = task.parse::<usize>() {
                states.insert((job.to_string(), t), state.to_string());
            }
        }
    }
    Ok(states)
}

/// Cancels the arrays; a failure is said, not fatal (the tasks may have ended already).
fn scancel(arrays: &[Array]) {
    if arrays.is_empty() {
        return;
    }
    let ids: Vec<&str> = arrays.iter().map(|a| a.job_id.as_str()).collect();
    match Command::new("scancel")
        .args(&ids)
        .stdin(Stdio::null())
        .output()
    {
        Ok(o) if o.status.success() => {
            eprintln!("cancelled Slurm job(s) {}", ids.join(", "));
        }
        Ok(o) => eprintln!(
            "warning: scancel {}: {}",
            ids.join(" "),
            String::from_utf8_lossy(&o.stderr).trim()
        ),
        Err(e) => eprintln!("warning: cannot run scancel: {e}"),
    }
}

/// The exit code run `i`'s task wrote for it, if it did.
fn exit_code(dir: &Path, i: usize) -> Option<i32> {
    std::fs::read_to_string(dir.join(format!("{i}.exit")))
        .ok()?
        .trim()
        .parse()
        .ok()
}

/// The last lines of run `i`'s log (its `swarm run`'s stderr).
fn log_tail(dir: &Path, i: usize) -> Vec<String> {
    let text = std::fs::read_to_string(dir.join(format!("{i}.log"))).unwrap_or_default();
    let lines: Vec<&str> = text.lines().collect();
    lines[lines.len().saturating_sub(runner::STDERR_TAIL)..]
        .iter()
        .map(|l| l.to_string())
        .collect()
}

/// `<root>/array-<n>` for the first `n` not taken, created.
fn new_array_dir(root: &Path) -> std::io::Result<PathBuf> {
    std::fs::create_dir_all(root)?;
    for n in 0.. {
        let dir = root.join(format!("array-{n}"));
        match std::fs::create_dir(&dir) {
            Ok(()) => return Ok(dir),
            Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => continue,
            Err(e) => return Err(e),
        }
    }
    unreachable!("an unbounded range")
}

/// `p` from the filesystem root: the tasks run with the submit directory as theirs, but the
/// array's files must be found from any directory.
fn absolute(p: &Path) -> PathBuf {
    std::path::absolute(p).unwrap_or_else(|_| p.to_path_buf())
}

/// `s` as one word of a POSIX shell.
fn shell_word(s: &str) -> String {
    format!("'{}'", s.replace('\'', "'\\''"))
}

fn describe(s: ExitStatus) -> String {
    match s.code() {
        Some(c) => format!("exit {c}"),
        None => format!("{s}"),
    }
}

/// An exit status from a shell's `$?` (a code, or 128 + the signal).
trait FromRawCode {
    fn from_raw_code(code: i32) -> Self;
}

impl FromRawCode for ExitStatus {
    fn from_raw_code(code: i32) -> Self {
        use std::os::unix::process::ExitStatusExt;
        ExitStatus::from_raw((code & 0xff) << 8)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_task_script_quotes_every_path() {
        let s = task_script(
            Path::new("/s w/it's/array-0"),
            Path::new("/bin/swarm"),
            true,
            3,
        );
        assert!(s.contains("i=$((t * 3))\nend=$((i + 3))\n"));
        assert!(s.contains("sed -n \"$((i + 1))p\" '/s w/it'\\''s/array-0/runs.txt'"));
        assert!(s.contains(
            "'/bin/swarm' run \"$run/config.toml\" --out \"$run\" --force --in-process > /dev/null 2> '/s w/it'\\''s/array-0'/\"$i\".log &"
        ));
        assert!(s.contains(
            "mv '/s w/it'\\''s/array-0'/\"$i\".exit.part '/s w/it'\\''s/array-0'/\"$i\".exit"
        ));
    }

    /// The script run by `sh` as Slurm would run task `t`, with a stand-in `swarm` that
    /// records its arguments: each task runs its own runs, in order, and records each exit.
    #[test]
    fn each_task_runs_its_share_of_the_runs() {
        let d = tempfile::tempdir().unwrap();
        let fake = d.path().join("swarm");
        std::fs::write(
            &fake,
            "#!/bin/sh\necho \"$4\" >> \"$(dirname \"$0\")/ran\"\ncase \"$4\" in *r3) exit 7;; esac\n",
        )
        .unwrap();
        let mut perm = std::fs::metadata(&fake).unwrap().permissions();
        std::os::unix::fs::PermissionsExt::set_mode(&mut perm, 0o755);
        std::fs::set_permissions(&fake, perm).unwrap();
        let runs: String = (0..5).map(|r| format!("/x/r{r}\n")).collect();
        std::fs::write(d.path().join("runs.txt"), runs).unwrap();
        let script = d.path().join("run.sh");
        std::fs::write(&script, task_script(d.path(), &fake, false, 2)).unwrap();
        for t in 0..3 {
            let ok = Command::new("sh")
                .arg(&script)
                .env("SLURM_ARRAY_TASK_ID", t.to_string())
                .status()
                .unwrap();
            assert!(ok.success() || t == 1, "task {t}");
        }
        let ran = std::fs::read_to_string(d.path().join("ran")).unwrap();
        assert_eq!(ran, "/x/r0\n/x/r1\n/x/r2\n/x/r3\n/x/r4\n");
        let codes: Vec<Option<i32>> = (0..6).map(|i| exit_code(d.path(), i)).collect();
        assert_eq!(codes, [Some(0), Some(0), Some(0), Some(7), Some(0), None]);
    }

    #[test]
    fn arrays_are_numbered_and_collected_ones_skipped() {
        let out = tempfile::tempdir().unwrap();
        let root = out.path().join(SLURM_DIR);
        let a = new_array_dir(&root).unwrap();
        let b = new_array_dir(&root).unwrap();
        let c = new_array_dir(&root).unwrap();
        assert!(a.ends_with("array-0") && b.ends_with("array-1") && c.ends_with("array-2"));
        for (d, id) in [(&a, "7"), (&b, "8")] {
            std::fs::write(d.join("job_id"), format!("{id}\n")).unwrap();
            std::fs::write(d.join("runs.txt"), "/x/runs/a\n/x/runs/b\n").unwrap();
        }
        std::fs::write(a.join("collected"), "").unwrap();
        // c was never submitted (no job_id).
        let p = pending_arrays(out.path()).unwrap();
        assert_eq!(p.len(), 1);
        assert_eq!(p[0].job_id, "8");
        assert_eq!(
            p[0].runs,
            [PathBuf::from("/x/runs/a"), PathBuf::from("/x/runs/b")]
        );
    }

    #[test]
    fn an_exit_code_becomes_a_status() {
        assert!(ExitStatus::from_raw_code(0).success());
        assert_eq!(ExitStatus::from_raw_code(130).code(), Some(130));
        let d = tempfile::tempdir().unwrap();
        assert_eq!(exit_code(d.path(), 3), None);
        std::fs::write(d.path().join("3.exit"), "1\n").unwrap();
        assert_eq!(exit_code(d.path(), 3), Some(1));
    }
}
