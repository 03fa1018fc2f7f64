//! The robot processes of one host: started, signalled on the orchestrator's orders, and
//! reaped by one small thread each (as the orchestrator does on the world's host).

use std::collections::{BTreeMap, BTreeSet};
use std::path::PathBuf;
use std::process::Stdio;

use crossbeam_channel::Sender;
use swarmrt_scenario::process::{child_command, describe, signal_all};

/// A reaped robot process.
#[derive(Debug)]
pub struct Reaped {
    /// Its pid.
    pub pid: i32,
    /// How it ended.
    pub how: String,
}

/// How to start a robot of this host.
pub struct Launch {
    /// The `swarm-agent` executable.
    pub agent: PathBuf,
    /// The run id.
    pub run_id: String,
    /// The config the host wrote.
    pub config: PathBuf,
    /// Stable storage for the robots' Raft state.
    pub storage: PathBuf,
    /// The host's first robot id (its robots read slot `id - first`).
    pub first: u32,
    /// The run's config (which program each robot runs).
    pub cfg: swarmrt_scenario::Config,
    /// The run's iceoryx2 config on this host, for robot programs.
    pub ipc_config: PathBuf,
}

/// The robot processes of this host.
pub struct Robots {
    launch: Launch,
    /// pid -> (robot, incarnation) of every live process.
    live: BTreeMap<i32, (u32, u32)>,
    /// Processes killed on an order (kill, restart): their end is no death.
    ordered: BTreeSet<i32>,
    /// Processes stopped by a freeze.
    frozen: BTreeSet<i32>,
}

impl Robots {
    /// No processes yet.
    pub fn new(launch: Launch) -> Robots {
        Robots {
            launch,
            live: BTreeMap::new(),
            ordered: BTreeSet::new(),
            frozen: BTreeSet::new(),
        }
    }

    /// Starts robot `robot`; its end is sent to `reaped`. Returns its pid.
    pub fn spawn<M: From<Reaped> + Send + 'static>(
        &mut self,
        robot: u32,
        incarnation: u32,
        reaped: &Sender<M>,
    ) -> std::io::Result<i32> {
        let l = &self.launch;
        // A robot program (`robots.program`) runs as on the world's host: its own command
        // line, then swarm-agent's arguments, and the run's names in its environment.
        let mut cmd = match swarmrt_scenario::program::program_of(&l.cfg, robot) {
            None => child_command(&l.agent),
            Some((_, argv)) => {
                let mut c = child_command(std::path::Path::new(&argv[0]));
                c.args(&argv[1..]);
                c
            }
        };
        let run = swarmrt_protocol::services::RunServices::new(&l.run_id);
        cmd.envs(run.robot_env(
            robot,
            incarnation,
            &l.config,
            &l.storage,
            l.first,
            &l.ipc_config,
        ));
        let child = cmd
            .args(["--run-id", &l.run_id, "--robot", &robot.to_string()])
            .args(["--incarnation", &incarnation.to_string()])
            .args(["--slot-offset", &l.first.to_string(), "--config"])
            .arg(&l.config)
            .arg("--storage")
            .arg(&l.storage)
            .stdin(Stdio::null())
            // The host's stdout carries its reports.
            .stdout(Stdio::null())
            .spawn()?;
        let pid = child.id() as i32;
        let tx = reaped.clone();
        let watcher = std::thread::Builder::new()
            .name(format!("reap-{pid}"))
            .stack_size(64 * 1024)
            .spawn(move || {
                let how = loop {
                    let mut status = 0;
                    // SAFETY: waitpid on our own child, writing only `status`.
                    let r = unsafe { libc::waitpid(pid, &mut status, 0) };
                    if r == pid {
                        break describe(status);
                    }
                    if std::io::Error::last_os_error().raw_os_error() != Some(libc::EINTR) {
                        break format!(
                            "could not be waited for: {}",
                            std::io::Error::last_os_error()
                        );
                    }
                };
                let _ = tx.send(M::from(Reaped { pid, how }));
            });
        if let Err(e) = watcher {
            signal_all(&[pid], libc::SIGKILL);
            let mut status = 0;
            // SAFETY: as above; the child was just killed, so this returns promptly.
            unsafe { libc::waitpid(pid, &mut status, 0) };
            return Err(e);
        }
        self.live.insert(pid, (robot, incarnation));
        Ok(pid)
    }

    fn pid_of(&self, robot: u32) -> Option<i32> {
        self.live
            .iter()
            .find(|(pid, (r, _))| *r == robot && !self.ordered.contains(pid))
            .map(|(&pid, _)| pid)
    }

    /// SIGKILLs the live process of `robot` on an order; false if it has none.
    pub fn kill(&mut self, robot: u32) -> bool {
        let Some(pid) = self.pid_of(robot) else {
            return false;
        };
        self.ordered.insert(pid);
        self.frozen.remove(&pid);
        signal_all(&[pid], libc::SIGKILL);
        true
    }

    /// SIGSTOPs (`freeze`) or SIGCONTs the live process of `robot`.
    pub fn freeze(&mut self, robot: u32, freeze: bool) {
        if let Some(pid) = self.pid_of(robot) {
            if freeze {
                self.frozen.insert(pid);
                signal_all(&[pid], libc::SIGSTOP);
            } else {
                self.frozen.remove(&pid);
                signal_all(&[pid], libc::SIGCONT);
            }
        }
    }

    /// Forgets a reaped process: (robot, incarnation, killed on an order).
    pub fn reaped(&mut self, pid: i32) -> Option<(u32, u32, bool)> {
        let (robot, inc) = self.live.remove(&pid)?;
        self.frozen.remove(&pid);
        Some((robot, inc, self.ordered.remove(&pid)))
    }

    /// Pids still running.
    pub fn pids(&self) -> Vec<i32> {
        self.live.keys().copied().collect()
    }

    /// Continues every frozen process (a stopped process can see no shutdown).
    pub fn thaw_all(&mut self) {
        let f: Vec<i32> = std::mem::take(&mut self.frozen).into_iter().collect();
        signal_all(&f, libc::SIGCONT);
    }

    /// True when no process is left.
    pub fn is_empty(&self) -> bool {
        self.live.is_empty()
    }
}
