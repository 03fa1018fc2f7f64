//! Robots written in C (issue 17): the generated header lays out every message as Rust does,
//! C go-to robots (`examples/c/goto.c` on `libswarmrt.a`) write byte for byte the records of
//! Rust ones, alone or mixed with them, and a C robot killed, frozen, restarted or
//! terminated mid-run is handled like a Rust one and leaves nothing behind.

use std::fmt::Write as _;
use std::process::Command;
use std::time::Duration;

use swarmrt_protocol::layout;
use swarmrt_tests::c_robot::{self, goto_c, program_for_all, programs_for};
use swarmrt_tests::*;

const LIMIT: Duration = Duration::from_secs(120);
const CONFIG: &str = "configs/goto_simple.toml";

/// `swarmrt_observation_header_t` for `ObservationHeader` (as `layout` names the C types).
fn snake(rust: &str) -> String {
    let mut s = String::new();
    for (i, ch) in rust.chars().enumerate() {
        if ch.is_ascii_uppercase() && i > 0 {
            s.push('_');
        }
        s.push(ch.to_ascii_lowercase());
    }
    s
}

/// A C program printing, from `swarmrt_messages.h` alone, what `layout_lines()` says:
/// `sizeof`, `_Alignof` and the iceoryx2 type name (`SWARMRT_*_TYPE_NAME`) of each struct,
/// `offsetof` and `sizeof` of each field.
fn layout_program() -> String {
    let mut c = String::from(
        "#include <stdio.h>\n#include <stddef.h>\n#include \"swarmrt_messages.h\"\n\
         #define FIELD(T, S, F) printf(\"%s.%s offset %zu size %zu\\n\", S, #F, \
         offsetof(T, F), sizeof(((T *)0)->F));\nint main(void) {\n",
    );
    for s in layout::messages() {
        let ty = format!("swarmrt_{}_t", snake(s.name));
        let type_name = format!("SWARMRT_{}_TYPE_NAME", snake(s.name).to_ascii_uppercase());
        writeln!(
            c,
            "    printf(\"%s size %zu align %zu type %s\\n\", \"{}\", sizeof({ty}), \
             (size_t)_Alignof({ty}), {type_name});",
            s.name
        )
        .unwrap();
        for f in &s.fields {
            writeln!(c, "    FIELD({ty}, \"{}\", {})", s.name, f.name).unwrap();
        }
    }
    c.push_str("    return 0;\n}\n");
    c
}

#[test]
fn the_c_header_lays_out_every_message_as_rust_does() {
    let tmp = tempfile::tempdir().unwrap();
    let src = tmp.path().join("layout.c");
    std::fs::write(&src, layout_program()).unwrap();
    let exe = c_robot::compile("layout", &[&src], &["-Werror"], false);
    let out = Command::new(&exe).output().unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let c = String::from_utf8(out.stdout).unwrap();
    let c: Vec<&str> = c.lines().collect();
    let rust = layout::layout_lines();
    assert!(rust.len() > 40, "every struct and field: {rust:?}");
    for (i, (r, c)) in rust.iter().zip(&c).enumerate() {
        assert_eq!(
            r, c,
            "line {i}: Rust and C lay the messages out differently"
        );
    }
    assert_eq!(rust.len(), c.len());
}

#[test]
fn c_goto_robots_write_the_records_of_rust_ones() {
    let tmp = tempfile::tempdir().unwrap();
    let (c, rust) = (tmp.path().join("c"), tmp.path().join("rust"));
    // Until every robot is home (stop_when_done), so events.jsonl holds the arrivals.
    let m = run_config(CONFIG, &c, &["--set", &program_for_all(goto_c())]);
    run_config(CONFIG, &rust, &[]);
    assert_same_records(&c, &rust, "all C vs all Rust");
    assert_eq!(m["reached_target"], 9, "{m}");
    assert_eq!(m["rejected"], 0, "{m}");
    let procs = m["processes"].as_array().unwrap();
    assert_eq!(procs.len(), 9, "{m}");
    for p in procs {
        assert_eq!(p["end"], "exited with code 0", "{m}");
    }
    // And for a fixed number of ticks, mid-journey.
    let (c, rust) = (tmp.path().join("c200"), tmp.path().join("rust200"));
    run_config(
        CONFIG,
        &c,
        &["--ticks", "200", "--set", &program_for_all(goto_c())],
    );
    run_config(CONFIG, &rust, &["--ticks", "200"]);
    assert_same_records(&c, &rust, "all C vs all Rust, 200 ticks");
}

/// The config keys the C robot reads that goto_simple leaves at their defaults: start groups
/// with a goal of their own and explicit sizes, explicit lidar ray angles; with sensor noise
/// and a lossy radio.
const GROUPS: &str = r#"
[scenario]
name = "goto_groups"
seed = 5
ticks = 300
dt = 0.1
[map]
bounds = [0.0, 0.0, 12.0, 12.0]
goal = { x = 10.0, y = 10.0, radius = 1.2 }
circles = [{ x = 5.0, y = 5.5, r = 0.8 }]
[robots]
count = 9
radius = 0.15
max_speed = 1.0
max_turn_rate = 3.0
start = { spacing = 0.7, heading_deg = 45.0, group_sizes = [4, 5], groups = [
  { x = 2.0, y = 2.0, goal = [3.0, 10.0] }, { x = 9.0, y = 2.0 } ] }
lidar = { rays = 7, range = 3.0, angles_deg = [-90.0, -60.0, -30.0, 0.0, 30.0, 60.0, 90.0] }
noise = { pose = 0.02, heading = 0.01, lidar = 0.05 }
[radio]
loss = 0.3
delay_ticks = 2
[behaviour]
kind = "goto"
slot_spacing = 0.4
"#;

#[test]
fn c_goto_robots_read_group_goals_ray_angles_and_noisy_sensors_as_rust_ones_do() {
    let tmp = tempfile::tempdir().unwrap();
    let config = tmp.path().join("goto_groups.toml");
    std::fs::write(&config, GROUPS).unwrap();
    let config = config.to_str().unwrap();
    let (c, rust) = (tmp.path().join("c"), tmp.path().join("rust"));
    run_config(config, &c, &["--set", &program_for_all(goto_c())]);
    let m = run_config(config, &rust, &[]);
    assert_same_records(&c, &rust, "start groups, ray angles, noise: C vs Rust");
    assert!(m["radio"]["dropped_loss"].as_u64().unwrap() > 0, "{m}");
}

#[test]
fn a_mixed_swarm_replays_and_matches_an_all_rust_one() {
    let tmp = tempfile::tempdir().unwrap();
    let set = programs_for(&[("0..4", goto_c()), ("7", goto_c())]);
    let args = ["--ticks", "400", "--set", set.as_str()];
    let (a, b, rust) = (
        tmp.path().join("mixed-a"),
        tmp.path().join("mixed-b"),
        tmp.path().join("rust"),
    );
    let m = run_config(CONFIG, &a, &args);
    run_config(CONFIG, &b, &args);
    run_config(CONFIG, &rust, &["--ticks", "400"]);
    assert_same_records(&a, &b, "mixed, run twice");
    assert_same_records(&a, &rust, "mixed vs all Rust");
    assert_eq!(m["reproducible"], true, "{m}");
    // The C robots' beacons reached Rust robots and back (the world checked every frame).
    assert_eq!(m["rejected"], 0, "{m}");
    assert!(m["radio"]["delivered"].as_u64().unwrap() > 0, "{m}");
}

/// Every process whose command line names `run_id`.
fn processes_of_run(run_id: &str) -> Vec<String> {
    let mut found = Vec::new();
    for e in std::fs::read_dir("/proc").unwrap().flatten() {
        if e.file_name().to_string_lossy().parse::<u32>().is_err() {
            continue;
        }
        let cmd = std::fs::read(e.path().join("cmdline")).unwrap_or_default();
        let cmd = String::from_utf8_lossy(&cmd).replace('\0', " ");
        if cmd.contains(run_id) && alive(e.file_name().to_string_lossy().parse().unwrap()) {
            found.push(cmd);
        }
    }
    found
}

#[test]
fn c_robots_killed_frozen_and_restarted_by_the_fault_schedule_replay_and_leave_nothing() {
    let tmp = tempfile::tempdir().unwrap();
    let faults = [
        "--ticks",
        "300",
        "--set",
        "faults.kill=[{tick=60,robot=4}]",
        "--set",
        "faults.freeze=[{robot=5,from=40,to=70}]",
        "--set",
        "faults.restart=[{tick=90,robot=6,down_ticks=10}]",
    ];
    let set = program_for_all(goto_c());
    let mut with_c = faults.to_vec();
    with_c.extend_from_slice(&["--set", &set]);
    let (c, rust) = (tmp.path().join("c"), tmp.path().join("rust"));
    let m = run_config(CONFIG, &c, &with_c);
    run_config(CONFIG, &rust, &faults);
    assert_same_records(&c, &rust, "C robots under faults vs Rust robots");

    assert_eq!(m["dead"], 1, "{m}");
    assert_eq!(m["robots_lost"], 1, "{m}");
    assert_eq!(m["restarts"], 1, "{m}");
    assert!(m["frozen_ticks"].as_u64().unwrap() >= 30, "{m}");
    assert_eq!(m["unscheduled_deaths"], serde_json::json!([]), "{m}");
    assert_eq!(m["reproducible"], true, "{m}");
    for p in m["processes"].as_array().unwrap() {
        let killed = p["scheduled_kill"] == true;
        assert_eq!(
            killed,
            p["robot"] == 4 || (p["robot"] == 6 && p["incarnation"] == 0),
            "{p}"
        );
        if !killed {
            assert_eq!(p["end"], "exited with code 0", "{p}");
        }
    }
    let events = String::from_utf8(bytes(&c, "events.jsonl")).unwrap();
    assert!(
        events.contains(r#"{"event":"fault","tick":60,"fault":"kill","robot":4}"#),
        "{events}"
    );
    let run_id = m["run_id"].as_str().expect("metrics.json has run_id");
    assert!(leftovers(run_id).is_empty(), "{:?}", leftovers(run_id));
    assert!(
        processes_of_run(run_id).is_empty(),
        "{:?}",
        processes_of_run(run_id)
    );
}

#[test]
fn a_c_robot_sent_sigterm_exits_143_and_the_run_goes_on() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("run");
    let child = start_long_run(&dir, &["--set", &program_for_all(goto_c())]);
    let children = children_of(child.id());
    let exe = goto_c().display().to_string();
    let victim = children
        .iter()
        .find(|(_, c)| c.starts_with(&exe) && c.contains("--robot 3 "))
        .map(|(p, _)| *p)
        .unwrap_or_else(|| panic!("robot 3 runs goto-c: {children:?}"));
    unsafe {
        libc::kill(victim, libc::SIGTERM);
    }
    wait_until("robot 3 to exit", LIMIT, || !alive(victim));
    let at = last_tick(&dir);
    wait_until("the run to go on", LIMIT, || last_tick(&dir) >= at + 20);
    unsafe {
        libc::kill(child.id() as i32, libc::SIGINT);
    }
    assert_ok(&wait_with_watchdog(child, LIMIT));
    let m = metrics(&dir);
    assert_eq!(m["dead"], 1, "{m}");
    for p in m["processes"].as_array().unwrap() {
        let want = if p["pid"] == victim {
            "exited with code 143"
        } else {
            "exited with code 0"
        };
        assert_eq!(p["end"], want, "{m}");
    }
    assert_nothing_left(&children, &run_id_of(&children));
}
