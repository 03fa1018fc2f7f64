//! `swarm sweep` and `swarm tune` with `--executor slurm` against a real Slurm started by the
//! test ([`SlurmLab`]): the same rows, records and best.toml as on this machine; a task
//! cancelled from outside is a failed row; Ctrl-C cancels the arrays and keeps finished rows;
//! `--detach` then `--collect`; no `sbatch`, a refused submission and a bad executor file are
//! one line each.

use std::collections::BTreeMap;
use std::path::Path;
use std::sync::Mutex;
use std::time::Duration;

use swarmrt_tests::slurm::SlurmLab;
use swarmrt_tests::*;

const LIMIT: Duration = Duration::from_secs(600);

/// One cluster at a time: two would share this machine's two cores and the node's name.
static CLUSTER: Mutex<()> = Mutex::new(());

fn lab() -> (std::sync::MutexGuard<'static, ()>, SlurmLab) {
    let guard = CLUSTER.lock().unwrap_or_else(|e| e.into_inner());
    let lab = SlurmLab::start().expect("a one-node Slurm cluster starts");
    (guard, lab)
}

/// Runs `swarm args` from the workspace with the cluster's environment.
fn swarm_on(lab: &SlurmLab, args: &[&str]) -> std::process::Output {
    wait_with_watchdog(spawn_swarm(args, &lab.env()), LIMIT)
}

/// Waits until no process (a run, its world or robots) works in `out` any more: a task Slurm
/// cancelled leaves nothing behind.
fn assert_nothing_runs_in(out: &Path) {
    let needle = out.display().to_string();
    wait_until(
        "the cancelled run's processes to end",
        Duration::from_secs(60),
        || processes_mentioning(&needle).is_empty(),
    );
}

fn stderr(out: &std::process::Output) -> String {
    String::from_utf8_lossy(&out.stderr).into_owned()
}

/// Columns that depend on the wall clock, left out of equality checks.
fn wall_clock(column: &str) -> bool {
    ["wall_seconds", "ticks_per_second", "startup_ms"].contains(&column)
        || column.starts_with("shell.timing.")
}

/// `sweep.csv` as (varied values and seed) -> (column -> value), wall-clock columns left out.
fn rows(out: &Path) -> BTreeMap<String, BTreeMap<String, String>> {
    let text = std::fs::read_to_string(out.join("sweep.csv")).expect("sweep.csv");
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let seed = header.iter().position(|h| *h == "seed").unwrap();
    lines
        .map(|l| {
            let f: Vec<&str> = l.split(',').collect();
            assert_eq!(f.len(), header.len(), "a whole row: {l}");
            let key = f[..=seed].join(",");
            let cols = header
                .iter()
                .zip(&f)
                .filter(|(h, _)| !wall_clock(h))
                .map(|(h, v)| (h.to_string(), v.to_string()))
                .collect();
            (key, cols)
        })
        .collect()
}

#[test]
fn a_sweep_and_a_tune_through_slurm_equal_local_ones() {
    let (_guard, lab) = lab();
    let tmp = tempfile::tempdir().unwrap();
    let (local, cluster) = (tmp.path().join("local"), tmp.path().join("slurm"));
    let sweep = |out: &Path, extra: &[&str]| {
        let mut args = vec![
            "sweep",
            "configs/goto_simple.toml",
            "--out",
            out.to_str().unwrap(),
            "--set",
            "scenario.ticks=60",
            "--vary",
            "radio.loss=0,0.3",
            "--seeds",
            "2",
        ];
        args.extend(extra);
        swarm_on(&lab, &args)
    };
    // Processes mode: every task runs a world and nine robot processes on the node.
    assert_ok(&sweep(&local, &["--jobs", "2"]));
    // Three runs per task: tasks of three and of one run.
    assert_ok(&sweep(
        &cluster,
        &["--executor", "slurm", "--runs-per-task", "3"],
    ));
    let (a, b) = (rows(&local), rows(&cluster));
    assert_eq!(a.len(), 4);
    assert_eq!(a, b, "sweep.csv rows differ between local and Slurm");
    for (key, row) in &a {
        assert_eq!(row["failed"], "false", "{key}");
        let dir = &row["run_dir"];
        assert_same_records(&local.join(dir), &cluster.join(dir), key);
    }
    // The sweep's own outputs are there, and the array really ran through the cluster.
    for f in ["summary.md", "plots"] {
        assert!(cluster.join(f).exists(), "{f}");
    }
    let array = cluster.join("slurm/array-0");
    let job = std::fs::read_to_string(array.join("job_id")).unwrap();
    let tasks = lab.tasks();
    for run in 0..4 {
        assert_eq!(
            std::fs::read_to_string(array.join(format!("{run}.exit"))).unwrap(),
            "0\n"
        );
    }
    for t in 0..2 {
        let id = format!("{}_{t}", job.trim());
        assert!(
            tasks.iter().any(|(i, s)| *i == id && s == "COMPLETED"),
            "{id} in {tasks:?}"
        );
    }
    let id = format!("{}_2", job.trim());
    assert!(
        !tasks.iter().any(|(i, _)| *i == id),
        "two tasks only: {tasks:?}"
    );
    // Run again: nothing is missing, nothing is submitted.
    assert_ok(&sweep(&cluster, &["--executor", "slurm"]));
    assert!(!cluster.join("slurm/array-1").exists());

    // A small tune: each iteration's evaluations are one array, and the tune ends where the
    // local one does.
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
        swarm_on(&lab, &args)
    };
    let (tl, ts) = (tmp.path().join("tune-local"), tmp.path().join("tune-slurm"));
    assert_ok(&tune(&tl, &[]));
    assert_ok(&tune(&ts, &["--executor", "slurm"]));
    for f in ["best.toml", "tune.csv"] {
        assert_eq!(
            std::fs::read_to_string(tl.join(f)).unwrap(),
            std::fs::read_to_string(ts.join(f)).unwrap(),
            "{f}"
        );
    }
    assert!(
        ts.join("slurm/array-1/job_id").exists(),
        "one array per iteration"
    );
    assert!(!ts.join("slurm/array-2").exists());
}

/// `sweep` of a short run (50 ticks) and a long one (stopped only by the test), one task at
/// a time, into `out`.
fn short_and_long<'a>(out: &'a Path, extra: &[&'a str]) -> Vec<&'a str> {
    let mut args = vec![
        "sweep",
        "configs/goto_simple.toml",
        "--out",
        out.to_str().unwrap(),
        "--set",
        "scenario.stop_when_done=false",
        "--vary",
        "scenario.ticks=50,100000",
        "--executor",
        "slurm",
        "--jobs",
        "1",
    ];
    args.extend(extra);
    args
}

/// Waits until task `t` of the sweep's first array is running.
fn wait_running(lab: &SlurmLab, out: &Path, t: usize) -> String {
    let job_file = out.join("slurm/array-0/job_id");
    wait_until("the array's job id", LIMIT, || job_file.exists());
    let id = format!("{}_{t}", std::fs::read_to_string(&job_file).unwrap().trim());
    wait_until("the long task to run", LIMIT, || {
        lab.tasks().iter().any(|(i, s)| *i == id && s == "RUNNING")
    });
    id
}

#[test]
fn a_task_cancelled_from_outside_is_a_failed_row_and_collect_gathers_a_detached_sweep() {
    let (_guard, lab) = lab();
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("sweep");
    let detached = swarm_on(&lab, &short_and_long(&out, &["--detach"]));
    assert_ok(&detached);
    assert!(
        stderr(&detached).contains(&format!("swarm sweep --collect {}", out.display())),
        "{}",
        stderr(&detached)
    );
    let id = wait_running(&lab, &out, 1);
    let cancel = lab.command("scancel").arg(&id).status().unwrap();
    assert!(cancel.success());

    let collected = swarm_on(&lab, &["sweep", "--collect", out.to_str().unwrap()]);
    assert_eq!(collected.status.code(), Some(1), "{}", stderr(&collected));
    let err = stderr(&collected);
    assert!(
        err.contains(&format!(
            "warning: run runs/scenario.ticks=100000_s1 failed: Slurm task {id}"
        )) && err.contains("CANCELLED"),
        "{err}"
    );
    assert!(err.contains("1 of 2 runs failed"), "{err}");
    let r = rows(&out);
    assert_eq!(r["50,1"]["failed"], "false");
    assert_eq!(r["50,1"]["ticks"], "50");
    assert_eq!(r["100000,1"]["failed"], "true");
    assert!(out.join("summary.md").exists());
    assert_nothing_runs_in(&out);
    // Collecting again finds nothing left to wait for.
    let again = swarm_on(&lab, &["sweep", "--collect", out.to_str().unwrap()]);
    assert_eq!(again.status.code(), Some(0), "{}", stderr(&again));
    assert_eq!(rows(&out).len(), 2);
}

#[test]
fn ctrl_c_cancels_the_array_and_keeps_the_finished_rows() {
    let (_guard, lab) = lab();
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("sweep");
    let child = spawn_swarm(&short_and_long(&out, &[]), &lab.env());
    let id = wait_running(&lab, &out, 1);
    // SAFETY: kill has no memory effects; the pid is our live child.
    unsafe {
        libc::kill(child.id() as i32, libc::SIGINT);
    }
    let result = wait_with_watchdog(child, LIMIT);
    assert_eq!(result.status.code(), Some(130), "{}", stderr(&result));
    let err = stderr(&result);
    assert!(err.contains("cancelled Slurm job(s)"), "{err}");
    // The cluster runs nothing of the sweep any more.
    let job = id.split('_').next().unwrap().to_string();
    wait_until("the cancelled task to end", LIMIT, || {
        lab.tasks()
            .iter()
            .filter(|(i, _)| i.starts_with(&format!("{job}_")))
            .all(|(_, s)| s != "RUNNING" && s != "PENDING" && s != "COMPLETING")
    });
    let r = rows(&out);
    assert_eq!(r.len(), 1, "only the finished run is a row: {r:?}");
    assert_eq!(r["50,1"]["failed"], "false");
    assert!(!out.join("runs/scenario.ticks=100000_s1").exists());
    assert_nothing_runs_in(&out);
    assert!(err.contains("resume with: swarm sweep"), "{err}");
}

#[test]
fn no_sbatch_a_refused_submission_and_a_bad_executor_file_are_named() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("no-sbatch");
    let empty = tmp.path().join("empty-path");
    std::fs::create_dir(&empty).unwrap();
    let args = [
        "sweep",
        "configs/goto_simple.toml",
        "--out",
        out.to_str().unwrap(),
        "--set",
        "scenario.ticks=20",
        "--in-process",
        "--vary",
        "radio.loss=0,0.1",
        "--executor",
        "slurm",
    ];
    let result = wait_with_watchdog(
        spawn_swarm(&args, &[("PATH", empty.to_str().unwrap())]),
        LIMIT,
    );
    assert_eq!(result.status.code(), Some(1));
    let err = stderr(&result);
    assert!(
        err.contains("warning: run runs/radio.loss=0_s1 failed: cannot submit to Slurm: `sbatch` is not on PATH"),
        "{err}"
    );
    let r = rows(&out);
    assert_eq!(r.len(), 2);
    assert!(r.values().all(|row| row["failed"] == "true"));

    // A bad executor file is refused before anything is written, naming file and key.
    let file = tmp.path().join("cluster.toml");
    std::fs::write(
        &file,
        "[executor]\nkind = \"slurm\"\npartiton = \"short\"\n",
    )
    .unwrap();
    let bad_out = tmp.path().join("bad");
    let result = swarm(
        &[
            "sweep",
            "configs/goto_simple.toml",
            "--out",
            bad_out.to_str().unwrap(),
            "--vary",
            "radio.loss=0",
            "--executor-config",
            file.to_str().unwrap(),
        ],
        LIMIT,
    );
    assert_eq!(result.status.code(), Some(2));
    let err = stderr(&result);
    assert!(
        err.contains("cluster.toml: key `executor.partiton`: unknown field"),
        "{err}"
    );
    assert!(!bad_out.exists());
    let result = swarm(
        &[
            "sweep",
            "configs/goto_simple.toml",
            "--vary",
            "radio.loss=0",
            "--detach",
        ],
        LIMIT,
    );
    assert_eq!(result.status.code(), Some(2));
    assert!(
        stderr(&result).contains("--detach needs a cluster"),
        "{}",
        stderr(&result)
    );

    // A refused submission: every run of the array is a failed row naming sbatch's reason.
    let (_guard, lab) = lab();
    let out = tmp.path().join("refused");
    let mut refused = args.to_vec();
    refused[3] = out.to_str().unwrap();
    refused.extend(["--partition", "nope"]);
    let result = swarm_on(&lab, &refused);
    assert_eq!(result.status.code(), Some(1));
    let err = stderr(&result);
    assert!(
        err.contains("failed: sbatch refused the array (exit 1): sbatch: error: Batch job submission failed: Invalid partition name specified"),
        "{err}"
    );
    assert!(rows(&out).values().all(|row| row["failed"] == "true"));
}

#[test]
fn a_task_killed_outright_is_a_failed_row_naming_its_task() {
    let (_guard, lab) = lab();
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("sweep");
    let args = [
        "sweep",
        "configs/goto_simple.toml",
        "--out",
        out.to_str().unwrap(),
        "--set",
        "scenario.stop_when_done=false",
        "--set",
        "scenario.ticks=100000",
        "--vary",
        "radio.loss=0",
        "--executor",
        "slurm",
        "--detach",
    ];
    assert_ok(&swarm_on(&lab, &args));
    let id = wait_running(&lab, &out, 0);
    // Kill a run that ticks, which is what this is about: a kill while the task was still
    // spawning the run's processes once left the run ending in order instead (CI under load:
    // "the world process failed before the run started (killed by signal 15)").
    let trajectory = out.join("runs/radio.loss=0_s1/trajectory.csv");
    wait_until("the run to tick", LIMIT, || {
        std::fs::metadata(&trajectory).is_ok_and(|m| m.len() > 0)
    });
    // SIGKILL to every process of the task: the run cannot stop in order, and its row still
    // names the task.
    let kill = lab
        .command("scancel")
        .args(["--signal=KILL", "--full"])
        .arg(&id)
        .status()
        .unwrap();
    assert!(kill.success());
    let collected = swarm_on(&lab, &["sweep", "--collect", out.to_str().unwrap()]);
    assert_eq!(collected.status.code(), Some(1), "{}", stderr(&collected));
    let err = stderr(&collected);
    assert!(err.contains(&format!("failed: Slurm task {id} ")), "{err}");
    assert_eq!(rows(&out)["0,1"]["failed"], "true");
    assert_nothing_runs_in(&out);
}
