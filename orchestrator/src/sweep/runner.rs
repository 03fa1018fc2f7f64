//! Runs a sweep's jobs, `jobs` at a time, each as a child `swarm run` writing an ordinary run
//! directory.
//!
//! Why a child process per run rather than calling `processes::run` on threads: a crash or
//! abort in one run's supervisor (or in the in-process cores) would take every other run and
//! the sweep down with it, and a run's Ctrl-C handling and its cleanup on every exit path are
//! per process. A child `swarm run` owns its Ctrl-C handling and its cleanup, writes exactly
//! what `swarm run` writes, and a crash in one run cannot take the sweep down. `--in-process` runs go the same way (`swarm run --in-process`), so both modes
//! share one path. Children run in their own process group: a terminal's Ctrl-C reaches only
//! the sweep, which forwards it once to each running child (a second Ctrl-C forwards it
//! again, which makes `swarm run` kill its run at once).

use std::collections::{BTreeMap, VecDeque};
use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::Command;
use std::process::{ExitStatus, Stdio};
use std::sync::Condvar;
use std::sync::Mutex;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Duration;

use crossbeam_channel::{Receiver, Sender};

use super::executor::Executor;
use crate::processes::child_command;
use crate::run_dir;

/// Lines of a failed run's stderr kept for the report.
pub(crate) const STDERR_TAIL: usize = 12;

/// One run to do.
#[derive(Debug, Clone)]
pub struct Job {
    /// The run directory; removed and recreated when the job starts.
    pub dir: PathBuf,
    /// The resolved config, written to `dir/config.toml` and run from there.
    pub config_toml: String,
}

/// How a job ended.
#[derive(Debug, Clone, PartialEq)]
pub enum Outcome {
    /// It ran to the end; its `metrics.json`.
    Done(serde_json::Value),
    /// It failed (a child crashed, metrics say `failed`); what it left and why.
    Failed {
        /// Its `metrics.json`, if it wrote one.
        metrics: Option<serde_json::Value>,
        /// One line saying what happened.
        reason: String,
    },
    /// Ctrl-C (or a signal from elsewhere) stopped it; it is not a row.
    Interrupted,
    /// Never started, because the sweep was stopping.
    NotStarted,
}

/// What the pool reports to the caller's thread, in the order it happens.
#[derive(Debug)]
pub enum Event {
    /// The `n`-th Ctrl-C arrived and was forwarded to the running children.
    Interrupt(u32),
    /// Job `index` ended.
    Finished(usize, Outcome),
    /// A host of the ssh executor was lost; its runs go to the other hosts. One line.
    HostLost(String),
}

/// Where a pool's workers start their runs: this machine (no launcher) or a host reached
/// through its launcher (`ssh host`, `ip netns exec ns`).
#[derive(Debug, Clone, PartialEq)]
pub struct PoolHost {
    /// Its name in messages.
    pub name: String,
    /// The command prefixed to `swarm run ...`; empty: this machine.
    pub launcher: Vec<String>,
    /// Runs at once on it.
    pub slots: usize,
    /// The `swarm` executable there [default: the one running here, at the same path].
    pub swarm: Option<PathBuf>,
}

/// How to run the jobs.
#[derive(Debug, Clone)]
pub struct PoolOptions {
    /// The `swarm` executable for the children.
    pub swarm: PathBuf,
    /// Pass `--in-process` to every run.
    pub in_process: bool,
    /// Where the runs are made.
    pub executor: Executor,
    /// The sweep's (or tune's) directory: an executor keeps its own files under it.
    pub state_dir: PathBuf,
}

/// Shared between the workers and the Ctrl-C forwarder.
struct Shared {
    /// Jobs not started yet (a lost host's job goes back to the front) and how many run.
    queue: Mutex<Queue>,
    /// Signalled when a job ends or is put back: idle workers look at the queue again.
    changed: Condvar,
    stop: AtomicBool,
    /// Running children: pid -> whether Ctrl-C was forwarded to it. A pid leaves this map
    /// before it is reaped, so a signal can never reach a recycled pid.
    active: Mutex<BTreeMap<i32, bool>>,
    /// Per host: lost (its workers take no more jobs).
    lost: Vec<AtomicBool>,
}

struct Queue {
    pending: VecDeque<usize>,
    running: usize,
}

/// Runs `jobs` with the options' executor and hands every [`Event`] to `on_event` on the
/// calling thread. Stops launching on Ctrl-C (`interrupt`); returns whether it was interrupted.
pub fn run_all(
    jobs: &[Job],
    opts: &PoolOptions,
    interrupt: Receiver<()>,
    on_event: impl FnMut(Event),
) -> bool {
    match &opts.executor {
        Executor::Local { jobs: n } => {
            let here = PoolHost {
                name: "this machine".into(),
                launcher: Vec::new(),
                slots: *n,
                swarm: None,
            };
            run_pool(jobs, opts, &[here], interrupt, on_event)
        }
        Executor::Ssh(hosts) => run_pool(jobs, opts, hosts, interrupt, on_event),
        Executor::Slurm(slurm) => super::slurm::run_all(jobs, opts, slurm, interrupt, on_event),
    }
}

/// The pool: `slots` workers per host, each starting one child `swarm run` after the other.
fn run_pool(
    jobs: &[Job],
    opts: &PoolOptions,
    hosts: &[PoolHost],
    interrupt: Receiver<()>,
    mut on_event: impl FnMut(Event),
) -> bool {
    let shared = Shared {
        queue: Mutex::new(Queue {
            pending: (0..jobs.len()).collect(),
            running: 0,
        }),
        changed: Condvar::new(),
        stop: AtomicBool::new(false),
        active: Mutex::new(BTreeMap::new()),
        lost: hosts.iter().map(|_| AtomicBool::new(false)).collect(),
    };
    let (tx, rx) = crossbeam_channel::unbounded::<Option<Event>>();
    let (quit_tx, quit_rx) = crossbeam_channel::bounded::<()>(0);
    let mut workers = 0;
    std::thread::scope(|s| {
        {
            let tx = tx.clone();
            let shared = &shared;
            s.spawn(move || forward_interrupts(&interrupt, &quit_rx, shared, &tx));
        }
        for h in 0..hosts.len() {
            for _ in 0..hosts[h].slots.clamp(1, jobs.len().max(1)) {
                workers += 1;
                let tx = tx.clone();
                let shared = &shared;
                s.spawn(move || {
                    worker(jobs, opts, hosts, h, shared, &tx);
                    let _ = tx.send(None);
                });
            }
        }
        let mut left = workers;
        while left > 0 {
            match rx.recv() {
                Ok(Some(ev)) => on_event(ev),
                Ok(None) => left -= 1,
                Err(_) => break,
            }
        }
        drop(quit_tx);
        // Only an Interrupt can still be queued (the forwarder may have sent one late).
        while let Ok(Some(ev)) = rx.try_recv() {
            on_event(ev);
        }
    });
    shared.stop.load(Ordering::SeqCst)
}

/// Sets `stop` and forwards SIGINT to every running child on each Ctrl-C, until `quit`.
fn forward_interrupts(
    interrupt: &Receiver<()>,
    quit: &Receiver<()>,
    shared: &Shared,
    tx: &Sender<Option<Event>>,
) {
    let mut count = 0;
    loop {
        crossbeam_channel::select! {
            recv(interrupt) -> msg => {
                if msg.is_err() {
                    // No Ctrl-C handler: nothing to forward.
                    let _ = quit.recv();
                    return;
                }
                count += 1;
                let mut active = shared.active.lock().unwrap_or_else(|e| e.into_inner());
                shared.stop.store(true, Ordering::SeqCst);
                for (pid, signalled) in active.iter_mut() {
                    // SAFETY: kill has no memory effects; the pid is a live, unreaped child.
                    unsafe {
                        libc::kill(*pid, libc::SIGINT);
                    }
                    *signalled = true;
                }
                drop(active);
                let _ = tx.send(Some(Event::Interrupt(count)));
            }
            recv(quit) -> _ => return,
        }
    }
}

/// Takes jobs for host `h` until none is left (or Ctrl-C, or the host is lost). An idle worker
/// waits while jobs run elsewhere: a lost host's job may come back to the queue.
fn worker(
    jobs: &[Job],
    opts: &PoolOptions,
    hosts: &[PoolHost],
    h: usize,
    shared: &Shared,
    tx: &Sender<Option<Event>>,
) {
    let host = &hosts[h];
    loop {
        let i = {
            let mut q = shared.queue.lock().unwrap_or_else(|e| e.into_inner());
            loop {
                if shared.stop.load(Ordering::SeqCst) || shared.lost[h].load(Ordering::SeqCst) {
                    return;
                }
                if let Some(i) = q.pending.pop_front() {
                    q.running += 1;
                    break i;
                }
                if q.running == 0 {
                    return;
                }
                q = shared.changed.wait(q).unwrap_or_else(|e| e.into_inner());
            }
        };
        let outcome = run_one(&jobs[i], opts, host, shared);
        let outcome = match host_lost(host, &outcome) {
            Some(why) => {
                shared.lost[h].store(true, Ordering::SeqCst);
                let others = (0..hosts.len()).any(|o| !shared.lost[o].load(Ordering::SeqCst));
                let rel = jobs[i].dir.file_name().map_or_else(
                    || jobs[i].dir.display().to_string(),
                    |n| n.to_string_lossy().into_owned(),
                );
                if others {
                    let mut q = shared.queue.lock().unwrap_or_else(|e| e.into_inner());
                    q.pending.push_front(i);
                    q.running -= 1;
                    drop(q);
                    shared.changed.notify_all();
                    let _ = tx.send(Some(Event::HostLost(format!(
                        "host {} lost ({why}); its run runs/{rel} goes to another host",
                        host.name
                    ))));
                    return;
                }
                Outcome::Failed {
                    metrics: None,
                    reason: format!("host {} lost ({why}) and no host is left", host.name),
                }
            }
            None => outcome,
        };
        {
            let mut q = shared.queue.lock().unwrap_or_else(|e| e.into_inner());
            q.running -= 1;
        }
        shared.changed.notify_all();
        if tx.send(Some(Event::Finished(i, outcome))).is_err() {
            return;
        }
    }
}

/// Whether a run that failed without writing its metrics failed because its host is gone:
/// then `launcher true` fails too (ssh's own failure is exit 255). Only for remote hosts.
fn host_lost(host: &PoolHost, outcome: &Outcome) -> Option<String> {
    if host.launcher.is_empty() || !matches!(outcome, Outcome::Failed { metrics: None, .. }) {
        return None;
    }
    let mut probe = Command::new(&host.launcher[0]);
    probe
        .args(&host.launcher[1..])
        .arg("true")
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(Stdio::piped());
    let child = match probe.spawn() {
        Ok(c) => c,
        Err(e) => return Some(format!("cannot run its launcher: {e}")),
    };
    let pid = child.id() as i32;
    // The probe is waited for on a thread so the worker blocks with a deadline, not a poll.
    let (tx, rx) = crossbeam_channel::bounded(1);
    std::thread::spawn(move || {
        let _ = tx.send(child.wait_with_output());
    });
    match rx.recv_timeout(PROBE_TIMEOUT) {
        Ok(Ok(out)) if out.status.success() => None,
        Ok(Ok(out)) => {
            let err = String::from_utf8_lossy(&out.stderr);
            let said = err
                .lines()
                .rev()
                .find(|l| !l.trim().is_empty())
                .unwrap_or("");
            Some(format!(
                "`{} true` {}: {}",
                host.launcher.join(" "),
                describe(out.status),
                said.trim()
            ))
        }
        Ok(Err(e)) => Some(format!("its launcher could not be waited for: {e}")),
        Err(_) => {
            // SAFETY: kill has no memory effects; the probe is our child, reaped by its thread.
            unsafe {
                libc::kill(pid, libc::SIGKILL);
            }
            Some(format!(
                "`{} true` did not answer in {} s",
                host.launcher.join(" "),
                PROBE_TIMEOUT.as_secs()
            ))
        }
    }
}

/// How long a lost host's launcher may take to say so.
const PROBE_TIMEOUT: Duration = Duration::from_secs(15);

/// Prepares the run directory and runs `swarm run` in it. The child is spawned under the
/// `active` lock after a last look at `stop`, so every child either sees a forwarded Ctrl-C
/// or is never started. This thread waits for the child, so the child's parent-death signal
/// (bound to the spawning thread) only fires if the sweep itself dies.
fn run_one(job: &Job, opts: &PoolOptions, host: &PoolHost, shared: &Shared) -> Outcome {
    let mut child = {
        let mut active = shared.active.lock().unwrap_or_else(|e| e.into_inner());
        if shared.stop.load(Ordering::SeqCst) {
            return Outcome::NotStarted;
        }
        let config = job.dir.join("config.toml");
        if let Err(e) = prepare(&job.dir, &job.config_toml) {
            return Outcome::Failed {
                metrics: None,
                reason: format!("cannot prepare {}: {e:#}", job.dir.display()),
            };
        }
        let swarm = host.swarm.as_ref().unwrap_or(&opts.swarm);
        let mut cmd = match host.launcher.split_first() {
            None => child_command(swarm),
            Some((launcher, args)) => {
                let mut c = child_command(Path::new(launcher));
                c.args(args).arg(swarm);
                c
            }
        };
        // The directory holds the config the child runs from (and nothing of an earlier
        // attempt, see `prepare`), so the child needs --force; it still takes the
        // directory's lock and is refused if another run holds it.
        cmd.arg("run")
            .arg(&config)
            .arg("--out")
            .arg(&job.dir)
            .arg("--force");
        if opts.in_process {
            cmd.arg("--in-process");
        }
        cmd.stdin(Stdio::null())
            .stdout(Stdio::null())
            .stderr(Stdio::piped());
        match cmd.spawn() {
            Ok(c) => {
                active.insert(c.id() as i32, false);
                c
            }
            Err(e) => {
                return Outcome::Failed {
                    metrics: None,
                    reason: format!("cannot start {}: {e}", cmd.get_program().to_string_lossy()),
                };
            }
        }
    };
    let pid = child.id() as i32;
    let tail = child.stderr.take().map(|err| {
        std::thread::spawn(move || {
            let mut tail = VecDeque::new();
            for line in BufReader::new(err).lines() {
                let Ok(line) = line else { break };
                tracing::debug!(target: "swarm::sweep::child", pid, "{line}");
                if tail.len() == STDERR_TAIL {
                    tail.pop_front();
                }
                tail.push_back(line);
            }
            Vec::from(tail)
        })
    });
    wait_without_reaping(pid);
    let signalled = shared
        .active
        .lock()
        .unwrap_or_else(|e| e.into_inner())
        .remove(&pid)
        .unwrap_or(false);
    let status = child.wait();
    let tail = tail.and_then(|h| h.join().ok()).unwrap_or_default();
    classify(&job.dir, status, signalled, &tail)
}

/// Removes what an earlier, unfinished attempt left and writes the resolved config (as
/// `config.toml`), under the directory's lock and through its handle (checked as every run
/// directory is): a directory another run is using is refused, not cleared.
pub(crate) fn prepare(dir: &Path, toml: &str) -> anyhow::Result<()> {
    let out = run_dir::open_out("the run directory", dir).map_err(|e| anyhow::anyhow!("{e}"))?;
    let _lock = run_dir::lock(&out).map_err(|e| anyhow::anyhow!("{e}"))?;
    for entry in out.entries()? {
        if entry.name == run_dir::LOCK_FILE {
            continue;
        }
        if entry.is_dir {
            out.remove_dir_all(&entry.name)?;
        } else {
            out.remove_file(&entry.name)?;
        }
    }
    // Marked as swarm's, so the child's `--force` may clear it.
    run_dir::mark(&out)?;
    out.write("config.toml", toml)?;
    Ok(())
}

/// Blocks until child `pid` has exited, leaving it a zombie so its pid stays reserved.
fn wait_without_reaping(pid: i32) {
    loop {
        // SAFETY: siginfo_t is plain data; waitid only writes into it.
        let mut info: libc::siginfo_t = unsafe { std::mem::zeroed() };
        let r = unsafe {
            libc::waitid(
                libc::P_PID,
                pid as libc::id_t,
                &mut info,
                libc::WEXITED | libc::WNOWAIT,
            )
        };
        if r == 0 || std::io::Error::last_os_error().raw_os_error() != Some(libc::EINTR) {
            return;
        }
    }
}

/// Sorts a finished child into an outcome from its `metrics.json`, exit status and whether
/// the sweep forwarded Ctrl-C to it.
pub(crate) fn classify(
    dir: &Path,
    status: std::io::Result<ExitStatus>,
    signalled: bool,
    tail: &[String],
) -> Outcome {
    let metrics: Option<serde_json::Value> = std::fs::read_to_string(dir.join("metrics.json"))
        .ok()
        .and_then(|t| serde_json::from_str(&t).ok());
    let ok_exit = status.as_ref().is_ok_and(ExitStatus::success);
    match &metrics {
        Some(m) if m["interrupted"] == true => return Outcome::Interrupted,
        Some(m) if m["failed"] == false && ok_exit => return Outcome::Done(m.clone()),
        _ if signalled => return Outcome::Interrupted,
        _ => {}
    }
    let how = match &status {
        Ok(s) => describe(*s),
        Err(e) => format!("could not be waited for: {e}"),
    };
    let said = tail
        .iter()
        .rev()
        .find(|l| !l.trim().is_empty())
        .map(|l| format!(": {}", l.trim()))
        .unwrap_or_default();
    let reason = match metrics.as_ref().and_then(|m| m["failure"].as_str()) {
        Some(f) => f.to_string(),
        None => format!("swarm run {how}{said}"),
    };
    Outcome::Failed { metrics, reason }
}

fn describe(s: ExitStatus) -> String {
    use std::os::unix::process::ExitStatusExt;
    match (s.code(), s.signal()) {
        (Some(c), _) => format!("exited with code {c}"),
        (None, Some(sig)) => format!("was killed by signal {sig}"),
        _ => format!("ended with {s}"),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;
    use std::os::unix::process::ExitStatusExt;

    fn with_metrics(m: Option<serde_json::Value>) -> tempfile::TempDir {
        let dir = tempfile::tempdir().unwrap();
        if let Some(m) = m {
            std::fs::write(dir.path().join("metrics.json"), m.to_string()).unwrap();
        }
        dir
    }

    fn exit(code: i32) -> std::io::Result<ExitStatus> {
        Ok(ExitStatus::from_raw(code << 8))
    }

    #[test]
    fn classify_outcomes() {
        let done = json!({"failed": false, "interrupted": false, "ticks": 5});
        let d = with_metrics(Some(done.clone()));
        assert_eq!(
            classify(d.path(), exit(0), false, &[]),
            Outcome::Done(done.clone())
        );
        // Finished just before the forwarded Ctrl-C arrived: still a row.
        assert_eq!(classify(d.path(), exit(0), true, &[]), Outcome::Done(done));

        let d = with_metrics(Some(json!({"failed": false, "interrupted": true})));
        assert_eq!(classify(d.path(), exit(0), true, &[]), Outcome::Interrupted);
        assert_eq!(
            classify(d.path(), exit(0), false, &[]),
            Outcome::Interrupted
        );

        // Killed by the forwarded SIGINT before its handler was installed.
        let d = with_metrics(None);
        let sigint = Ok(ExitStatus::from_raw(libc::SIGINT));
        assert_eq!(classify(d.path(), sigint, true, &[]), Outcome::Interrupted);

        let d = with_metrics(Some(
            json!({"failed": true, "interrupted": false, "failure": "world process killed"}),
        ));
        match classify(d.path(), exit(1), false, &[]) {
            Outcome::Failed { metrics, reason } => {
                assert!(metrics.is_some());
                assert_eq!(reason, "world process killed");
            }
            o => panic!("{o:?}"),
        }
        let d = with_metrics(None);
        let tail = vec!["error: boom".to_string(), String::new()];
        match classify(d.path(), Ok(ExitStatus::from_raw(9)), false, &tail) {
            Outcome::Failed { metrics, reason } => {
                assert!(metrics.is_none());
                assert_eq!(reason, "swarm run was killed by signal 9: error: boom");
            }
            o => panic!("{o:?}"),
        }
    }
}
