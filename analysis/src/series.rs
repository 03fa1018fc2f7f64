//! A behaviour's per-tick tables (`swarmrt_agent::behaviour::Series`): computed from a run's
//! records, written as `<name>.csv` in the run directory and drawn as their line plots.

use std::fmt::Write as _;
use std::path::Path;

use anyhow::Context;
use swarmrt_agent::behaviour::Series;
use swarmrt_scenario::Config;
use swarmrt_scenario::safe_fs::OutDir;

use crate::plot::series::write_series_plot;

/// The behaviour's tables for the run in `dir` (none for a behaviour that has no tables).
pub fn from_records(cfg: &Config, dir: &Path) -> anyhow::Result<Vec<Series>> {
    let Some(p) = swarmrt_agent::registry::plugin(&cfg.behaviour.kind) else {
        return Ok(Vec::new());
    };
    let rec = crate::run_dir::read(dir)?;
    let configured = p
        .configure(cfg)
        .map_err(|(key, message)| anyhow::anyhow!("key `{key}`: {message}"))?;
    Ok(configured.series(&rec))
}

/// `s` as CSV: the header, then one line per row.
pub fn to_csv(s: &Series) -> String {
    let mut out = s.columns.join(",");
    out.push('\n');
    for row in &s.rows {
        for (i, v) in row.iter().enumerate() {
            if i > 0 {
                out.push(',');
            }
            let _ = write!(out, "{v}");
        }
        out.push('\n');
    }
    out
}

/// Writes every table of the run in `dir` through its handle (atomically: temp file, then
/// rename; a symbolic link planted at either name is refused, never followed) and its plots;
/// returns the names of the files written.
pub fn write_all(cfg: &Config, dir: &OutDir) -> anyhow::Result<Vec<String>> {
    let mut written = Vec::new();
    for s in from_records(cfg, dir.path())? {
        let name = format!("{}.csv", s.name);
        // Through `<name>.csv.tmp`, as before.
        dir.write_replace(&name, to_csv(&s))
            .with_context(|| format!("writing {}", dir.join(&name).display()))?;
        written.push(name);
        for plot in &s.plots {
            write_series_plot(&s, plot, dir)?;
            written.extend([format!("{}.svg", plot.file), format!("{}.png", plot.file)]);
        }
    }
    Ok(written)
}
