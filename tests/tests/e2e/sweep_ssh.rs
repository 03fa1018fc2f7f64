//! `swarm sweep --executor ssh` over three emulated hosts of the namespace lab (their launcher
//! stands in for ssh; each host has its own network and /dev/shm, the filesystem is shared):
//! the runs spread over the hosts, a host killed mid-sweep has its run re-queued on the others
//! and is reported, and the rows equal a local sweep's.

use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;
use std::time::Duration;

use swarmrt_tests::lab::Lab;
use swarmrt_tests::*;

const LIMIT: Duration = Duration::from_secs(600);

/// `sweep.csv` as (varied values and seed) -> (column -> value), wall-clock columns left out.
fn rows(out: &Path) -> BTreeMap<String, BTreeMap<String, String>> {
    let text = std::fs::read_to_string(out.join("sweep.csv")).expect("sweep.csv");
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let seed = header.iter().position(|h| *h == "seed").unwrap();
    let wall = |c: &str| {
        ["wall_seconds", "ticks_per_second", "startup_ms"].contains(&c)
            || c.starts_with("shell.timing.")
    };
    lines
        .map(|l| {
            let f: Vec<&str> = l.split(',').collect();
            assert_eq!(f.len(), header.len(), "a whole row: {l}");
            let cols = header
                .iter()
                .zip(&f)
                .filter(|(h, _)| !wall(h))
                .map(|(h, v)| (h.to_string(), v.to_string()))
                .collect();
            (f[..=seed].join(","), cols)
        })
        .collect()
}

#[test]
fn runs_spread_over_three_hosts_and_a_killed_hosts_run_is_made_elsewhere() {
    let mut lab = Lab::new(3).unwrap_or_else(|e| panic!("cannot build the emulated hosts: {e}"));
    let tmp = tempfile::tempdir().unwrap();
    let hosts = tmp.path().join("hosts.toml");
    let mut text = String::new();
    for i in 0..3 {
        let launcher: Vec<String> = lab.launcher(i).iter().map(|a| format!("{a:?}")).collect();
        text.push_str(&format!(
            "[[host]]\nname = \"h{i}\"\nlauncher = [{}]\n",
            launcher.join(", ")
        ));
    }
    std::fs::write(&hosts, text).unwrap();
    let sweep = |out: &Path, extra: &[&str]| {
        let mut args = vec![
            "sweep",
            "configs/goto_simple.toml",
            "--out",
            out.to_str().unwrap(),
            "--set",
            "scenario.ticks=300",
            "--vary",
            "radio.loss=0,0.2,0.4",
            "--seeds",
            "3",
        ];
        args.extend(extra);
        args.iter().map(|a| a.to_string()).collect::<Vec<_>>()
    };

    // Processes mode on the hosts: each run's world and robots live in that host's /dev/shm.
    let out = tmp.path().join("ssh");
    let args = sweep(
        &out,
        &["--executor", "ssh", "--hosts", hosts.to_str().unwrap()],
    );
    let args: Vec<&str> = args.iter().map(String::as_str).collect();
    let child = spawn_swarm(&args, &[]);
    let mut seen: BTreeSet<usize> = BTreeSet::new();
    wait_until("a run on each host", LIMIT, || {
        for i in 0..3 {
            if !lab.processes(i).is_empty() {
                seen.insert(i);
            }
        }
        seen.len() == 3
    });
    // Host 2 goes down mid-run: its run's processes and the host itself.
    wait_until("a run on host 2", LIMIT, || !lab.processes(2).is_empty());
    lab.kill_host(2);
    let result = wait_with_watchdog(child, LIMIT);
    let err = String::from_utf8_lossy(&result.stderr).into_owned();
    assert_ok(&result);
    assert!(
        err.contains("warning: host h2 lost (`nsenter") && err.contains("goes to another host"),
        "{err}"
    );
    assert!(err.contains("1 host(s) lost during the sweep"), "{err}");

    let local = tmp.path().join("local");
    let largs = sweep(&local, &["--jobs", "2", "--in-process"]);
    let largs: Vec<&str> = largs.iter().map(String::as_str).collect();
    assert_ok(&swarm(&largs, LIMIT));
    let (a, b) = (rows(&local), rows(&out));
    assert_eq!(a.len(), 9);
    assert_eq!(b.len(), 9, "every run is a row once: {b:?}");
    for (key, row) in &a {
        let mut theirs = b[key].clone();
        let mut ours = row.clone();
        // The mode differs by design (in-process here, processes on the hosts).
        theirs.remove("mode");
        ours.remove("mode");
        for k in theirs
            .keys()
            .filter(|k| !ours.contains_key(*k))
            .cloned()
            .collect::<Vec<_>>()
        {
            assert!(k.starts_with("shell.") || k == "startup_ms", "{k}");
            theirs.remove(&k);
        }
        assert_eq!(ours, theirs, "{key}");
        assert_eq!(b[key]["failed"], "false", "{key}");
        let dir = &row["run_dir"];
        assert_same_records(&local.join(dir), &out.join(dir), key);
    }
    // A small tune over the two hosts left (the lost one is refused at once: its runs come
    // back to the others) reaches the local tune's best.toml and tune.csv.
    let tune = |out: &Path, extra: &[&str]| {
        let mut args = vec![
            "tune",
            "configs/goto_simple.toml",
            "--out",
            out.to_str().unwrap(),
            "--set",
            "scenario.ticks=60",
            "--in-process",
            "--param",
            "behaviour.speed=0.3:1.0",
            "--fitness",
            "radio.sent",
            "--particles",
            "2",
            "--evaluations",
            "4",
            "--iterations",
            "2",
            "--seed",
            "5",
        ];
        args.extend(extra);
        swarm(&args, LIMIT)
    };
    let (tl, ts) = (tmp.path().join("tune-local"), tmp.path().join("tune-ssh"));
    assert_ok(&tune(&tl, &[]));
    let over_hosts = tune(
        &ts,
        &["--executor", "ssh", "--hosts", hosts.to_str().unwrap()],
    );
    assert_ok(&over_hosts);
    for f in ["best.toml", "tune.csv"] {
        assert_eq!(
            std::fs::read_to_string(tl.join(f)).unwrap(),
            std::fs::read_to_string(ts.join(f)).unwrap(),
            "{f}"
        );
    }
    let err = String::from_utf8_lossy(&over_hosts.stderr);
    assert!(err.contains("warning: host h2 lost"), "{err}");

    // Nothing of the sweep is left on the surviving hosts.
    for i in 0..2 {
        assert!(
            lab.processes(i).is_empty(),
            "host {i}: {:?}",
            lab.processes(i)
        );
        // The per-user base directory may stay; no run's files or segments may.
        let shm: Vec<String> = lab
            .shm(i)
            .into_iter()
            .filter(|e| !e.starts_with("swarmrt-"))
            .collect();
        assert!(shm.is_empty(), "host {i}: {shm:?}");
        let l = lab.launcher(i);
        let base = std::process::Command::new(&l[0])
            .args(&l[1..])
            .args(["sh", "-c", "ls -A /dev/shm/swarmrt-* 2>/dev/null"])
            .output()
            .unwrap();
        let base = String::from_utf8_lossy(&base.stdout).trim().to_string();
        assert!(base.is_empty() || base.ends_with(':'), "host {i}: {base}");
    }
}
