//! The orchestrator's side of a `--hosts` run: one `swarm-host` per remote host, started
//! through the host's launcher (ssh in real life), fed the run's config and its robots' faults
//! as lines on its stdin, and heard through its stdout.
//!
//! A host that fails before the run starts fails the run (exit 2, one line naming it). A host
//! lost during the run (its process or launcher ended, or it reported a failure) makes its
//! robots dead at the current tick; the run goes on and is not reproducible.

use std::collections::BTreeMap;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::{ChildStdin, Stdio};
use std::time::Duration;

use anyhow::Context;
use crossbeam_channel::Sender;
use swarmrt_hosts::HostsFile;
use swarmrt_protocol::control::{HostControl, HostReport, ProcessFault};

use swarmrt_scenario::process::{child_command, signal_all};

/// How long the after-run cleanup through one launcher may take.
const CLEAN_TIMEOUT: Duration = Duration::from_secs(15);

/// A failure of a host that makes the whole run fail (a bad or unreachable host): the user's
/// to fix, so `swarm run` exits 2 with this one line.
#[derive(Debug, thiserror::Error)]
#[error("host {host}: {why}")]
pub struct HostFailure {
    /// The host's name.
    pub host: String,
    /// What failed.
    pub why: String,
}

/// The hosts of a run, as given to `swarm run --hosts`.
#[derive(Debug, Clone)]
pub struct RunHosts {
    /// The checked file.
    pub file: HostsFile,
    /// Its copy in the run directory (the world reads it there).
    pub path: PathBuf,
}

/// What a host's threads tell the supervisor.
#[derive(Debug)]
pub enum HostMsg {
    /// A report line.
    Report(HostReport),
    /// Its stdout closed.
    Eof,
}

/// One running `swarm-host` (its launcher process, really).
struct Remote {
    name: String,
    pid: i32,
    stdin: Option<ChildStdin>,
    joined: bool,
    done: bool,
    /// Its launcher has been reaped.
    exited: bool,
    /// Set once the host is gone or failed: why.
    lost: Option<String>,
    stats: Option<serde_json::Value>,
}

/// The remote hosts of a run.
pub struct Remotes {
    file: HostsFile,
    hosts: Vec<Remote>,
    /// Remote robots killed on an order and not restarted: a host lost later does not
    /// count them again as its deaths.
    killed: std::collections::BTreeSet<u32>,
}

/// The `swarm-host` command on `host`: its launcher, then the program and its arguments.
fn host_command(file: &HostsFile, i: usize, run_id: &str, program: &Path) -> std::process::Command {
    let h = &file.hosts[i];
    let mut cmd = child_command(Path::new(&h.launcher[0]));
    cmd.args(&h.launcher[1..])
        .arg(h.program.as_deref().unwrap_or(program));
    cmd.args(["--run-id", run_id]);
    cmd
}

impl Remotes {
    /// Starts every host's `swarm-host` through its launcher and gives it the config. Each
    /// host's reports come to `tx` as `wrap(host, msg)`; `watch` reaps a launcher and gets a
    /// channel whose sender is dropped once that launcher's stdout has ended.
    pub fn launch<M: Send + 'static>(
        file: &HostsFile,
        run_id: &str,
        config_path: &Path,
        tx: &Sender<M>,
        wrap: fn(usize, HostMsg) -> M,
        watch: impl Fn(i32, crossbeam_channel::Receiver<()>) -> std::io::Result<()>,
    ) -> anyhow::Result<Remotes> {
        let program = crate::binaries::sibling_binary("swarm-host")?;
        let toml = std::fs::read_to_string(config_path)
            .with_context(|| format!("cannot read {}", config_path.display()))?;
        let config_line = HostControl::Config { toml }.to_line();
        let mut hosts = Vec::new();
        let mut remotes = Remotes {
            file: file.clone(),
            hosts: Vec::new(),
            killed: Default::default(),
        };
        for (i, h) in file.hosts.iter().enumerate() {
            let mut cmd = host_command(file, i, run_id, &program);
            cmd.args(["--host", &h.name])
                .args(["--first", &h.robots.start.to_string()])
                .args(["--count", &h.robots.len().to_string()])
                .args(["--connect", &h.connect])
                .arg("--certs")
                .arg(&h.certs)
                .stdin(Stdio::piped())
                .stdout(Stdio::piped());
            let mut child = match cmd.spawn() {
                Ok(c) => c,
                Err(e) => {
                    remotes.hosts = hosts;
                    remotes.kill();
                    return Err(HostFailure {
                        host: h.name.clone(),
                        why: format!("cannot start its launcher {:?}: {e}", h.launcher[0]),
                    }
                    .into());
                }
            };
            let pid = child.id() as i32;
            let mut stdin = child.stdin.take();
            if let Some(s) = stdin.as_mut()
                && s.write_all(config_line.as_bytes())
                    .and_then(|_| s.flush())
                    .is_err()
            {
                stdin = None;
            }
            let stdout = child.stdout.take().context("host stdout")?;
            let tx2 = tx.clone();
            let (eof_tx, eof_rx) = crossbeam_channel::bounded::<()>(0);
            let tx3 = tx2.clone();
            swarmrt_ipc::lines::read_json_lines(
                stdout,
                format!("host {}", h.name),
                move |r: HostReport| tx2.send(wrap(i, HostMsg::Report(r))).is_ok(),
                move || {
                    let _ = tx3.send(wrap(i, HostMsg::Eof));
                    // Dropped after the last message: the launcher's reaper waits for that.
                    drop(eof_tx);
                },
            );
            hosts.push(Remote {
                name: h.name.clone(),
                pid,
                stdin,
                joined: false,
                done: false,
                exited: false,
                lost: None,
                stats: None,
            });
            if let Err(e) = watch(pid, eof_rx) {
                remotes.hosts = hosts;
                remotes.kill();
                return Err(anyhow::anyhow!(
                    "cannot watch host {}'s launcher: {e}",
                    h.name
                ));
            }
        }
        remotes.hosts = hosts;
        Ok(remotes)
    }

    /// The host running `robot`, if a remote one does.
    pub fn host_of(&self, robot: u32) -> Option<usize> {
        self.file.host_of(robot)
    }

    /// The host whose launcher is `pid`.
    pub fn by_pid(&self, pid: i32) -> Option<usize> {
        self.hosts.iter().position(|h| h.pid == pid)
    }

    /// The host's name.
    pub fn name(&self, host: usize) -> &str {
        &self.hosts[host].name
    }

    /// Sends `c` to host `host` (a host that is gone is skipped).
    pub fn order(&mut self, host: usize, c: &HostControl) {
        match *c {
            HostControl::Fault(ProcessFault::Kill { robot }) => {
                self.killed.insert(robot);
            }
            HostControl::Fault(ProcessFault::Restart { robot, .. }) => {
                self.killed.remove(&robot);
            }
            _ => {}
        }
        let h = &mut self.hosts[host];
        if let Some(s) = h.stdin.as_mut()
            && s.write_all(c.to_line().as_bytes())
                .and_then(|_| s.flush())
                .is_err()
        {
            h.stdin = None;
        }
    }

    /// Notes a report; returns robots to declare dead when the host failed.
    pub fn note(&mut self, host: usize, r: &HostReport) {
        let h = &mut self.hosts[host];
        match r {
            HostReport::Joined => h.joined = true,
            HostReport::Done { stats } => {
                h.done = true;
                h.stats = Some(stats.clone());
            }
            HostReport::Failed { why } => {
                h.lost.get_or_insert_with(|| why.clone());
            }
            HostReport::Started { .. } | HostReport::Exited { .. } => {}
        }
    }

    /// The host's launcher ended with `how`. Returns why the host is lost, unless it had
    /// finished (or was already lost).
    pub fn ended(&mut self, host: usize, how: &str) -> Option<String> {
        let h = &mut self.hosts[host];
        h.stdin = None;
        h.exited = true;
        if h.done || h.lost.is_some() {
            return None;
        }
        let why = format!("its swarm-host (or launcher) {how}");
        h.lost = Some(why.clone());
        Some(why)
    }

    /// The world stopped hearing host `name` (its link outlived Zenoh's lease) and marked its
    /// robots dead: the host is lost unless it had finished, whether or not its launcher has
    /// ended yet (before, `metrics.json` said so only when the launcher's exit came first).
    pub fn link_lost(&mut self, name: &str) {
        if let Some(h) = self.hosts.iter_mut().find(|h| h.name == name)
            && !h.done
        {
            h.lost
                .get_or_insert_with(|| "the world stopped hearing it (link lost)".to_string());
        }
    }

    /// Why the host is lost, if it is.
    pub fn lost(&self, host: usize) -> Option<&str> {
        self.hosts[host].lost.as_deref()
    }

    /// The first host that failed, as a run failure.
    pub fn failure(&self) -> Option<HostFailure> {
        self.hosts.iter().find_map(|h| {
            h.lost.as_ref().map(|why| HostFailure {
                host: h.name.clone(),
                why: why.clone(),
            })
        })
    }

    /// The robots of host `host` that were alive until now (not killed on an order).
    pub fn alive_robots(&self, host: usize) -> Vec<u32> {
        self.file.hosts[host]
            .robots
            .clone()
            .filter(|r| !self.killed.contains(r))
            .collect()
    }

    /// Every launcher's pid.
    pub fn pids(&self) -> Vec<i32> {
        self.hosts.iter().map(|h| h.pid).collect()
    }

    /// Pids of launchers not reaped yet (a host often ends before the world's last report).
    pub fn running(&self) -> Vec<i32> {
        self.hosts
            .iter()
            .filter(|h| !h.exited)
            .map(|h| h.pid)
            .collect()
    }

    /// Closes every host's stdin (a host still running takes that as "the orchestrator is
    /// gone" and cleans up) after a `Stop`.
    pub fn stop_all(&mut self) {
        for i in 0..self.hosts.len() {
            self.order(i, &HostControl::Stop);
        }
    }

    /// SIGKILLs every launcher (the fail-fast path; cleanup follows).
    pub fn kill(&mut self) {
        signal_all(&self.running(), libc::SIGKILL);
    }

    /// Every host's counters, by name (`metrics.json` -> `hosts`).
    pub fn stats(&self) -> serde_json::Value {
        let m: BTreeMap<&str, serde_json::Value> = self
            .hosts
            .iter()
            .map(|h| {
                let mut v = h.stats.clone().unwrap_or_else(|| serde_json::json!({}));
                v["robots"] = serde_json::json!(self.file.hosts[self.by_name(&h.name)].robots);
                if let Some(l) = &h.lost {
                    v["lost"] = serde_json::json!(l);
                }
                (h.name.as_str(), v)
            })
            .collect();
        serde_json::json!(m)
    }

    fn by_name(&self, name: &str) -> usize {
        self.file
            .hosts
            .iter()
            .position(|h| h.name == name)
            .expect("hosts come from the file")
    }

    /// Runs `swarm-host --clean` through every host's launcher, so a host whose `swarm-host`
    /// was killed leaves nothing behind either. Returns the hosts where it failed.
    pub fn clean(&self, run_id: &str) -> Vec<String> {
        let Ok(program) = crate::binaries::sibling_binary("swarm-host") else {
            return self.hosts.iter().map(|h| h.name.clone()).collect();
        };
        let mut failed = Vec::new();
        for (i, h) in self.hosts.iter().enumerate() {
            let mut cmd = host_command(&self.file, i, run_id, &program);
            cmd.arg("--clean")
                .stdin(Stdio::null())
                .stdout(Stdio::null());
            let ok = match cmd.spawn() {
                Ok(mut c) => {
                    // Waited for on a thread, so the timeout needs no polling.
                    let pid = c.id() as i32;
                    let (tx, rx) = crossbeam_channel::bounded(1);
                    std::thread::spawn(move || {
                        let _ = tx.send(c.wait().is_ok_and(|s| s.success()));
                    });
                    rx.recv_timeout(CLEAN_TIMEOUT).unwrap_or_else(|_| {
                        signal_all(&[pid], libc::SIGKILL);
                        false
                    })
                }
                Err(_) => false,
            };
            if !ok {
                tracing::warn!(host = %h.name, "could not clean the run's resources there");
                failed.push(h.name.clone());
            }
        }
        failed
    }

    /// True when every host joined.
    pub fn all_joined(&self) -> bool {
        self.hosts.iter().all(|h| h.joined)
    }
}
