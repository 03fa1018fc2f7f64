//! Benchmark child processes: spawn (this binary, `child --spec`), read their one-line
//! JSON messages, reap them. Dropping a [`Children`] kills and reaps whatever is left, so no
//! error path leaves a process behind.

use std::io::{BufRead, BufReader};
use std::process::{Child, Stdio};
use std::time::Duration;

use anyhow::{Context, bail};
use crossbeam_channel::{Receiver, select};

use super::Interrupt;
use super::child::{ChildMsg, ChildSpec};

/// A child's messages: one per stdout line; the channel closes at its EOF.
pub struct Messages {
    name: String,
    rx: Receiver<ChildMsg>,
    stdin: Option<std::process::ChildStdin>,
}

impl Messages {
    /// The next message, within `timeout`; an error on EOF (the child failed), timeout or
    /// Ctrl-C.
    pub fn next(&self, timeout: Duration, interrupt: &Interrupt) -> anyhow::Result<ChildMsg> {
        let stop = interrupt.receiver();
        select! {
            recv(self.rx) -> m => m.map_err(|_| anyhow::anyhow!(
                "{} ended without reporting (see its error above)", self.name)),
            recv(stop) -> _ => bail!("interrupted"),
            default(timeout) => bail!("{} reported nothing within {timeout:?}", self.name),
        }
    }

    /// Tells a child that waits on its stdin to go on.
    pub fn go(&mut self) -> anyhow::Result<()> {
        use std::io::Write;
        let stdin = self.stdin.as_mut().context("child has no stdin")?;
        stdin.write_all(b"go\n")?;
        stdin.flush()?;
        Ok(())
    }

    /// Waits for `Ready`; returns its address, if any.
    pub fn ready(
        &self,
        timeout: Duration,
        interrupt: &Interrupt,
    ) -> anyhow::Result<Option<String>> {
        match self.next(timeout, interrupt)? {
            ChildMsg::Ready { addr } => Ok(addr),
            other => bail!("{}: expected ready, got {other:?}", self.name),
        }
    }

    /// Waits for `Result`; returns its value.
    pub fn result(
        &self,
        timeout: Duration,
        interrupt: &Interrupt,
    ) -> anyhow::Result<serde_json::Value> {
        match self.next(timeout, interrupt)? {
            ChildMsg::Result { value } => Ok(value),
            other => bail!("{}: expected a result, got {other:?}", self.name),
        }
    }
}

/// The child processes of one measurement.
#[derive(Default)]
pub struct Children {
    kids: Vec<(String, Child)>,
}

/// True while `pid` is a live child of this process (not reaped, pid not recycled).
fn is_my_child(pid: u32) -> bool {
    std::fs::read_to_string(format!("/proc/{pid}/stat"))
        .ok()
        .and_then(|s| {
            let rest = s.rsplit_once(')')?.1.to_string();
            let ppid = rest.split_whitespace().nth(1)?.parse::<u32>().ok()?;
            Some(ppid == std::process::id())
        })
        .unwrap_or(false)
}

impl Children {
    /// No children yet.
    pub fn new() -> Children {
        Children::default()
    }

    /// How many were started.
    pub fn len(&self) -> usize {
        self.kids.len()
    }

    /// True when none were started.
    pub fn is_empty(&self) -> bool {
        self.kids.is_empty()
    }

    /// Pids of the children started so far.
    pub fn pids(&self) -> Vec<u32> {
        self.kids.iter().map(|(_, c)| c.id()).collect()
    }

    /// Starts `swarm-bench child --spec <spec>`; with `report`, its stdout is read as
    /// messages, otherwise discarded.
    pub fn spawn(
        &mut self,
        name: &str,
        spec: &ChildSpec,
        report: bool,
    ) -> anyhow::Result<Option<Messages>> {
        let exe = std::env::current_exe().context("cannot locate the swarm-bench executable")?;
        let json = serde_json::to_string(spec)?;
        let mut cmd = swarmrt_orchestrator::processes::child_command(&exe);
        cmd.args(["child", "--spec", &json])
            .stdin(if report {
                Stdio::piped()
            } else {
                Stdio::null()
            })
            .stdout(if report {
                Stdio::piped()
            } else {
                Stdio::null()
            });
        let mut child = cmd
            .spawn()
            .with_context(|| format!("cannot start bench child {name}"))?;
        let messages = if report {
            let out = child.stdout.take().context("child stdout")?;
            let (tx, rx) = crossbeam_channel::unbounded();
            let who = name.to_string();
            std::thread::spawn(move || {
                for line in BufReader::new(out).lines() {
                    let Ok(line) = line else { break };
                    match serde_json::from_str::<ChildMsg>(&line) {
                        Ok(m) => {
                            if tx.send(m).is_err() {
                                return;
                            }
                        }
                        Err(_) => tracing::warn!("{who} said: {line}"),
                    }
                }
            });
            Some(Messages {
                name: name.to_string(),
                rx,
                stdin: child.stdin.take(),
            })
        } else {
            None
        };
        self.kids.push((name.to_string(), child));
        Ok(messages)
    }

    /// Waits until every child has exited, at most `timeout`; then kills the rest. An error
    /// names children that had to be killed or exited with a failure.
    pub fn finish(&mut self, timeout: Duration) -> anyhow::Result<()> {
        let kids = std::mem::take(&mut self.kids);
        let pids: Vec<u32> = kids.iter().map(|(_, c)| c.id()).collect();
        let (tx, rx) = crossbeam_channel::bounded(1);
        // One thread waits for the children in turn (blocking waitpid, no polling); the
        // caller waits for that thread with a deadline.
        let waiter = std::thread::spawn(move || {
            let mut failed = Vec::new();
            for (name, mut c) in kids {
                match c.wait() {
                    Ok(st) if st.success() => {}
                    Ok(st) => failed.push(format!("{name} {st}")),
                    // ECHILD: reaped by someone else (a finished run's reaper); gone anyway.
                    Err(_) => {}
                }
            }
            let _ = tx.send(failed);
        });
        let failed = match rx.recv_timeout(timeout) {
            Ok(f) => f,
            Err(_) => {
                let mut killed = 0;
                for &p in &pids {
                    if is_my_child(p) {
                        // SAFETY: kill only sends a signal to a live child of ours.
                        unsafe {
                            libc::kill(p as i32, libc::SIGKILL);
                        }
                        killed += 1;
                    }
                }
                let mut f = rx.recv().unwrap_or_default();
                f.push(format!("{killed} children killed after {timeout:?}"));
                f
            }
        };
        let _ = waiter.join();
        if failed.is_empty() {
            Ok(())
        } else {
            bail!("bench children failed: {}", failed.join(", "))
        }
    }
}

impl Drop for Children {
    fn drop(&mut self) {
        for (_, c) in &self.kids {
            if is_my_child(c.id()) {
                // SAFETY: kill only sends a signal to a live child of ours.
                unsafe {
                    libc::kill(c.id() as i32, libc::SIGKILL);
                }
            }
        }
        for (_, c) in &mut self.kids {
            let _ = c.wait();
        }
    }
}

/// Memory of a set of processes from `/proc/<pid>/smaps_rollup`.
#[derive(Debug, Clone, Copy, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Memory {
    /// Processes read.
    pub processes: usize,
    /// Sum of resident set sizes, KiB (shared pages counted once per process).
    pub rss_kib: u64,
    /// Sum of proportional set sizes, KiB (shared pages split between their users).
    pub pss_kib: u64,
}

/// Reads `Rss` and `Pss` of each pid; processes already gone are skipped.
pub fn memory(pids: &[u32]) -> Memory {
    let mut m = Memory::default();
    for pid in pids {
        let Ok(text) = std::fs::read_to_string(format!("/proc/{pid}/smaps_rollup")) else {
            continue;
        };
        let field = |name: &str| -> u64 {
            text.lines()
                .find(|l| l.starts_with(name))
                .and_then(|l| l.split_whitespace().nth(1))
                .and_then(|v| v.parse().ok())
                .unwrap_or(0)
        };
        m.processes += 1;
        m.rss_kib += field("Rss:");
        m.pss_kib += field("Pss:");
    }
    m
}

/// Open file descriptors of `pid` (0 if it is gone).
pub fn open_fds(pid: u32) -> usize {
    std::fs::read_dir(format!("/proc/{pid}/fd"))
        .map(|d| d.count())
        .unwrap_or(0)
}

/// Live children of this process (pid, command line), from
/// `/proc/self/task/<tid>/children` (exact and fast: no scan of every process).
pub fn my_children() -> Vec<(u32, String)> {
    let mut out = Vec::new();
    let Ok(tasks) = std::fs::read_dir("/proc/self/task") else {
        return out;
    };
    for t in tasks.flatten() {
        let Ok(list) = std::fs::read_to_string(t.path().join("children")) else {
            continue;
        };
        for pid in list
            .split_whitespace()
            .filter_map(|p| p.parse::<u32>().ok())
        {
            let zombie = std::fs::read_to_string(format!("/proc/{pid}/stat"))
                .ok()
                .and_then(|s| {
                    s.rsplit_once(')')
                        .map(|(_, r)| r.split_whitespace().next() == Some("Z"))
                })
                .unwrap_or(true);
            if !zombie {
                let cmd = std::fs::read(format!("/proc/{pid}/cmdline")).unwrap_or_default();
                out.push((pid, String::from_utf8_lossy(&cmd).replace('\0', " ")));
            }
        }
    }
    out
}
