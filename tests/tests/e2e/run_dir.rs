//! The run directory is never overwritten (issue 18): `swarm run` refuses an `--out` that holds
//! anything unless `--force`, a run holds `DIR/.lock` for its whole life so a second run into
//! it fails at once (with `--force` too), default directories started in the same second
//! differ, and a full disk leaves whole ticks and a `metrics.json` saying the run failed.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

use swarmrt_tests::{
    assert_ok, children_of, last_tick, metrics, start_long_run, swarm, swarm_bin,
    wait_with_watchdog, workspace,
};

const LIMIT: Duration = Duration::from_secs(180);

/// `swarm run configs/goto_simple.toml --ticks 50 --out DIR extra...`.
fn short_run(dir: &Path, extra: &[&str]) -> Output {
    let mut args = vec![
        "run",
        "configs/goto_simple.toml",
        "--ticks",
        "50",
        "--out",
        dir.to_str().unwrap(),
    ];
    args.extend_from_slice(extra);
    swarm(&args, LIMIT)
}

/// Every file of a directory and its subdirectories (`config/iceoryx2.toml`) with its bytes,
/// by path relative to `dir`.
fn snapshot(dir: &Path) -> BTreeMap<String, Vec<u8>> {
    let mut files = BTreeMap::new();
    let mut todo = vec![dir.to_path_buf()];
    while let Some(d) = todo.pop() {
        for e in std::fs::read_dir(&d).unwrap().flatten() {
            if e.file_type().unwrap().is_dir() {
                todo.push(e.path());
            } else {
                let rel = e.path().strip_prefix(dir).unwrap().display().to_string();
                files.insert(rel, std::fs::read(e.path()).unwrap());
            }
        }
    }
    files
}

fn stderr(out: &Output) -> String {
    String::from_utf8_lossy(&out.stderr).into_owned()
}

/// Asserts a user error: exit 2 and one line that names `dir` and contains `says`.
fn assert_refused(out: &Output, dir: &Path, says: &str) {
    let err = stderr(out);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert_eq!(err.trim().lines().count(), 1, "one line: {err}");
    assert!(
        err.contains(dir.to_str().unwrap()),
        "names the directory: {err}"
    );
    assert!(err.contains(says), "says {says:?}: {err}");
}

#[test]
fn an_existing_out_is_refused_and_left_byte_identical() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("run");
    assert_ok(&short_run(&dir, &[]));
    let before = snapshot(&dir);
    assert!(before.contains_key("trajectory.csv") && before.contains_key("metrics.json"));

    // Another scenario into the same directory: refused, nothing touched.
    let out = swarm(
        &[
            "run",
            "configs/formation_simple.toml",
            "--ticks",
            "50",
            "--out",
            dir.to_str().unwrap(),
        ],
        LIMIT,
    );
    assert_refused(&out, &dir, "--force");
    assert!(out.stdout.is_empty(), "no run directory printed");
    assert_eq!(
        snapshot(&dir),
        before,
        "the earlier run's files are untouched"
    );

    // A directory that holds anything at all is refused too.
    let other = tmp.path().join("notes");
    std::fs::create_dir(&other).unwrap();
    std::fs::write(other.join("todo.txt"), "keep me").unwrap();
    assert_refused(&short_run(&other, &["--in-process"]), &other, "--force");
    assert_eq!(
        std::fs::read_to_string(other.join("todo.txt")).unwrap(),
        "keep me"
    );
    // --force clears only a run directory (a config.toml, no subdirectories).
    assert_refused(
        &short_run(&other, &["--in-process", "--force"]),
        &other,
        "only a run directory",
    );
    assert_eq!(
        std::fs::read_to_string(other.join("todo.txt")).unwrap(),
        "keep me"
    );

    // A file is no run directory.
    let file = tmp.path().join("file");
    std::fs::write(&file, "x").unwrap();
    assert_refused(
        &short_run(&file, &["--in-process", "--force"]),
        &file,
        "not a directory",
    );

    // An empty existing directory is fine.
    let empty = tmp.path().join("empty");
    std::fs::create_dir(&empty).unwrap();
    assert_ok(&short_run(&empty, &["--in-process"]));
}

#[test]
fn force_replaces_a_finished_runs_directory() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("run");
    assert_ok(&short_run(&dir, &["--seed", "3"]));
    let first = snapshot(&dir);
    // A table of the earlier run that the new one does not write must not survive: as a
    // behaviour's table is, it is named in the mark (`wrote <name>`).
    std::fs::write(dir.join("formation.csv"), "stale").unwrap();
    let mark = std::fs::read_to_string(dir.join(".swarmrt-run")).unwrap();
    std::fs::write(
        dir.join(".swarmrt-run"),
        format!("{mark}wrote formation.csv\n"),
    )
    .unwrap();

    let out = short_run(&dir, &["--seed", "4", "--force"]);
    assert_ok(&out);
    assert_eq!(
        String::from_utf8_lossy(&out.stdout).trim(),
        dir.to_str().unwrap()
    );
    let m = metrics(&dir);
    assert_eq!(m["seed"], 4);
    assert_eq!(m["failed"], false);
    assert!(
        !dir.join("formation.csv").exists(),
        "the earlier run's files were removed"
    );
    let second = snapshot(&dir);
    assert_eq!(
        first.keys().collect::<Vec<_>>(),
        second.keys().collect::<Vec<_>>(),
        "the same files, all written by the second run"
    );
    assert_ne!(first["config.toml"], second["config.toml"]);
    // Exactly what a run into a fresh directory writes.
    let fresh = tmp.path().join("fresh");
    assert_ok(&short_run(&fresh, &["--seed", "4"]));
    assert_eq!(
        std::fs::read(fresh.join("trajectory.csv")).unwrap(),
        second["trajectory.csv"]
    );
}

/// A Raft run's directory holds its robots' stable storage (`storage/`): `--force` clears it
/// too, so the new run's robots do not start from the old run's state.
#[test]
fn force_replaces_a_raft_runs_directory_with_its_storage() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("raft");
    let run = |extra: &[&str]| {
        let mut args = vec![
            "run",
            "configs/raft_election.toml",
            "--ticks",
            "60",
            "--out",
            dir.to_str().unwrap(),
        ];
        args.extend_from_slice(extra);
        swarm(&args, LIMIT)
    };
    assert_ok(&run(&[]));
    let state = dir.join("storage/raft-0.state");
    assert!(state.exists(), "robot 0 wrote its Raft state");
    std::fs::write(dir.join("storage/raft-99.state"), "stale").unwrap();
    assert_ok(&run(&["--force"]));
    assert!(state.exists());
    assert!(
        !dir.join("storage/raft-99.state").exists(),
        "storage cleared"
    );
}

#[test]
fn a_second_run_into_a_running_runs_directory_fails_at_once() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("run");
    let first = start_long_run(&dir, &[]);
    let children = children_of(first.id());
    let config = std::fs::read(dir.join("config.toml")).unwrap();

    for extra in [&[][..], &["--force"][..], &["--in-process", "--force"][..]] {
        let started = Instant::now();
        let out = short_run(&dir, extra);
        let took = started.elapsed();
        assert_refused(&out, &dir, "another run is using this directory");
        assert!(
            stderr(&out).contains(&format!("pid {}", first.id())),
            "names the holder: {}",
            stderr(&out)
        );
        assert!(
            took < Duration::from_secs(5),
            "refused at once, took {took:?} ({extra:?})"
        );
    }
    // The first run is untouched and still going.
    assert_eq!(std::fs::read(dir.join("config.toml")).unwrap(), config);
    let at = last_tick(&dir);
    swarmrt_tests::wait_until("the first run to go on", LIMIT, || {
        last_tick(&dir) > at + 20
    });

    // Ctrl-C (SIGINT to its pid): it stops in order and its records are whole.
    unsafe {
        libc::kill(first.id() as i32, libc::SIGINT);
    }
    let out = wait_with_watchdog(first, LIMIT);
    assert_ok(&out);
    let m = metrics(&dir);
    assert_eq!(m["interrupted"], true);
    assert_eq!(m["failed"], false);
    assert_eq!(m["seed"], 1);
    let csv = std::fs::read_to_string(dir.join("trajectory.csv")).unwrap();
    let ticks = m["ticks"].as_u64().unwrap() as usize;
    assert_eq!(
        csv.lines().count(),
        1 + 9 * (ticks + 1),
        "one row per robot per tick"
    );
    swarmrt_tests::assert_nothing_left(&children, m["run_id"].as_str().unwrap());

    // Once it has ended, the lock is free again and --force may replace it.
    assert_ok(&short_run(&dir, &["--in-process", "--force"]));
}

/// `swarm <args>` started from `cwd` with its output captured, not waited for.
fn spawn_piped(cwd: &Path, args: &[&str]) -> std::process::Child {
    Command::new(swarm_bin())
        .current_dir(cwd)
        .args(args)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap()
}

#[test]
fn two_runs_started_together_into_one_directory_cannot_both_pass() {
    let tmp = tempfile::tempdir().unwrap();
    for i in 0..4 {
        let dir = tmp.path().join(format!("run{i}"));
        let args = [
            "run",
            "configs/goto_simple.toml",
            "--in-process",
            "--ticks",
            "50",
            "--out",
            dir.to_str().unwrap(),
        ];
        let (a, b) = (
            spawn_piped(&workspace(), &args),
            spawn_piped(&workspace(), &args),
        );
        let outs = [wait_with_watchdog(a, LIMIT), wait_with_watchdog(b, LIMIT)];
        let codes: Vec<_> = outs.iter().map(|o| o.status.code()).collect();
        let won = outs.iter().filter(|o| o.status.success()).count();
        assert_eq!(
            won,
            1,
            "exactly one run writes {}: {codes:?}",
            dir.display()
        );
        let lost = outs.iter().find(|o| !o.status.success()).unwrap();
        assert_eq!(lost.status.code(), Some(2), "{}", stderr(lost));
        assert_eq!(metrics(&dir)["failed"], false);
    }
}

#[test]
fn default_directories_of_runs_started_in_the_same_second_differ() {
    // From a scratch working directory: default run directories are relative (runs/...).
    let tmp = tempfile::tempdir().unwrap();
    let config = workspace().join("configs/goto_simple.toml");
    let mut same_second = false;
    for _ in 0..10 {
        // Start both just after a second turns: on a loaded machine two spawns can straddle
        // the boundary (CI saw 5 tries fail), and the names only differ by the second.
        let into = std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .unwrap()
            .subsec_nanos();
        std::thread::sleep(std::time::Duration::from_nanos(
            1_000_000_000 - u64::from(into) + 20_000_000,
        ));
        let args = [
            "run",
            "--in-process",
            "--ticks",
            "5",
            config.to_str().unwrap(),
        ];
        let (a, b) = (
            spawn_piped(tmp.path(), &args),
            spawn_piped(tmp.path(), &args),
        );
        let outs = [wait_with_watchdog(a, LIMIT), wait_with_watchdog(b, LIMIT)];
        let dirs: Vec<PathBuf> = outs
            .iter()
            .map(|o| {
                assert_ok(o);
                PathBuf::from(String::from_utf8_lossy(&o.stdout).trim())
            })
            .collect();
        assert_ne!(dirs[0], dirs[1]);
        for d in &dirs {
            assert_eq!(
                metrics(&tmp.path().join(d))["failed"],
                false,
                "{}",
                d.display()
            );
        }
        // runs/goto_simple-s1-<time> and the same with -1: started in the same second.
        let mut names: Vec<String> = dirs.iter().map(|d| d.display().to_string()).collect();
        names.sort();
        if names[1] == format!("{}-1", names[0]) {
            same_second = true;
            break;
        }
    }
    assert!(
        same_second,
        "no two runs started in the same second in 10 tries"
    );
}

/// A tmpfs of `size` mounted on a fresh directory, unmounted on drop; `None` (with the reason
/// printed) where mounting is not permitted.
struct SmallDisk {
    _tmp: tempfile::TempDir,
    path: PathBuf,
}

impl SmallDisk {
    /// A tmpfs of `size`; panics with the reason where none can be mounted (it needs root,
    /// as CI runs the suite): this test must not pass without having filled a disk.
    fn mount(size: &str) -> SmallDisk {
        let tmp = tempfile::tempdir().unwrap();
        let path = tmp.path().join("disk");
        std::fs::create_dir(&path).unwrap();
        let out = Command::new("mount")
            .args(["-t", "tmpfs", "-o", &format!("size={size}"), "tmpfs"])
            .arg(&path)
            .output()
            .unwrap_or_else(|e| panic!("cannot run mount ({e}): this test needs util-linux"));
        assert!(
            out.status.success(),
            "cannot mount a small tmpfs (this test needs root, as CI runs the suite): {}",
            String::from_utf8_lossy(&out.stderr).trim()
        );
        SmallDisk { _tmp: tmp, path }
    }
}

impl Drop for SmallDisk {
    fn drop(&mut self) {
        let _ = Command::new("umount").arg("-l").arg(&self.path).status();
    }
}

/// The run filled the disk: exit 1, whole ticks only, `metrics.json` saying it failed.
fn assert_failed_cleanly(out: &Output, dir: &Path, robots: usize) {
    assert_eq!(out.status.code(), Some(1), "{}", stderr(out));
    let csv = std::fs::read_to_string(dir.join("trajectory.csv")).unwrap();
    assert!(csv.ends_with('\n'), "no torn line");
    let rows: Vec<&str> = csv.lines().skip(1).collect();
    assert_eq!(rows.len() % robots, 0, "whole ticks only");
    let last = last_tick(dir);
    assert!(last > 10, "the disk filled mid-run (last tick {last})");
    assert_eq!(rows.len(), robots * (last as usize + 1));
    for line in std::fs::read_to_string(dir.join("events.jsonl"))
        .unwrap()
        .lines()
    {
        let v: serde_json::Value = serde_json::from_str(line).expect("whole event lines");
        assert!(v["tick"].as_u64().is_none_or(|t| t <= last), "{line}");
    }
    let m = metrics(dir);
    assert_eq!(m["failed"], true, "{m}");
    assert_eq!(m["ticks"], last, "{m}");
    assert!(!dir.join("metrics.json.tmp").exists());
    assert!(
        !dir.join(".metrics-room").exists(),
        "the room set aside was used"
    );
    // A plot the full disk cut short is removed, not left torn.
    if let Ok(svg) = std::fs::read_to_string(dir.join("trajectory.svg")) {
        assert!(svg.trim_end().ends_with("</svg>"), "a whole plot or none");
    }
}

#[test]
fn a_full_disk_leaves_whole_ticks_and_a_failed_metrics_json() {
    let disk = SmallDisk::mount("256k");
    for (name, extra) in [
        ("processes", &[][..]),
        ("in-process", &["--in-process"][..]),
    ] {
        let dir = disk.path.join(name);
        let mut args = vec![
            "run",
            "configs/goto_simple.toml",
            "--ticks",
            "100000",
            "--set",
            "scenario.stop_when_done=false",
            "--out",
            dir.to_str().unwrap(),
        ];
        args.extend_from_slice(extra);
        let out = swarm(&args, LIMIT);
        assert_failed_cleanly(&out, &dir, 9);
        // Room for the next run.
        std::fs::remove_dir_all(&dir).unwrap();
    }
}

/// c0b8b90: `--out /proc/self` and `--out /dev` exited 1, as an internal failure; a path the
/// user gave that cannot hold a run is theirs to fix: one line, exit 2, nothing written.
#[test]
fn an_out_that_cannot_hold_a_run_is_a_user_error() {
    let tmp = tempfile::tempdir().unwrap();
    let file = tmp.path().join("a-file");
    std::fs::write(&file, "x").unwrap();
    let too_long = tmp.path().join("x".repeat(300));
    for out in [
        Path::new("/proc/self").to_path_buf(),
        Path::new("/dev").to_path_buf(),
        file.clone(),
        file.join("below"),
        too_long,
    ] {
        let o = short_run(&out, &[]);
        let err = stderr(&o);
        assert_eq!(o.status.code(), Some(2), "--out {}: {err}", out.display());
        assert_eq!(err.trim().lines().count(), 1, "one line: {err}");
        assert!(!err.contains("panicked"), "{err}");
    }
    assert_eq!(std::fs::read_to_string(&file).unwrap(), "x");
}
