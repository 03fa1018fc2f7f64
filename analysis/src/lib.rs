//! Reading what runs wrote: nothing here runs a swarm.
//!
//! - [`run_dir`]: a run directory's `trajectory.csv` and `events.jsonl` as typed records (the
//!   schema is `swarmrt_protocol::records`).
//! - [`metrics`]: the metrics registry: what every run gets from its records, plus each
//!   behaviour's own (found through `swarmrt_agent::registry`).
//! - [`series`]: a behaviour's per-tick tables (`<name>.csv`) and their plots.
//! - [`sweep_csv`]: `sweep.csv`, one row per finished run of a sweep.
//! - [`stats`]: a sweep's rows grouped by combination, with their statistics.
//! - [`export`]: a run in other formats (`swarm export --mcap`: MCAP for Foxglove).
//! - [`plot`]: every figure: a run's trajectories, a sweep's metrics, a tune's progress, the
//!   benchmarks'.
#![warn(missing_docs)]

pub mod export;
pub mod metrics;
pub mod plot;
pub mod run_dir;
pub mod series;
pub mod stats;
pub mod sweep_csv;
