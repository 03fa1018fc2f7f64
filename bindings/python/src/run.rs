//! `swarm run` from Python: the orchestrator's own command on a worker thread, the GIL
//! released, Ctrl-C passed on as the CLI's interrupt.

use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Duration;

use clap::Parser;
use pyo3::prelude::*;
use swarmrt_orchestrator::cli::{Cli, Cmd};
use swarmrt_orchestrator::error::SwarmError;

use crate::{ConfigError, SwarmrtError};

/// Runs `swarm <argv...>` (a `run` command) and returns its run directory. `progress`, if
/// given, is called with the ticks done about ten times a second.
#[pyfunction]
#[pyo3(signature = (argv, progress=None))]
pub fn run(py: Python<'_>, argv: Vec<String>, progress: Option<Py<PyAny>>) -> PyResult<String> {
    let cli = Cli::try_parse_from(std::iter::once("swarm".to_string()).chain(argv))
        .map_err(|e| ConfigError::new_err(e.to_string().trim().to_string()))?;
    let Cmd::Run(mut args) = cli.command else {
        return Err(ConfigError::new_err("only `run` is a native command"));
    };
    let done = Arc::new(AtomicU64::new(0));
    args.ticks_done = Some(done.clone());
    let (stop, interrupt) = crossbeam_channel::unbounded::<()>();
    let (tx, finished) = crossbeam_channel::bounded(1);
    let worker = std::thread::spawn(move || {
        let r =
            std::panic::catch_unwind(|| swarmrt_orchestrator::commands::run::run(&args, interrupt));
        let _ = tx.send(());
        r
    });
    let mut interrupted = None;
    loop {
        let over = py.detach(|| finished.recv_timeout(Duration::from_millis(100)).is_ok());
        if let Some(p) = &progress {
            p.call1(py, (done.load(Ordering::Relaxed),))?;
        }
        if over {
            break;
        }
        if interrupted.is_none()
            && let Err(e) = py.check_signals()
        {
            // Ctrl-C (or another signal's exception): the run stops as the CLI's does,
            // writes what it has, and the exception is raised once it is over.
            let _ = stop.send(());
            interrupted = Some(e);
        }
    }
    let result = py.detach(|| worker.join());
    if let Some(e) = interrupted {
        return Err(e);
    }
    match result {
        Ok(Ok(Ok(dir))) => Ok(dir.display().to_string()),
        Ok(Ok(Err(e))) => Err(to_py(e)),
        Ok(Err(panic)) | Err(panic) => Err(SwarmrtError::new_err(format!(
            "internal error: {}",
            panic_message(&panic)
        ))),
    }
}

/// Loads `config` with `set` as `swarm check` does: its scenario's name, seed, ticks and
/// robot count on success, [`ConfigError`] with the one line otherwise.
#[pyfunction]
#[pyo3(signature = (config, set=Vec::new()))]
pub fn check_config(config: &str, set: Vec<String>) -> PyResult<(String, u64, u64, u32)> {
    let cfg = load(config, &set)?;
    let s = &cfg.scenario;
    Ok((s.name.clone(), s.seed, s.ticks, cfg.robots.count))
}

/// The config as a run loads it (schema, bounds, `[behaviour]`, map, programs).
pub fn load(config: &str, set: &[String]) -> PyResult<swarmrt_scenario::Config> {
    swarmrt_orchestrator::config::load_config(std::path::Path::new(config), set).map_err(to_py)
}

/// A command's failure as the Python exception of its kind.
pub fn to_py(e: SwarmError) -> PyErr {
    match e {
        SwarmError::User(line) => ConfigError::new_err(line),
        SwarmError::Internal(e) => SwarmrtError::new_err(format!("{e:#}")),
        SwarmError::Interrupted(line) => pyo3::exceptions::PyKeyboardInterrupt::new_err(line),
    }
}

/// What a caught panic said.
pub fn panic_message(panic: &Box<dyn std::any::Any + Send>) -> String {
    panic
        .downcast_ref::<&str>()
        .map(|s| s.to_string())
        .or_else(|| panic.downcast_ref::<String>().cloned())
        .unwrap_or_else(|| "a panic".to_string())
}
