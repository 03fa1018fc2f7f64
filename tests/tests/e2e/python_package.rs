//! The Python package as a user installs it (issue 50): the wheel built by maturin with this
//! suite's binaries, installed into a fresh venv (`swarmrt_tests::python`), and the package's
//! own tests (`tests/python/`) run by pytest from a directory outside the source tree, so
//! `import swarmrt` can only find the installed wheel.
//!
//! - `test_run.py`: `swarmrt.run` writes `swarm run --in-process`'s bytes, its DataFrames
//!   are the files, process runs use the wheel's binaries, a typo is a `ConfigError` with the
//!   CLI's line, a sweep over `radio.loss` is a table, a plot is not blank.
//! - `test_env.py`: PettingZoo's `parallel_api_test` and `parallel_seed_test` on two configs
//!   (one lossy), Gymnasium's `check_env`, the vector env against single worlds, autoreset,
//!   bad actions, reward callables, a robot killed by a fault leaving the agents.
//! - `test_policy.py`: a policy deployed as robot processes writes its rollout's records.
//! - `test_notebook.py`: `examples/notebooks/quickstart.ipynb` executed headless (nbclient).

use std::process::{Command, Stdio};
use std::time::Duration;

use swarmrt_tests::{python, wait_with_watchdog, workspace};

const LIMIT: Duration = Duration::from_secs(600);

/// Runs pytest on `tests/python/<file>` with the venv's Python, from a fresh directory.
fn pytest(file: &str) {
    let python = python::python();
    let cwd = tempfile::tempdir().unwrap();
    let child = Command::new(python)
        .current_dir(cwd.path())
        .args([
            "-m",
            "pytest",
            "-q",
            "-p",
            "no:cacheprovider",
            "-W",
            "ignore::UserWarning",
        ])
        .arg(workspace().join("tests").join("python").join(file))
        .env("SWARMRT_WORKSPACE", workspace())
        .env("PYTHONDONTWRITEBYTECODE", "1")
        .env_remove("PYTHONPATH")
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let out = wait_with_watchdog(child, LIMIT);
    assert!(
        out.status.success(),
        "pytest {file} ({}):\n{}{}",
        out.status,
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
}

#[test]
fn the_notebook_api_runs_reads_and_plots_as_the_cli_does() {
    pytest("test_run.py");
}

#[test]
fn the_environments_pass_pettingzoos_and_gymnasiums_checkers() {
    pytest("test_env.py");
}

#[test]
fn a_policy_deployed_as_robot_processes_writes_its_rollouts_records() {
    pytest("test_policy.py");
}

#[test]
fn the_quickstart_notebook_runs_headless() {
    pytest("test_notebook.py");
}
