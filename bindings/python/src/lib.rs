//! `swarmrt._native`: the thin layer between Python and the cores. It converts at the
//! boundary and keeps the logic in Rust: `run` is `swarm run` itself (the orchestrator's
//! command, so the records and metrics are the CLI's bytes), `VecEnv` steps worlds of
//! [`swarmrt_harness::env`] on threads, and `features`/`command` give a robot process the same
//! view and the same command bytes as the environment. Long work runs with the GIL released;
//! a failure is a Python exception with the CLI's one line, and a panic is caught on the
//! worker's side of the boundary.

mod env;
mod run;

use pyo3::prelude::*;

pyo3::create_exception!(
    _native,
    ConfigError,
    pyo3::exceptions::PyValueError,
    "A config or its --set overrides are invalid: the message is the CLI's one line (file, key, expected)."
);
pyo3::create_exception!(
    _native,
    SwarmrtError,
    pyo3::exceptions::PyRuntimeError,
    "A run failed for a reason that is not the config's (a full disk, a crashed core)."
);

#[pymodule]
fn _native(m: &Bound<'_, PyModule>) -> PyResult<()> {
    let py = m.py();
    m.add("ConfigError", py.get_type::<ConfigError>())?;
    m.add("SwarmrtError", py.get_type::<SwarmrtError>())?;
    m.add_function(wrap_pyfunction!(run::run, m)?)?;
    m.add_function(wrap_pyfunction!(run::check_config, m)?)?;
    m.add_function(wrap_pyfunction!(env::features, m)?)?;
    m.add_function(wrap_pyfunction!(env::command, m)?)?;
    m.add_class::<env::VecEnv>()?;
    m.add(
        "OBSERVATION_SIZE",
        std::mem::size_of::<swarmrt_protocol::Observation>(),
    )?;
    m.add(
        "COMMAND_SIZE",
        std::mem::size_of::<swarmrt_protocol::Command>(),
    )?;
    Ok(())
}
