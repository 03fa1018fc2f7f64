//! The run directory (DESIGN section 7): naming, `config.toml`, `metrics.json` and the plots
//! drawn from `trajectory.csv`.

use std::path::{Path, PathBuf};

use anyhow::Context;
use swarmrt_scenario::Config;

use swarmrt_analysis::plot::trajectory::write_trajectory_plots;

/// `runs/<scenario>-s<seed>-<time>/`, with a numeric suffix if that exists already.
pub fn default_dir(cfg: &Config) -> PathBuf {
    unused_dir(&format!(
        "runs/{}-s{}-{}",
        cfg.scenario.name,
        cfg.scenario.seed,
        timestamp()
    ))
}

/// The current UTC time as `YYYYMMDD-hhmmss`, for directory names.
pub fn timestamp() -> String {
    let secs = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map(|d| d.as_secs())
        .unwrap_or(0);
    let (h, m, s) = ((secs / 3600) % 24, (secs / 60) % 60, secs % 60);
    let days = secs / 86_400;
    let (y, mo, d) = civil_from_days(days as i64);
    format!("{y:04}{mo:02}{d:02}-{h:02}{m:02}{s:02}")
}

/// `base`, or `base-1`, `base-2`, ... if that exists already.
pub fn unused_dir(base: &str) -> PathBuf {
    let mut dir = PathBuf::from(base);
    let mut k = 1;
    while dir.exists() {
        dir = PathBuf::from(format!("{base}-{k}"));
        k += 1;
    }
    dir
}

/// Days since 1970-01-01 to (year, month, day), proleptic Gregorian (H. Hinnant's algorithm).
pub fn civil_from_days(z: i64) -> (i64, u32, u32) {
    let z = z + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z.rem_euclid(146_097);
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = (doy - (153 * mp + 2) / 5 + 1) as u32;
    let m = if mp < 10 { mp + 3 } else { mp - 9 } as u32;
    (yoe + era * 400 + (m <= 2) as i64, m, d)
}

/// Creates the directory and writes the resolved config (seed included).
pub fn prepare(dir: &Path, cfg: &Config) -> anyhow::Result<PathBuf> {
    std::fs::create_dir_all(dir).with_context(|| format!("cannot create {}", dir.display()))?;
    let config_path = dir.join("config.toml");
    std::fs::write(&config_path, cfg.to_toml())
        .with_context(|| format!("cannot write {}", config_path.display()))?;
    Ok(config_path)
}

/// Writes `metrics.json` atomically (temp file + rename): never a truncated file.
pub fn write_metrics(dir: &Path, metrics: &serde_json::Value) -> anyhow::Result<()> {
    let tmp = dir.join("metrics.json.tmp");
    std::fs::write(&tmp, serde_json::to_string_pretty(metrics)? + "\n")?;
    std::fs::rename(&tmp, dir.join("metrics.json"))?;
    Ok(())
}

/// Draws `trajectory.svg` and `trajectory.png` from the recorded trajectory.
pub fn write_plots(dir: &Path, cfg: &Config) -> anyhow::Result<()> {
    let tracks = swarmrt_analysis::run_dir::read_tracks(dir)?;
    write_trajectory_plots(
        cfg,
        &tracks,
        &dir.join("trajectory.svg"),
        &dir.join("trajectory.png"),
    )
}

/// After the world process died, cuts `trajectory.csv` back to its last complete tick (all
/// `robots` rows) and `events.jsonl` to whole lines of ticks up to it. The world writes each
/// tick with one `write_all`, but the kernel may cut a large write short when a fatal signal
/// arrives, so the records are made whole here rather than trusted. Returns the last tick.
pub fn trim_torn_records(dir: &Path, robots: usize) -> anyhow::Result<Option<u64>> {
    let path = dir.join("trajectory.csv");
    let text = std::fs::read(&path).with_context(|| format!("{}", path.display()))?;
    let mut keep = text.iter().rposition(|&b| b == b'\n').map_or(0, |i| i + 1);
    let whole = String::from_utf8_lossy(&text[..keep]).into_owned();
    let tick_of = |l: &str| l.split(',').next().and_then(|t| t.parse::<u64>().ok());
    let rows: Vec<&str> = whole.lines().skip(1).collect();
    let mut last = rows.last().and_then(|l| tick_of(l));
    if let Some(t) = last {
        let in_last = rows
            .iter()
            .rev()
            .take_while(|l| tick_of(l) == Some(t))
            .count();
        if in_last < robots {
            // Drop the torn tick's rows.
            let cut: usize = rows.iter().rev().take(in_last).map(|l| l.len() + 1).sum();
            keep -= cut;
            last = rows.iter().rev().nth(in_last).and_then(|l| tick_of(l));
        }
    }
    truncate(&path, keep as u64)?;

    let path = dir.join("events.jsonl");
    let text = std::fs::read_to_string(&path).unwrap_or_default();
    let mut kept = 0;
    for line in text.split_inclusive('\n') {
        let Ok(v) = serde_json::from_str::<serde_json::Value>(line) else {
            break;
        };
        if !line.ends_with('\n') || v["tick"].as_u64().zip(last).is_some_and(|(t, l)| t > l) {
            break;
        }
        kept += line.len();
    }
    if kept < text.len() {
        truncate(&path, kept as u64)?;
    }
    Ok(last)
}

fn truncate(path: &Path, len: u64) -> anyhow::Result<()> {
    std::fs::OpenOptions::new()
        .write(true)
        .open(path)
        .and_then(|f| f.set_len(len))
        .with_context(|| format!("cannot trim {}", path.display()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn civil_dates() {
        assert_eq!(civil_from_days(0), (1970, 1, 1));
        assert_eq!(civil_from_days(20_779), (2026, 11, 22));
    }

    #[test]
    fn torn_records_are_cut_back_to_the_last_whole_tick() {
        let dir = tempfile::tempdir().unwrap();
        let header = "tick,id,x,y,theta,v,omega,lidar,state\n";
        let rows = "0,0,1,1,0,0,0,1,active\n0,1,2,2,0,0,0,1,active\n\
                    1,0,1,1,0,0,0,1,active\n1,1,2,2,0,0,0,1,active\n\
                    2,0,1,1,0,0,0,1,active\n2,1,2,";
        std::fs::write(dir.path().join("trajectory.csv"), format!("{header}{rows}")).unwrap();
        std::fs::write(
            dir.path().join("events.jsonl"),
            "{\"event\":\"reached\",\"tick\":1,\"robot\":0}\n\
             {\"event\":\"reached\",\"tick\":2,\"robot\":1}\n{\"event\":\"rea",
        )
        .unwrap();
        assert_eq!(trim_torn_records(dir.path(), 2).unwrap(), Some(1));
        let csv = std::fs::read_to_string(dir.path().join("trajectory.csv")).unwrap();
        assert!(csv.ends_with("1,1,2,2,0,0,0,1,active\n"), "{csv}");
        assert_eq!(csv.lines().count(), 5);
        let ev = std::fs::read_to_string(dir.path().join("events.jsonl")).unwrap();
        assert_eq!(ev, "{\"event\":\"reached\",\"tick\":1,\"robot\":0}\n");
        // Whole records are left alone.
        assert_eq!(trim_torn_records(dir.path(), 2).unwrap(), Some(1));
        assert_eq!(
            std::fs::read_to_string(dir.path().join("trajectory.csv")).unwrap(),
            csv
        );
    }
}
