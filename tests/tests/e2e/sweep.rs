//! `swarm sweep` end to end: rows, plots and summary; processes mode with two runs at once;
//! resume; Ctrl-C; bad input; rows equal to single runs.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::Duration;

use swarmrt_tests::*;

const LIMIT: Duration = Duration::from_secs(300);

/// Metrics that depend on the wall clock (or the mode), left out of equality checks.
const WALL_CLOCK: [&str; 4] = ["wall_seconds", "ticks_per_second", "startup_ms", "mode"];

/// `sweep configs/goto_simple.toml --out <out> --set scenario.ticks=60 <extra>`.
fn sweep_args(out: &Path, extra: &[&str]) -> Vec<String> {
    let mut args: Vec<String> = [
        "sweep",
        "configs/goto_simple.toml",
        "--out",
        out.to_str().unwrap(),
        "--set",
        "scenario.ticks=60",
    ]
    .iter()
    .map(|s| s.to_string())
    .collect();
    args.extend(extra.iter().map(|s| s.to_string()));
    args
}

fn run_sweep(args: &[String]) -> std::process::Output {
    let args: Vec<&str> = args.iter().map(String::as_str).collect();
    swarm(&args, LIMIT)
}

/// `sweep.csv` as header and rows; asserts every line is whole (newline-terminated, one field
/// per column). No field in these tests holds a comma.
fn read_csv(out: &Path) -> (Vec<String>, Vec<Vec<String>>) {
    let text = std::fs::read_to_string(out.join("sweep.csv")).expect("sweep.csv exists");
    assert!(
        text.ends_with('\n'),
        "sweep.csv ends in a cut line: {text:?}"
    );
    let mut lines = text.lines();
    let header: Vec<String> = lines
        .next()
        .unwrap()
        .split(',')
        .map(str::to_string)
        .collect();
    let rows: Vec<Vec<String>> = lines
        .map(|l| {
            let r: Vec<String> = l.split(',').map(str::to_string).collect();
            assert_eq!(r.len(), header.len(), "not a whole row: {l}");
            r
        })
        .collect();
    (header, rows)
}

fn col(header: &[String], name: &str) -> usize {
    header
        .iter()
        .position(|h| h == name)
        .unwrap_or_else(|| panic!("no column {name} in {header:?}"))
}

/// (varied values..., seed) of every row.
fn keys_of(header: &[String], rows: &[Vec<String>]) -> Vec<Vec<String>> {
    let seed = col(header, "seed");
    rows.iter().map(|r| r[..=seed].to_vec()).collect()
}

/// The row's deterministic metrics: every metric column but the wall-clock ones.
fn replayable(header: &[String], row: &[String]) -> BTreeMap<String, String> {
    let seed = col(header, "seed");
    header[seed + 1..header.len() - 1]
        .iter()
        .zip(&row[seed + 1..row.len() - 1])
        .filter(|(h, _)| !WALL_CLOCK.contains(&h.as_str()))
        .map(|(h, v)| (h.clone(), v.clone()))
        .collect()
}

/// A row's run directory.
fn run_dir(out: &Path, header: &[String], row: &[String]) -> PathBuf {
    out.join(&row[col(header, "run_dir")])
}

/// The run directories under `<out>/runs/`.
fn run_dirs(out: &Path) -> BTreeSet<String> {
    std::fs::read_dir(out.join("runs"))
        .map(|d| {
            d.flatten()
                .map(|e| format!("runs/{}", e.file_name().to_string_lossy()))
                .collect()
        })
        .unwrap_or_default()
}

/// Drops a marker file into every run directory: a run that runs again gets a fresh
/// directory, so its marker is gone.
fn mark_runs(out: &Path) {
    for d in run_dirs(out) {
        std::fs::write(out.join(d).join("marker"), "").unwrap();
    }
}

/// Run directories whose marker is gone (they ran again since [`mark_runs`]).
fn ran_again(out: &Path) -> BTreeSet<String> {
    run_dirs(out)
        .into_iter()
        .filter(|d| !out.join(d).join("marker").exists())
        .collect()
}

fn cross(a: &[&str], b: &[&str], seeds: &[u64]) -> BTreeSet<Vec<String>> {
    let mut set = BTreeSet::new();
    for x in a {
        for y in b {
            for s in seeds {
                set.insert(vec![x.to_string(), y.to_string(), s.to_string()]);
            }
        }
    }
    set
}

/// The trimmed contents of every `<text>` element of an SVG.
fn svg_texts(svg: &str) -> Vec<String> {
    svg.split("<text")
        .skip(1)
        .filter_map(|t| {
            let body = t.split_once('>')?.1;
            Some(body.split_once("</text>")?.0.trim().to_string())
        })
        .collect()
}

const PNG_SIGNATURE: [u8; 8] = [0x89, b'P', b'N', b'G', 0x0D, 0x0A, 0x1A, 0x0A];

/// Panics (with its stderr) if `child` has already exited.
fn assert_running(child: &mut std::process::Child) {
    if let Some(status) = child.try_wait().unwrap() {
        let mut err = String::new();
        if let Some(mut e) = child.stderr.take() {
            use std::io::Read;
            let _ = e.read_to_string(&mut err);
        }
        panic!("swarm ended early ({status}): {err}");
    }
}

#[test]
fn in_process_sweep_writes_a_row_per_run_plots_and_summary() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("sweep");
    let result = run_sweep(&sweep_args(
        &out,
        &[
            "--vary",
            "radio.loss=0,0.3",
            "--vary",
            "radio.delay_ticks=0,4",
            "--seeds",
            "2",
            "--in-process",
        ],
    ));
    assert_ok(&result);
    assert_eq!(
        String::from_utf8_lossy(&result.stdout).trim(),
        out.to_str().unwrap()
    );

    let (header, rows) = read_csv(&out);
    assert_eq!(header[..3], ["radio.loss", "radio.delay_ticks", "seed"]);
    assert_eq!(header.last().unwrap(), "run_dir");
    for m in [
        "failed",
        "mode",
        "reached_target",
        "collisions",
        "down",
        "radio.delivered",
        "radio.sent",
    ] {
        col(&header, m);
    }
    assert_eq!(rows.len(), 8);
    let keys: BTreeSet<Vec<String>> = keys_of(&header, &rows).into_iter().collect();
    assert_eq!(keys, cross(&["0", "0.3"], &["0", "4"], &[1, 2]));

    for row in &rows {
        let dir = run_dir(&out, &header, row);
        let m = metrics(&dir);
        assert_eq!(m["seed"].to_string(), row[2], "{}", dir.display());
        assert_eq!(m["mode"], "in-process");
        assert_eq!(m["failed"], false);
        assert_eq!(row[col(&header, "failed")], "false");
        assert_eq!(row[col(&header, "mode")], "in-process");
        // The row holds the run's own metrics.
        for key in ["reached_target", "collisions", "down", "ticks"] {
            assert_eq!(row[col(&header, key)], m[key].to_string(), "{key}");
        }
        assert_eq!(
            row[col(&header, "radio.delivered")],
            m["radio"]["delivered"].to_string()
        );
        // The run used the varied values.
        let cfg = String::from_utf8(bytes(&dir, "config.toml")).unwrap();
        let loss = if row[0] == "0" { "0.0" } else { "0.3" };
        assert!(cfg.contains(&format!("\nloss = {loss}\n")), "{cfg}");
        assert!(
            cfg.contains(&format!("\ndelay_ticks = {}\n", row[1])),
            "{cfg}"
        );
        assert!(cfg.contains("\nticks = 60\n"), "{cfg}");
        let dropped_loss = m["radio"]["dropped_loss"].as_u64().unwrap();
        assert_eq!(dropped_loss > 0, row[0] == "0.3", "{m}");
        // A whole run directory, as `swarm run` writes it.
        for f in ["trajectory.csv", "events.jsonl", "trajectory.png"] {
            assert!(dir.join(f).exists(), "{} lacks {f}", dir.display());
        }
    }
    assert_eq!(run_dirs(&out).len(), 8);

    for metric in ["reached_target", "down", "collisions", "radio.delivered"] {
        let svg = std::fs::read_to_string(out.join(format!("plots/{metric}.svg")))
            .unwrap_or_else(|e| panic!("plot of {metric}: {e}"));
        assert!(svg.starts_with("<svg"));
        let texts = svg_texts(&svg);
        for label in [metric, "radio.loss", "radio.delay_ticks", "0", "0.3", "4"] {
            assert!(
                texts.iter().any(|t| t == label),
                "{metric} plot lacks {label}: {texts:?}"
            );
        }
        let png = std::fs::read(out.join(format!("plots/{metric}.png"))).unwrap();
        assert_eq!(png[..8], PNG_SIGNATURE);
    }

    let md = std::fs::read_to_string(out.join("summary.md")).unwrap();
    let table: Vec<Vec<&str>> = md
        .lines()
        .filter(|l| l.starts_with('|'))
        .map(|l| l.trim_matches('|').split('|').map(str::trim).collect())
        .collect();
    assert_eq!(
        table[0][..4],
        ["radio.loss", "radio.delay_ticks", "runs", "reached_target"]
    );
    let body: BTreeSet<(String, String, String)> = table[2..]
        .iter()
        .map(|r| (r[0].to_string(), r[1].to_string(), r[2].to_string()))
        .collect();
    let expected: BTreeSet<(String, String, String)> =
        [("0", "0"), ("0", "4"), ("0.3", "0"), ("0.3", "4")]
            .iter()
            .map(|(a, b)| (a.to_string(), b.to_string(), "2".to_string()))
            .collect();
    assert_eq!(body, expected, "{md}");
    assert!(table[2..].iter().all(|r| r[3].contains(" ± ")), "{md}");
    // Every linked plot exists.
    let links: Vec<&str> = md
        .split("](")
        .skip(1)
        .filter_map(|s| s.split_once(')').map(|(l, _)| l))
        .collect();
    assert!(links.contains(&"plots/collisions.png"), "{links:?}");
    for l in links {
        assert!(out.join(l).exists(), "summary links a missing {l}");
    }
}

#[test]
fn processes_sweep_runs_two_at_a_time_and_leaves_nothing() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("sweep");
    let args = sweep_args(
        &out,
        &[
            "--vary",
            "radio.loss=0,0.5",
            "--seeds",
            "2",
            "--jobs",
            "2",
            "--set",
            "scenario.ticks=200",
            "--set",
            "scenario.stop_when_done=false",
        ],
    );
    let child = Command::new(swarm_bin())
        .current_dir(workspace())
        .args(&args)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    // Watch how many `swarm run` children are alive at once until the sweep ends.
    let pid = child.id();
    let mut most = 0;
    let mut robots_seen = 0;
    let start = std::time::Instant::now();
    while alive(pid as i32) {
        assert!(start.elapsed() < LIMIT, "the sweep did not finish");
        let runs: Vec<(i32, String)> = children_of(pid)
            .into_iter()
            .filter(|(_, c)| c.contains(" run "))
            .collect();
        most = most.max(runs.len());
        for (p, _) in &runs {
            robots_seen = robots_seen.max(
                children_of(*p as u32)
                    .iter()
                    .filter(|(_, c)| c.contains("swarm-agent"))
                    .count(),
            );
        }
        std::thread::sleep(Duration::from_millis(10));
    }
    let result = wait_with_watchdog(child, LIMIT);
    assert_ok(&result);
    assert_eq!(most, 2, "--jobs 2 runs two at a time, never more");
    assert!(
        robots_seen > 0,
        "runs in processes mode have robot processes"
    );

    let (header, rows) = read_csv(&out);
    assert_eq!(rows.len(), 4);
    let keys: BTreeSet<Vec<String>> = keys_of(&header, &rows).into_iter().collect();
    let expected: BTreeSet<Vec<String>> = [["0", "1"], ["0", "2"], ["0.5", "1"], ["0.5", "2"]]
        .iter()
        .map(|r| r.iter().map(|s| s.to_string()).collect())
        .collect();
    assert_eq!(keys, expected);
    let mut run_ids = BTreeSet::new();
    for row in &rows {
        assert_eq!(row[col(&header, "mode")], "processes");
        assert_eq!(row[col(&header, "ticks")], "200");
        let m = metrics(&run_dir(&out, &header, row));
        let id = m["run_id"].as_str().unwrap().to_string();
        assert!(leftovers(&id).is_empty(), "{:?}", leftovers(&id));
        assert!(processes_mentioning(&id).is_empty());
        run_ids.insert(id);
    }
    assert_eq!(run_ids.len(), 4, "every run has its own run id");
}

#[test]
fn resume_runs_only_missing_and_failed_rows() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("sweep");
    let args = sweep_args(
        &out,
        &["--vary", "radio.loss=0,0.3", "--seeds", "3", "--in-process"],
    );
    assert_ok(&run_sweep(&args));
    let first_text = std::fs::read_to_string(out.join("sweep.csv")).unwrap();
    let (header, first_rows) = read_csv(&out);
    assert_eq!(first_rows.len(), 6);
    assert_eq!(run_dirs(&out).len(), 6);
    mark_runs(&out);

    // Everything is done: nothing runs again, the rows stay as they were.
    assert_ok(&run_sweep(&args));
    assert_eq!(
        std::fs::read_to_string(out.join("sweep.csv")).unwrap(),
        first_text
    );
    assert_eq!(ran_again(&out), BTreeSet::new(), "a finished run ran again");
    assert_eq!(run_dirs(&out).len(), 6);

    // Two rows deleted, one marked failed: exactly those three run again.
    let failed = col(&header, "failed");
    let mut lines: Vec<String> = first_text.lines().map(str::to_string).collect();
    let removed = [lines.remove(2), lines.remove(4)];
    let mut marked: Vec<String> = lines[1].split(',').map(str::to_string).collect();
    marked[failed] = "true".into();
    lines[1] = marked.join(",");
    let marked_dir = marked.last().unwrap().clone();
    std::fs::write(out.join("sweep.csv"), lines.join("\n") + "\n").unwrap();

    assert_ok(&run_sweep(&args));
    let (header2, rows) = read_csv(&out);
    assert_eq!(header2, header);
    assert_eq!(rows.len(), 6);
    let again: BTreeSet<String> = removed
        .iter()
        .map(|l| l.rsplit(',').next().unwrap().to_string())
        .chain([marked_dir])
        .collect();
    assert_eq!(again.len(), 3);
    assert_eq!(ran_again(&out), again);
    assert_eq!(run_dirs(&out).len(), 6);
    // Same keys, and the runs done again gave the same metrics.
    let by_key = |rows: &[Vec<String>]| -> BTreeMap<Vec<String>, BTreeMap<String, String>> {
        rows.iter()
            .map(|r| (r[..2].to_vec(), replayable(&header, r)))
            .collect()
    };
    assert_eq!(by_key(&rows), by_key(&first_rows));
    assert!(rows.iter().all(|r| r[failed] == "false"));

    // Another set of varied keys cannot resume into this sweep.
    let other = run_sweep(&sweep_args(
        &out,
        &["--vary", "radio.delay_ticks=0,2", "--in-process"],
    ));
    assert_eq!(other.status.code(), Some(2));
    let err = String::from_utf8_lossy(&other.stderr);
    assert_eq!(err.trim().lines().count(), 1, "{err}");
    assert!(
        err.contains("radio.loss") && err.contains("radio.delay_ticks"),
        "{err}"
    );
    // Nor can another config.
    let mut changed = args.clone();
    changed.extend(["--set".to_string(), "radio.range=3".to_string()]);
    mark_runs(&out);
    let other = run_sweep(&changed);
    assert_eq!(other.status.code(), Some(2));
    let err = String::from_utf8_lossy(&other.stderr);
    assert!(err.contains("range"), "{err}");
    assert_eq!(run_dirs(&out).len(), 6);
    assert_eq!(
        ran_again(&out),
        BTreeSet::new(),
        "a refused sweep touched the runs"
    );
}

#[test]
fn interrupted_sweep_keeps_whole_rows_stops_runs_and_resumes() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("sweep");
    // Seed-major order: (50, s1), (900, s1), (50, s2), (900, s2). The first row comes fast;
    // the next run is long enough to be interrupted mid-way.
    let args: Vec<String> = [
        "sweep",
        "configs/goto_simple.toml",
        "--out",
        out.to_str().unwrap(),
        "--vary",
        "scenario.ticks=50,900",
        "--seeds",
        "2",
    ]
    .iter()
    .map(|s| s.to_string())
    .collect();
    let mut child = Command::new(swarm_bin())
        .current_dir(workspace())
        .args(&args)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let pid = child.id();
    wait_until("the first row", LIMIT, || {
        assert_running(&mut child);
        std::fs::read_to_string(out.join("sweep.csv")).is_ok_and(|t| t.lines().count() >= 2)
    });
    // Wait until a run with its robots is under way, then Ctrl-C the sweep.
    let mut run_child = Vec::new();
    let mut swarm_procs = Vec::new();
    wait_until("a running processes-mode run", LIMIT, || {
        assert_running(&mut child);
        run_child = children_of(pid);
        swarm_procs = run_child
            .iter()
            .flat_map(|(p, _)| children_of(*p as u32))
            .collect();
        swarm_procs.len() >= 5
    });
    let run_id = run_id_of(&swarm_procs);
    unsafe {
        libc::kill(pid as i32, libc::SIGINT);
    }
    let result = wait_with_watchdog(child, LIMIT);
    assert_eq!(result.status.code(), Some(130), "{result:?}");
    let err = String::from_utf8_lossy(&result.stderr);
    let resume = err
        .lines()
        .find(|l| l.contains("resume with:"))
        .unwrap_or_else(|| panic!("no resume line: {err}"));
    assert!(resume.contains(out.to_str().unwrap()), "{resume}");

    // Every line whole; only finished runs are rows; the interrupted run's directory is gone.
    let (header, rows) = read_csv(&out);
    assert_eq!(rows.len(), 1, "only (50, seed 1) finished: {rows:?}");
    let mut row_dirs = BTreeSet::new();
    for row in &rows {
        let m = metrics(&run_dir(&out, &header, row));
        assert_eq!(m["interrupted"], false);
        assert_eq!(m["ticks"].to_string(), row[col(&header, "ticks")]);
        assert!(row[col(&header, "ticks")].parse::<u64>().is_ok());
        row_dirs.insert(row[col(&header, "run_dir")].clone());
    }
    assert_eq!(run_dirs(&out), row_dirs);
    // The interrupted run stopped in order: no process, no shared memory left.
    let all: Vec<(i32, String)> = run_child.into_iter().chain(swarm_procs).collect();
    assert_nothing_left(&all, &run_id);
    // Plots and summary of what finished.
    assert!(out.join("summary.md").exists());

    let result = run_sweep(&args);
    assert_ok(&result);
    let (_, rows) = read_csv(&out);
    let keys: Vec<Vec<String>> = keys_of(&header, &rows);
    let unique: BTreeSet<Vec<String>> = keys.iter().cloned().collect();
    assert_eq!(keys.len(), 4, "{keys:?}");
    let expected: BTreeSet<Vec<String>> = [["50", "1"], ["50", "2"], ["900", "1"], ["900", "2"]]
        .iter()
        .map(|r| r.iter().map(|s| s.to_string()).collect())
        .collect();
    assert_eq!(unique, expected);
}

#[test]
fn bad_vary_is_a_one_line_user_error_naming_the_key() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("sweep");
    for (vary, key) in [
        ("radio.los=0,0.1", "radio.los"),
        ("radio.loss=0,1.5", "radio.loss"),
        ("radio.loss", "radio.loss"),
        ("radio.delay_ticks=1,x", "radio.delay_ticks"),
        ("radio.loss=0,,1", "radio.loss"),
    ] {
        let result = run_sweep(&sweep_args(&out, &["--vary", vary, "--in-process"]));
        assert_eq!(result.status.code(), Some(2), "{vary}: {result:?}");
        let err = String::from_utf8_lossy(&result.stderr);
        assert_eq!(err.trim().lines().count(), 1, "{vary}: {err}");
        assert!(err.starts_with("error: "), "{vary}: {err}");
        assert!(err.contains(&format!("`{key}`")), "{vary}: {err}");
        assert!(
            !out.exists(),
            "{vary}: nothing may be written before every config validates"
        );
    }
    let result = run_sweep(&sweep_args(
        &out,
        &["--vary", "radio.loss=0", "--metric", "colisions"],
    ));
    assert_eq!(result.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&result.stderr).contains("`colisions`"));
    assert!(!out.exists());
}

#[test]
fn out_must_be_new_empty_or_a_sweep_directory() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("not-a-sweep");
    std::fs::create_dir_all(out.join("plots")).unwrap();
    std::fs::write(out.join("plots/precious.png"), "mine").unwrap();
    let result = run_sweep(&sweep_args(
        &out,
        &["--vary", "radio.loss=0", "--in-process"],
    ));
    assert_eq!(result.status.code(), Some(2), "{result:?}");
    let err = String::from_utf8_lossy(&result.stderr);
    assert!(err.contains("not a sweep directory"), "{err}");
    assert_eq!(
        std::fs::read(out.join("plots/precious.png")).unwrap(),
        b"mine"
    );
    assert!(!out.join("runs").exists());
}

#[test]
fn sweep_rows_match_single_runs() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("sweep");
    assert_ok(&run_sweep(&sweep_args(
        &out,
        &[
            "--vary",
            "radio.loss=0,0.3",
            "--seeds",
            "2",
            "--start-seed",
            "5",
            "--in-process",
        ],
    )));
    let (header, rows) = read_csv(&out);
    assert_eq!(rows.len(), 4);
    for row in rows.iter().filter(|r| r[0] == "0.3") {
        let single = tmp.path().join(format!("single-{}", row[1]));
        let result = swarm(
            &[
                "run",
                "configs/goto_simple.toml",
                "--seed",
                &row[1],
                "--set",
                "radio.loss=0.3",
                "--set",
                "scenario.ticks=60",
                "--out",
                single.to_str().unwrap(),
            ],
            LIMIT,
        );
        assert_ok(&result);
        let swept = run_dir(&out, &header, row);
        // A single processes-mode run writes the same records as the in-process sweep's run.
        for f in ["trajectory.csv", "events.jsonl"] {
            assert!(
                bytes(&swept, f) == bytes(&single, f),
                "{f} differs for seed {}",
                row[1]
            );
        }
        let m = metrics(&single);
        for key in [
            "reached_target",
            "collisions",
            "down",
            "ticks",
            "lidar_on_ticks",
        ] {
            assert_eq!(row[col(&header, key)], m[key].to_string(), "{key}");
        }
        for key in ["sent", "delivered", "dropped", "dropped_loss"] {
            assert_eq!(
                row[col(&header, &format!("radio.{key}"))],
                m["radio"][key].to_string(),
                "radio.{key}"
            );
        }
    }
    let seeds: BTreeSet<&str> = rows.iter().map(|r| r[1].as_str()).collect();
    assert_eq!(seeds, BTreeSet::from(["5", "6"]));
}

#[test]
fn a_crashed_run_is_a_failed_row_the_sweep_fails_and_resume_runs_it_again() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("sweep");
    let args: Vec<String> = [
        "sweep",
        "configs/goto_simple.toml",
        "--out",
        out.to_str().unwrap(),
        "--vary",
        "scenario.ticks=50,900",
    ]
    .iter()
    .map(|s| s.to_string())
    .collect();
    let mut child = Command::new(swarm_bin())
        .current_dir(workspace())
        .args(&args)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let pid = child.id();
    wait_until("the first row", LIMIT, || {
        assert_running(&mut child);
        std::fs::read_to_string(out.join("sweep.csv")).is_ok_and(|t| t.lines().count() >= 2)
    });
    // SIGKILL the world of the second (long) run.
    let mut world = None;
    wait_until("the second run's world", LIMIT, || {
        assert_running(&mut child);
        world = children_of(pid)
            .iter()
            .flat_map(|(p, _)| children_of(*p as u32))
            .find(|(_, c)| c.contains("swarm-world"))
            .map(|(p, _)| p);
        world.is_some()
    });
    unsafe {
        libc::kill(world.unwrap(), libc::SIGKILL);
    }
    let result = wait_with_watchdog(child, LIMIT);
    assert_eq!(result.status.code(), Some(1), "{result:?}");
    let err = String::from_utf8_lossy(&result.stderr);
    assert!(err.contains("1 of 2 runs failed"), "{err}");

    let (header, rows) = read_csv(&out);
    assert_eq!(rows.len(), 2);
    let failed = col(&header, "failed");
    let by_ticks: BTreeMap<&str, &Vec<String>> = rows.iter().map(|r| (r[0].as_str(), r)).collect();
    assert_eq!(by_ticks["50"][failed], "false");
    assert_eq!(by_ticks["900"][failed], "true");
    let m = metrics(&run_dir(&out, &header, by_ticks["900"]));
    assert_eq!(m["failed"], true, "{m}");
    // The summary counts it and leaves it out of the means.
    let md = std::fs::read_to_string(out.join("summary.md")).unwrap();
    assert!(md.contains("(1 finished, 1 failed)"), "{md}");

    // The same command runs the failed run again, and only that one.
    mark_runs(&out);
    assert_ok(&run_sweep(&args));
    let (_, rows) = read_csv(&out);
    assert_eq!(rows.len(), 2);
    assert!(rows.iter().all(|r| r[failed] == "false"), "{rows:?}");
    assert_eq!(
        ran_again(&out),
        BTreeSet::from(["runs/scenario.ticks=900_s1".to_string()])
    );
}
