//! `swarm bench`: the commands run, their JSON holds what the issue asks for, the loss
//! accounting shows the runtime's settings losing nothing, and nothing is left behind. No
//! assertion here is about speed.

use std::time::Duration;
use swarmrt_tests::{assert_ok, leftovers, swarm};

const LIMIT: Duration = Duration::from_secs(300);

fn json_of(out: &std::process::Output) -> serde_json::Value {
    assert_ok(out);
    serde_json::from_slice(&out.stdout).unwrap_or_else(|e| {
        panic!(
            "stdout is not JSON ({e}):\n{}",
            String::from_utf8_lossy(&out.stdout)
        )
    })
}

/// Live processes whose command line mentions any of `ids` (bench children carry their run
/// id in `--spec` or `--run-id`).
fn processes_of(ids: &[String]) -> Vec<String> {
    let mut found = Vec::new();
    for e in std::fs::read_dir("/proc").unwrap().flatten() {
        let name = e.file_name().to_string_lossy().to_string();
        let Ok(pid) = name.parse::<i32>() else {
            continue;
        };
        if !swarmrt_tests::alive(pid) {
            continue;
        }
        let cmd = std::fs::read(format!("/proc/{pid}/cmdline")).unwrap_or_default();
        let cmd = String::from_utf8_lossy(&cmd).replace('\0', " ");
        if ids.iter().any(|id| cmd.contains(id.as_str())) {
            found.push(cmd);
        }
    }
    found
}

fn assert_nothing_left(v: &serde_json::Value) {
    let ids: Vec<String> = v["run_ids"]
        .as_array()
        .expect("run_ids")
        .iter()
        .map(|x| x.as_str().unwrap().to_string())
        .collect();
    assert!(!ids.is_empty(), "the report names its run ids");
    for id in &ids {
        assert!(leftovers(id).is_empty(), "{id}: {:?}", leftovers(id));
    }
    let left = processes_of(&ids);
    assert!(left.is_empty(), "processes left running: {left:?}");
}

fn positive(v: &serde_json::Value, what: &str) {
    let x = v
        .as_f64()
        .unwrap_or_else(|| panic!("{what} is not a number: {v}"));
    assert!(x > 0.0, "{what} = {x}");
}

#[test]
fn bench_ipc_reports_every_transport_and_the_runtime_loses_nothing() {
    let tmp = tempfile::tempdir().unwrap();
    let out_dir = tmp.path().join("ipc");
    let out = swarm(
        &[
            "bench",
            "ipc",
            "--secs",
            "0.2",
            "--payload",
            "64",
            "--fanout",
            "1,3",
            "--json",
            "--out",
            out_dir.to_str().unwrap(),
        ],
        LIMIT,
    );
    let v = json_of(&out);

    let transports = [
        "iox2-poll",
        "iox2-listener",
        "iox2-waitset",
        "unix-socket",
        "tcp-loopback",
        "crossbeam-inproc",
    ];
    let rows = v["rows"].as_array().expect("rows");
    for t in transports {
        let row = rows
            .iter()
            .find(|r| r["transport"] == t && r["payload"] == 64)
            .unwrap_or_else(|| panic!("no row for {t}: {v}"));
        assert!(row["error"].is_null(), "{t}: {}", row["error"]);
        positive(&row["rtt_ns"]["median"], &format!("{t} rtt median"));
        positive(&row["rtt_ns"]["p99"], &format!("{t} rtt p99"));
        positive(&row["rtt_ns"]["p999"], &format!("{t} rtt p99.9"));
        positive(&row["msgs_per_s"], &format!("{t} msgs/s"));
        positive(&row["bytes_per_s"], &format!("{t} bytes/s"));
        positive(&row["rtt_vs_baseline"], &format!("{t} ratio"));
        assert_eq!(row["sent"], row["received"], "{t} is lossless: {row}");
    }

    let fanout = v["fanout"].as_array().expect("fanout");
    for k in [1, 3] {
        let f = fanout
            .iter()
            .find(|f| f["subscribers"] == k)
            .unwrap_or_else(|| panic!("no fan-out row for {k}"));
        assert!(
            f["error"].is_null(),
            "fan-out {k}: {}\nstderr: {}",
            f["error"],
            String::from_utf8_lossy(&out.stderr)
        );
        positive(
            &f["result"]["last_receive_ns"]["median"],
            "fan-out last receive",
        );
        positive(&f["result"]["all_acked_ns"]["p99"], "fan-out all acked p99");
    }

    let loss = v["loss"].as_array().expect("loss");
    let row = |id: &str| {
        loss.iter()
            .find(|l| l["id"] == id)
            .unwrap_or_else(|| panic!("no loss row {id}: {v}"))
    };
    let defaults = row("iceoryx2-defaults");
    assert!(defaults["error"].is_null(), "{defaults}");
    assert!(defaults["sent"].as_u64().unwrap() > 0);
    let d = defaults["dropped"].as_u64().expect("dropped is a count");
    assert_eq!(
        d + defaults["received"].as_u64().unwrap(),
        defaults["sent"].as_u64().unwrap(),
        "{defaults}"
    );
    let lock_step = row("runtime-lock-step");
    assert!(lock_step["error"].is_null(), "{lock_step}");
    assert!(lock_step["sent"].as_u64().unwrap() > 0);
    assert_eq!(
        lock_step["dropped"], 0,
        "the runtime's settings drop nothing: {lock_step}"
    );
    assert_eq!(lock_step["received"], lock_step["sent"]);
    assert_eq!(lock_step["gaps"], 0);

    assert!(v["path"]["error"].is_null(), "{}", v["path"]);
    positive(&v["path"]["runtime_rtt_ns"]["median"], "runtime path");
    positive(&v["path"]["raw_rtt_ns"]["median"], "raw path");

    for f in ["results.json", "ipc.svg", "ipc.png"] {
        assert!(out_dir.join(f).exists(), "{f} written");
    }
    assert_nothing_left(&v);
}

#[test]
fn bench_swarm_reports_runtime_floor_and_in_process_and_cleans_up() {
    let tmp = tempfile::tempdir().unwrap();
    let out_dir = tmp.path().join("swarm");
    let out = swarm(
        &[
            "bench",
            "swarm",
            "--agents",
            "3",
            // Long enough (~0.2 s) for the robots' turn to be watched while they tick.
            "--ticks",
            "1000",
            "--in-process-agents",
            "20",
            "--json",
            "--out",
            out_dir.to_str().unwrap(),
        ],
        LIMIT,
    );
    let v = json_of(&out);
    let rt = &v["runtime"][0];
    assert!(rt["error"].is_null(), "{rt}");
    assert_eq!(rt["agents"], 3);
    assert_eq!(rt["ticks"], 1000);
    positive(&rt["ticks_per_s"], "runtime ticks/s");
    positive(&rt["tick_ms_median"], "runtime median");
    positive(&rt["startup_ms"], "runtime startup");
    positive(&rt["memory"]["pss_kib"], "runtime PSS");
    assert_eq!(rt["memory"]["processes"], 4, "world + 3 robots: {rt}");
    positive(&rt["world_fds"], "world fds");
    positive(&rt["cpu"]["robot_turn_us"], "a runtime robot's turn");

    let fl = &v["floor"][0];
    assert!(fl["error"].is_null(), "{fl}");
    assert_eq!(fl["result"]["ticks"], 1000);
    positive(&fl["cpu"]["robot_turn_us"], "a floor robot's turn");
    positive(&fl["result"]["tick_ns"]["median"], "floor median");
    positive(&fl["memory"]["pss_kib"], "floor PSS");
    positive(&v["comparison"][0]["median_ratio"], "runtime / floor");

    let ip = &v["in_process"][0];
    assert!(ip["error"].is_null(), "{ip}");
    assert_eq!(ip["agents"], 20);
    positive(&ip["robot_steps_per_s"], "in-process robot-steps/s");

    for f in [
        "results.json",
        "swarm.svg",
        "swarm.png",
        "runs/n3/trajectory.csv",
    ] {
        assert!(out_dir.join(f).exists(), "{f} written");
    }
    assert_nothing_left(&v);
}

/// `--rounds 2`: two runtime and two floor rows per N, in alternation, each round its own
/// run directory, and the reported ratio is the median of the rounds' ratios.
#[test]
fn bench_swarm_rounds_alternate_and_report_the_median_ratio() {
    let tmp = tempfile::tempdir().unwrap();
    let out_dir = tmp.path().join("rounds");
    let out = swarm(
        &[
            "bench",
            "swarm",
            "--agents",
            "2,3",
            "--ticks",
            "20",
            "--rounds",
            "2",
            "--in-process-agents",
            "5",
            "--in-process-ticks",
            "1",
            "--json",
            "--out",
            out_dir.to_str().unwrap(),
        ],
        LIMIT,
    );
    let v = json_of(&out);
    let rounds_of = |rows: &serde_json::Value| -> Vec<(u64, u64)> {
        rows.as_array()
            .unwrap()
            .iter()
            .map(|r| (r["round"].as_u64().unwrap(), r["agents"].as_u64().unwrap()))
            .collect()
    };
    let order = vec![(1, 2), (1, 3), (2, 2), (2, 3)];
    assert_eq!(rounds_of(&v["runtime"]), order);
    assert_eq!(rounds_of(&v["floor"]), order);
    for (i, n) in [(0, 2), (1, 3)] {
        let c = &v["comparison"][i];
        assert_eq!(c["agents"], n);
        let ratios: Vec<f64> = c["ratios"]
            .as_array()
            .unwrap()
            .iter()
            .map(|r| r.as_f64().unwrap())
            .collect();
        assert_eq!(ratios.len(), 2, "{c}");
        // Each round's ratio is its own pair's medians.
        for (k, ratio) in ratios.iter().enumerate() {
            let rt = &v["runtime"][2 * k + i];
            let fl = &v["floor"][2 * k + i];
            let expect = rt["tick_ms_median"].as_f64().unwrap()
                / (fl["result"]["tick_ns"]["median"].as_f64().unwrap() / 1e6);
            assert!((ratio - expect).abs() < 1e-9, "{ratio} against {expect}");
        }
        let median = c["median_ratio"].as_f64().unwrap();
        assert!(((ratios[0] + ratios[1]) / 2.0 - median).abs() < 1e-9, "{c}");
    }
    for f in ["runs/n2-r1", "runs/n2-r2", "runs/n3-r1", "runs/n3-r2"] {
        assert!(
            out_dir.join(f).join("trajectory.csv").exists(),
            "{f} written"
        );
    }
    assert!(out_dir.join("swarm.png").exists());
    assert_nothing_left(&v);
}

#[test]
fn bench_refuses_bad_arguments_with_one_line() {
    for args in [
        &["bench", "ipc", "--payload", "8"][..],
        &["bench", "ipc", "--secs", "0"][..],
        &["bench", "swarm", "--agents", "0"][..],
        &["bench", "swarm", "--rounds", "0"][..],
    ] {
        let out = swarm(args, Duration::from_secs(60));
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{args:?}: {err}");
        assert_eq!(err.trim().lines().count(), 1, "{args:?}: {err}");
    }
}

#[test]
fn ctrl_c_stops_a_bench_and_leaves_nothing() {
    use std::process::{Command, Stdio};
    let tmp = tempfile::tempdir().unwrap();
    let child = Command::new(swarmrt_tests::swarm_bin())
        .current_dir(swarmrt_tests::workspace())
        .args([
            "bench",
            "ipc",
            "--secs",
            "30",
            "--payload",
            "64",
            "--fanout",
            "1",
            "--out",
            tmp.path().join("ipc").to_str().unwrap(),
        ])
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let pid = child.id();
    // Wait until a measurement's processes run, and note their run id.
    let mut ids = Vec::new();
    swarmrt_tests::wait_until("a bench child", Duration::from_secs(60), || {
        for (_, cmd) in swarmrt_tests::children_of(pid) {
            if let Some(rest) = cmd.split("\"run_id\":\"").nth(1)
                && let Some(id) = rest.split('"').next()
                && !ids.iter().any(|x: &String| x == id)
            {
                ids.push(id.to_string());
            }
        }
        !ids.is_empty()
    });
    let children = swarmrt_tests::children_of(pid);
    unsafe {
        libc::kill(pid as i32, libc::SIGINT);
    }
    let out = swarmrt_tests::wait_with_watchdog(child, LIMIT);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(130), "{err}");
    assert!(err.contains("interrupted"), "{err}");
    for (p, cmd) in &children {
        assert!(!swarmrt_tests::alive(*p), "left running: {cmd}");
    }
    for id in &ids {
        assert!(leftovers(id).is_empty(), "{id}: {:?}", leftovers(id));
    }
    assert!(processes_of(&ids).is_empty());
}

/// `--peers uds,zenoh` (issue 34): each round runs the runtime, then the floor's lock-step
/// over Unix sockets and over Zenoh; their rows have every tick, CPU and memory, and the
/// iceoryx2 floor, not asked for, does not run.
#[test]
fn bench_swarm_runs_the_peer_floors() {
    let tmp = tempfile::tempdir().unwrap();
    let out_dir = tmp.path().join("peers");
    let out = swarm(
        &[
            "bench",
            "swarm",
            "--agents",
            "3",
            "--ticks",
            "20",
            "--peers",
            "uds,zenoh",
            "--in-process-agents",
            "5",
            "--in-process-ticks",
            "1",
            "--json",
            "--out",
            out_dir.to_str().unwrap(),
        ],
        LIMIT,
    );
    let v = json_of(&out);
    assert_eq!(
        v["floor"].as_array().unwrap().len(),
        0,
        "no iox2 floor: {v}"
    );
    let peers = v["peers"].as_array().expect("peers");
    assert_eq!(peers.len(), 2, "{v}");
    for (row, name) in peers.iter().zip(["uds", "zenoh"]) {
        assert_eq!(row["peer"], name, "{row}");
        assert!(row["error"].is_null(), "{name}: {}", row["error"]);
        assert_eq!(row["agents"], 3);
        assert_eq!(row["round"], 1);
        assert_eq!(row["result"]["ticks"], 20, "{row}");
        assert_eq!(row["result"]["tick_ns"]["samples"], 20, "{row}");
        positive(&row["ticks_per_s"], &format!("{name} ticks/s"));
        positive(&row["result"]["tick_ns"]["p99"], &format!("{name} p99"));
        assert_eq!(row["memory"]["processes"], 4, "world + 3 robots: {row}");
        positive(&row["memory"]["pss_kib"], &format!("{name} PSS"));
        positive(&row["cpu"]["ms_per_tick"], &format!("{name} CPU per tick"));
    }
    positive(
        &v["runtime"][0]["cpu"]["ms_per_tick"],
        "runtime CPU per tick",
    );
    let names: Vec<&str> = v["transports"]
        .as_array()
        .unwrap()
        .iter()
        .map(|t| t["transport"].as_str().unwrap())
        .collect();
    assert_eq!(names, ["runtime", "uds", "zenoh"]);
    assert!(out_dir.join("swarm.png").exists());
    assert_nothing_left(&v);
}

/// A peer robot that dies mid-run (`--peer-fault 1@5`, hidden) makes its row an error that
/// names it, through the world's watchdog; the bench goes on and leaves nothing behind.
#[test]
fn bench_swarm_a_dead_peer_robot_fails_its_row() {
    let tmp = tempfile::tempdir().unwrap();
    let out_dir = tmp.path().join("fault");
    let out = swarm(
        &[
            "bench",
            "swarm",
            "--agents",
            "3",
            "--ticks",
            "20",
            "--peers",
            "uds,zenoh",
            "--peer-fault",
            "1@5",
            "--in-process-agents",
            "5",
            "--in-process-ticks",
            "1",
            "--json",
            "--out",
            out_dir.to_str().unwrap(),
        ],
        LIMIT,
    );
    let v = json_of(&out);
    let peers = v["peers"].as_array().expect("peers");
    assert_eq!(peers.len(), 2, "{v}");
    for row in peers {
        let err = row["error"].as_str().unwrap_or_else(|| panic!("{row}"));
        assert!(err.contains("robot 1"), "{err}");
        assert!(row["result"].is_null(), "{row}");
    }
    assert!(
        v["runtime"][0]["error"].is_null(),
        "the runtime is not faulted"
    );
    assert_nothing_left(&v);
}
