//! The `swarm-world` process of a run: its command line, its start (with its reaper, as any
//! watched process of the supervisor), its stdout of reports and its stdin of controls.

use std::io::Write;
use std::path::Path;
use std::process::{ChildStdin, ChildStdout, Stdio};

use anyhow::Context;
use crossbeam_channel::Sender;
use swarmrt_protocol::control::{Control, WorldReport};
use swarmrt_protocol::services::RunServices;
use swarmrt_runtime::supervisor::Pid;
use swarmrt_runtime::supervisor::launch;
use swarmrt_scenario::safe_fs::OutDir;

use super::{Msg, RunOptions, child_command, exited};

/// The run's world as the orchestrator sees it.
pub(super) struct World {
    /// Its process.
    pub pid: Pid,
    /// Its controls; `None` once it cannot be written to.
    stdin: Option<ChildStdin>,
    /// Its stdout has ended.
    pub eof: bool,
    /// How its process ended, once reaped.
    pub exit: Option<String>,
}

impl World {
    /// Sends `c` (a world that cannot be written to any more is skipped).
    pub fn send(&mut self, c: &Control) {
        if let Some(s) = self.stdin.as_mut()
            && s.write_all(c.to_line().as_bytes())
                .and_then(|_| s.flush())
                .is_err()
        {
            self.stdin = None;
        }
    }

    /// Closes its controls.
    pub fn close(&mut self) {
        drop(self.stdin.take());
    }

    /// How it failed, once both its exit and the end of its stdout arrived without its end
    /// reported (they race on the channel, so one alone proves nothing).
    pub fn failure(&self) -> Option<String> {
        let how = self.exit.as_ref().filter(|_| self.eof)?;
        Some(format!("world process {how} before finishing"))
    }
}

/// The `swarm-world` command of this run.
fn world_command(
    world_bin: &Path,
    run: &RunServices,
    config_path: &Path,
    dir: &OutDir,
    opts: &RunOptions,
) -> std::process::Command {
    let mut world_cmd = child_command(world_bin);
    world_cmd
        .args(["--run-id", run.run_id(), "--config"])
        .arg(config_path)
        .arg("--out")
        .arg(dir.path())
        // The world refuses any directory but the one checked here.
        .arg("--out-id")
        .arg(dir.id().to_string());
    if let Some(h) = opts.hosts {
        world_cmd.arg("--hosts").arg(&h.path);
        world_cmd.arg("--certs").arg(&h.file.certs);
    }
    if opts.insecure_link {
        world_cmd.arg("--insecure-link");
    }
    if opts.realtime {
        world_cmd.arg("--realtime");
    }
    world_cmd
}

/// Starts `swarm-world` with its reaper and its stdout reader, both reporting on `tx`.
pub(super) fn start_world(
    world_bin: &Path,
    run: &RunServices,
    config_path: &Path,
    dir: &OutDir,
    opts: &RunOptions,
    tx: &Sender<Msg>,
) -> anyhow::Result<World> {
    let mut cmd = world_command(world_bin, run, config_path, dir, opts);
    cmd.stdin(Stdio::piped()).stdout(Stdio::piped());
    let mut world = launch::start(&mut cmd, exited(tx))
        .with_context(|| format!("cannot start {}", world_bin.display()))?;
    let stdin = world.stdin.take();
    let stdout = world.stdout.take().context("world stdout")?;
    read_world_reports(stdout, tx);
    Ok(World {
        pid: world.id() as Pid,
        stdin,
        eof: false,
        exit: None,
    })
}

/// The world's stdout reader: each report line as a message on `tx`, then its EOF.
fn read_world_reports(world_stdout: ChildStdout, tx: &Sender<Msg>) {
    let (tx, eof) = (tx.clone(), tx.clone());
    swarmrt_ipc::lines::read_json_lines(
        world_stdout,
        "the world".into(),
        move |r: WorldReport| tx.send(Msg::Report(r)).is_ok(),
        move || {
            let _ = eof.send(Msg::WorldEof);
        },
    );
}
