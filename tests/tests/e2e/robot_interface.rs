//! The robot interface beyond the built-in robot: the run directory's `iceoryx2.toml`, spare
//! subscriber slots for tools attaching mid-run (changing no record byte), `--realtime` with
//! a slow robot, and bad `robots.program` entries refused before the run.

use std::path::Path;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use iceoryx2::prelude::*;
use iceoryx2_bb_system_types::file_path::FilePath;
use swarmrt_protocol::{Command as RobotCommand, Observation, ObservationHeader};
use swarmrt_tests::{
    assert_ok, bytes, metrics, run_config, spawn_swarm, swarm, wait_until, wait_with_watchdog,
};

const LIMIT: Duration = Duration::from_secs(120);

/// What the observer saw.
#[derive(Debug, Default)]
struct Seen {
    observations: usize,
    commands: usize,
    first_tick: Option<u64>,
}

/// Attaches to the run in `dir` once it is past tick 20, through the run directory's
/// `config/iceoryx2.toml` alone, as a tool would: subscribes to observations and commands,
/// holds a sample for a while as a slow viewer does, and leaves after `want` ticks or when
/// `over` is set.
fn observe(dir: &Path, want: usize, over: &AtomicBool) -> Seen {
    let cfg_file = dir.join("config/iceoryx2.toml");
    wait_until("the run to pass tick 20", LIMIT, || {
        swarmrt_tests::last_tick(dir) >= 20
    });
    let path = FilePath::new(cfg_file.to_str().unwrap().as_bytes()).unwrap();
    let cfg = iceoryx2::config::Config::from_file(&path).expect("the run's iceoryx2.toml loads");
    let node = NodeBuilder::new()
        .name(&NodeName::new("observer").unwrap())
        .config(&cfg)
        .create::<ipc::Service>()
        .unwrap();
    let mut names = Vec::new();
    ipc::Service::list(&cfg, |s| {
        names.push(s.static_details.name().to_string());
        CallbackProgression::Continue
    })
    .unwrap();
    let obs_name = names.iter().find(|n| n.ends_with("/observations")).unwrap();
    // Commands travel in groups of 32 robot ids; this run has fewer robots: group 0.
    let cmd_name = names.iter().find(|n| n.ends_with("/commands/0")).unwrap();
    let obs = node
        .service_builder(&ServiceName::new(obs_name).unwrap())
        .publish_subscribe::<[Observation]>()
        .user_header::<ObservationHeader>()
        .open()
        .expect("a spare subscriber slot on observations");
    let obs_sub = obs.subscriber_builder().create().unwrap();
    let obs_event = node
        .service_builder(&ServiceName::new(obs_name).unwrap())
        .event()
        .open()
        .unwrap();
    let listener = obs_event.listener_builder().create().unwrap();
    let cmds = node
        .service_builder(&ServiceName::new(cmd_name).unwrap())
        .publish_subscribe::<RobotCommand>()
        .open()
        .expect("a spare subscriber slot on commands");
    let cmd_sub = cmds.subscriber_builder().create().unwrap();
    let mut seen = Seen::default();
    let start = Instant::now();
    while seen.observations < want && start.elapsed() < LIMIT && !over.load(Ordering::SeqCst) {
        let _ = listener.timed_wait(|_| {}, Duration::from_millis(200));
        while let Some(s) = obs_sub.receive().unwrap() {
            seen.first_tick.get_or_insert(s.user_header().tick);
            seen.observations += 1;
            if seen.observations == 3 {
                // A slow viewer: hold this sample while the world goes on.
                std::thread::sleep(Duration::from_millis(300));
            }
        }
        while cmd_sub.receive().unwrap().is_some() {
            seen.commands += 1;
        }
    }
    seen
}

#[test]
fn a_tool_attaching_mid_run_changes_no_record_byte() {
    let tmp = tempfile::tempdir().unwrap();
    let plain = tmp.path().join("plain");
    let watched = tmp.path().join("watched");
    let args = ["--ticks", "1500", "--set", "scenario.stop_when_done=false"];
    run_config("configs/goto_simple.toml", &plain, &args);

    let mut run_args = vec!["run", "configs/goto_simple.toml"];
    run_args.extend_from_slice(&args);
    run_args.extend_from_slice(&["--out", watched.to_str().unwrap()]);
    let child = spawn_swarm(&run_args, &[]);
    let over = AtomicBool::new(false);
    let seen = std::thread::scope(|s| {
        let observer = s.spawn(|| observe(&watched, 40, &over));
        let out = wait_with_watchdog(child, LIMIT);
        over.store(true, Ordering::SeqCst);
        assert_ok(&out);
        observer.join().unwrap()
    });
    assert!(seen.observations >= 40, "{seen:?}");
    assert!(seen.commands >= 40, "{seen:?}");
    assert!(seen.first_tick.unwrap() >= 20, "attached mid-run: {seen:?}");
    for f in ["trajectory.csv", "events.jsonl", "config.toml"] {
        assert!(
            bytes(&plain, f) == bytes(&watched, f),
            "{f} differs with a tool attached"
        );
    }
    let m = metrics(&watched);
    assert_eq!(m["shell"]["unknown_sender"], 0);
    assert_eq!(m["reproducible"], true);
}

#[test]
fn without_spare_slots_a_tool_is_refused_and_the_run_goes_on() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("run");
    let child = spawn_swarm(
        &[
            "run",
            "configs/goto_simple.toml",
            "--ticks",
            "150",
            "--set",
            "scenario.stop_when_done=false",
            "--set",
            "ipc.observers=0",
            "--out",
            dir.to_str().unwrap(),
        ],
        &[],
    );
    let refused = std::panic::catch_unwind(|| observe(&dir, 5, &AtomicBool::new(false))).is_err();
    assert_ok(&wait_with_watchdog(child, LIMIT));
    assert!(
        refused,
        "with ipc.observers = 0 there is no slot for a tool"
    );
    assert_eq!(metrics(&dir)["ticks"], 150);
}

#[test]
fn realtime_ticks_by_the_clock_and_a_slow_robot_keeps_its_last_command() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("run");
    // Robot 4 thinks 250 ms per tick: it answers about every third tick of 100 ms.
    let child = spawn_swarm(
        &[
            "run",
            "configs/goto_simple.toml",
            "--realtime",
            "--ticks",
            "40",
            "--out",
            dir.to_str().unwrap(),
        ],
        &[("SWARMRT_TEST_MISBEHAVE", "4:slow")],
    );
    assert_ok(&wait_with_watchdog(child, LIMIT));
    let m = metrics(&dir);
    assert_eq!(m["mode"], "realtime");
    assert_eq!(m["reproducible"], false);
    assert_eq!(m["ticks"], 40);
    assert_eq!(m["unscheduled_deaths"].as_array().unwrap().len(), 0);
    // Paced by the clock: 40 ticks of 0.1 s cannot take less than 4 s.
    assert!(
        m["wall_seconds"].as_f64().unwrap() >= 3.9,
        "{}",
        m["wall_seconds"]
    );
    let rt = &m["shell"]["realtime"];
    // The slow robot misses ticks, but not all of them.
    let missed = rt["missed_by_robot"]["4"].as_u64().unwrap();
    assert!((10..40).contains(&missed), "{rt}");
    assert!(rt["stale"].as_u64().unwrap() > 0, "{rt}");
    // Between its answers it keeps moving on its last command instead of stopping. Had it
    // stopped on every missed tick, its speed would drop to 0 after nearly every answer; the
    // robot itself may still stop now and then (avoiding a neighbour), so a few drops are its
    // own (one, with the suite sharing the machine with a build).
    let answers = 40 - missed;
    let csv = String::from_utf8(bytes(&dir, "trajectory.csv")).unwrap();
    let speeds: Vec<f64> = csv
        .lines()
        .skip(1)
        .map(|l| l.split(',').collect::<Vec<_>>())
        .filter(|f| f[1] == "4" && f[0].parse::<u64>().unwrap() >= 5)
        .map(|f| f[5].parse().unwrap())
        .collect();
    assert!(speeds.len() >= 30);
    let drops = speeds
        .windows(2)
        .filter(|w| w[0] > 0.0 && w[1] == 0.0)
        .count() as u64;
    assert!(
        drops * 2 < answers,
        "robot 4 stood still after {drops} of its {answers} answers: {speeds:?}"
    );
}

#[test]
fn bad_program_entries_fail_before_the_run_naming_the_key() {
    let tmp = tempfile::tempdir().unwrap();
    let script = tmp.path().join("robot.py");
    std::fs::write(&script, "print('hi')\n").unwrap();
    let cases = [
        (
            "robots.program=[\"./no/such/robot\"]".to_string(),
            "key `robots.program[0]`",
        ),
        (
            format!("robots.program=[\"{}\"]", script.display()),
            "not executable",
        ),
        (
            "robots.programs=[{robots=\"5..12\", program=[\"sh\"]}]".to_string(),
            "key `robots.programs[0].robots`",
        ),
        (
            "robots.programs=[{robots=1, program=[]}]".to_string(),
            "key `robots.programs[0].program`",
        ),
    ];
    for (set, want) in cases {
        let dir = tmp.path().join("run");
        let out = swarm(
            &[
                "run",
                "configs/goto_simple.toml",
                "--set",
                &set,
                "--out",
                dir.to_str().unwrap(),
            ],
            LIMIT,
        );
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{set}: {err}");
        assert!(err.contains(want), "{set}: {err}");
        assert!(!dir.join("trajectory.csv").exists(), "{set}: a run started");
    }
    let out = swarm(
        &[
            "run",
            "configs/goto_simple.toml",
            "--in-process",
            "--set",
            "robots.program=[\"sh\"]",
        ],
        LIMIT,
    );
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("--in-process"));
}

#[test]
fn python_c_and_rust_robots_in_one_run_replay_the_all_rust_records() {
    let tmp = tempfile::tempdir().unwrap();
    let python = swarmrt_tests::python::program("goto.py", &[]);
    let c = swarmrt_tests::c_robot::goto_c().display().to_string();
    // Robots 0..3 in Python, 3..6 in C, 6..9 the built-in Rust robot.
    let mixed = format!(
        "robots.programs=[{{robots=\"0..3\", program={python}}}, {{robots=\"3..6\", program=[{c:?}]}}]"
    );
    let ticks = ["--ticks", "300"];
    run_config("configs/goto_simple.toml", &tmp.path().join("rust"), &ticks);
    for run in ["mixed-1", "mixed-2"] {
        let dir = tmp.path().join(run);
        let m = run_config(
            "configs/goto_simple.toml",
            &dir,
            &["--ticks", "300", "--set", &mixed],
        );
        assert_eq!(m["rejected"], 0, "{run}");
        assert_eq!(m["shell"]["bad_hello"], 0, "{run}");
        assert_eq!(m["reproducible"], true, "{run}");
        // Every robot process ran the program its range names and ended on the shutdown.
        for p in m["processes"].as_array().unwrap() {
            assert_eq!(p["end"], "exited with code 0", "{run}: {p}");
        }
        for f in ["trajectory.csv", "events.jsonl"] {
            assert!(
                bytes(&tmp.path().join("rust"), f) == bytes(&dir, f),
                "{run}: {f} differs from the all-Rust run"
            );
        }
    }
    let cfg = String::from_utf8(bytes(&tmp.path().join("mixed-1"), "config.toml")).unwrap();
    assert!(cfg.contains("goto.py") && cfg.contains("goto-c"), "{cfg}");
}

#[test]
fn realtime_gives_up_on_a_hung_robot_and_keeps_the_clock() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("run");
    let hang = swarmrt_tests::python::program("misbehave.py", &["slow:60000"]);
    let m = run_config(
        "configs/goto_simple.toml",
        &dir,
        &[
            "--realtime",
            "--ticks",
            "30",
            "--set",
            &format!("robots.programs=[{{robots=2, program={hang}}}]"),
            "--set",
            "scenario.deadline_ms=300",
            // Three seconds: a well-behaved robot starved of CPU by the tests beside it for
            // one second was given up too (robots 6 and 7 once, in a loaded suite).
            "--set",
            "scenario.unresponsive_ms=3000",
        ],
    );
    assert_eq!(m["ticks"], 30);
    assert_eq!(m["dead"], 1, "{m}");
    assert_eq!(m["unscheduled_deaths"][0]["robot"], 2, "{m}");
    // Killed after a few seconds of silence, not after its minute of thinking.
    assert!(m["wall_seconds"].as_f64().unwrap() < 20.0, "{m}");
    let csv = String::from_utf8(bytes(&dir, "trajectory.csv")).unwrap();
    assert!(
        csv.lines()
            .any(|l| l.starts_with("30,2,") && l.ends_with(",dead"))
    );
}
