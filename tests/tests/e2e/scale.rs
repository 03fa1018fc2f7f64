//! Every config in `configs/` at half and at double its `robots.count` (issue 33): it either
//! runs and gets somewhere, or is refused before tick 0 with one line naming the file, the
//! key and what to change. Never a silent run in which nobody can move.

use std::path::Path;
use std::time::Duration;

use swarmrt_tests::{metrics, swarm, workspace};

/// Ticks each run gets (the planner's runs end earlier, when every UAV has arrived).
const TICKS: &str = "150";

/// The largest distance any robot ended from where it started.
fn farthest_move(dir: &Path) -> f64 {
    let text = std::fs::read_to_string(dir.join("trajectory.csv")).unwrap();
    let mut lines = text.lines();
    let head: Vec<&str> = lines.next().unwrap().split(',').collect();
    let (ix, iy) = (
        head.iter().position(|&c| c == "x").unwrap(),
        head.iter().position(|&c| c == "y").unwrap(),
    );
    let mut first = std::collections::BTreeMap::new();
    let mut last = std::collections::BTreeMap::new();
    for l in lines {
        let f: Vec<&str> = l.split(',').collect();
        let p: (f64, f64) = (f[ix].parse().unwrap(), f[iy].parse().unwrap());
        first.entry(f[1].to_string()).or_insert(p);
        last.insert(f[1].to_string(), p);
    }
    first
        .iter()
        .map(|(id, a)| {
            let b = last[id];
            (a.0 - b.0).hypot(a.1 - b.1)
        })
        .fold(0.0, f64::max)
}

#[test]
fn every_config_at_half_and_double_its_count_runs_or_says_why_not() {
    let tmp = tempfile::tempdir().unwrap();
    let mut configs: Vec<_> = std::fs::read_dir(workspace().join("configs"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "toml"))
        .collect();
    configs.sort();
    assert!(configs.len() >= 20, "{configs:?}");
    let (mut ran, mut refused) = (Vec::new(), Vec::new());
    for path in &configs {
        let name = path.file_stem().unwrap().to_str().unwrap();
        let rel = format!("configs/{name}.toml");
        let text = std::fs::read_to_string(path).unwrap();
        let count = toml::from_str::<toml::Table>(&text).unwrap()["robots"]["count"]
            .as_integer()
            .unwrap();
        let planner = text.contains("kind = \"planner\"");
        for c in [(count + 1) / 2, count * 2] {
            let case = format!("{name} with robots.count = {c}");
            let dir = tmp.path().join(format!("{name}-{c}"));
            let mut args = vec!["run", &rel, "--in-process", "--out", dir.to_str().unwrap()];
            let set = format!("robots.count={c}");
            args.extend(["--set", &set]);
            if !planner {
                args.extend(["--ticks", TICKS]);
            }
            let out = swarm(&args, Duration::from_secs(600));
            let err = String::from_utf8_lossy(&out.stderr).to_string();
            if out.status.code() == Some(2) {
                // Refused: one line, naming the file and the key.
                let lines: Vec<&str> = err.lines().filter(|l| !l.trim().is_empty()).collect();
                assert_eq!(lines.len(), 1, "{case}: one line:\n{err}");
                assert!(
                    lines[0].starts_with(&format!("error: {rel}: key `")),
                    "{case}: names the file and the key: {err}"
                );
                assert!(
                    !dir.join("metrics.json").exists(),
                    "{case}: refused before tick 0"
                );
                refused.push(case);
                continue;
            }
            assert!(out.status.success(), "{case}: {err}");
            let m = metrics(&dir);
            if planner {
                // Every UAV that lives gets its own goal and arrives.
                let alive = c - m["dead"].as_i64().unwrap();
                assert_eq!(m["planner"]["reached"].as_i64(), Some(alive), "{case}: {m}");
            } else if name == "quadrant_leader" {
                // Nobody moves by design: the swarm agrees on one leader.
                let q = &m["consensus"]["quadrant"];
                assert_eq!(q["all_agree"], true, "{case}: {m}");
                assert_eq!(
                    q["self_declared_leaders"].as_array().unwrap().len(),
                    1,
                    "{case}"
                );
            } else {
                let moved = farthest_move(&dir);
                assert!(moved > 0.1, "{case}: no robot got anywhere ({moved} m)");
            }
            ran.push(case);
        }
    }
    eprintln!("ran: {ran:#?}\nrefused: {refused:#?}");
    assert!(
        ran.iter()
            .any(|c| c.starts_with("planner_uav3 with robots.count = 6")),
        "three UAVs doubled fly: {ran:?}"
    );
}
