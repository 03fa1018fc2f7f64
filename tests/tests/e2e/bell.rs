//! The tick bell (issue 34): robots of this build, in Rust, C and Python, sleep on the run's
//! futex word, which the world rings once per tick; a robot that knows no bell (one written
//! against iceoryx2 alone) still gets every tick through the observation event; and frozen,
//! killed, restarted and hung robots leave the others ticking, with the records of Rust
//! robots.

use std::path::{Path, PathBuf};
use std::time::Duration;

use swarmrt_tests::c_robot::goto_c;
use swarmrt_tests::python::{self, example};
use swarmrt_tests::*;

const LIMIT: Duration = Duration::from_secs(120);

/// A Python go-to robot that knows no bell: `examples/python/goto.py` with the bell refused,
/// so the package falls back to a listener of the observation event, as a robot written
/// against iceoryx2 alone would sleep.
fn listening_goto(dir: &Path) -> PathBuf {
    let script = dir.join("listening_goto.py");
    std::fs::write(
        &script,
        format!(
            "import runpy, sys\n\
             import swarmrt.robot\n\
             def _no_bell(root):\n    raise OSError('no bell: listen instead')\n\
             swarmrt.robot.Bell = _no_bell\n\
             sys.argv = [{goto:?}]\n\
             runpy.run_path({goto:?}, run_name='__main__')\n",
            goto = example("goto.py").display().to_string()
        ),
    )
    .unwrap();
    script
}

/// `robots.programs`: robot 3 Python on the bell, 4 Python on a listener, 5 C; the others
/// are the built-in Rust robot.
fn mixed(dir: &Path) -> String {
    let py = python::python().display().to_string();
    let goto_py = example("goto.py").display().to_string();
    let listening = listening_goto(dir).display().to_string();
    let c = goto_c().display().to_string();
    format!(
        "robots.programs=[{{robots=\"3\",program=[{py:?},{goto_py:?}]}},\
         {{robots=\"4\",program=[{py:?},{listening:?}]}},\
         {{robots=\"5\",program=[{c:?}]}}]"
    )
}

#[test]
fn robots_of_every_language_and_a_listening_one_write_the_rust_records_under_faults() {
    let tmp = tempfile::tempdir().unwrap();
    let t = tmp.path();
    // A freeze on the bell robot, a kill of the C robot, restarts of the listening robot and
    // of a Rust one: each wakes (or not) on its own path.
    let faults = [
        "--ticks",
        "150",
        "--set",
        "faults.freeze=[{robot=3,from=30,to=60}]",
        "--set",
        "faults.kill=[{tick=80,robot=5}]",
        "--set",
        "faults.restart=[{tick=90,robot=4,down_ticks=10},{tick=95,robot=6,down_ticks=5}]",
    ];
    run_config("configs/goto_simple.toml", &t.join("rust"), &faults);
    let programs = mixed(t);
    let mut args = faults.to_vec();
    args.extend_from_slice(&["--set", &programs]);
    let m = run_config("configs/goto_simple.toml", &t.join("mixed"), &args);
    assert_same_records(
        &t.join("rust"),
        &t.join("mixed"),
        "mixed robots on the bell",
    );
    assert_eq!(m["ticks"], 150, "{m}");
    assert_eq!(m["reproducible"], true, "{m}");
    assert_eq!(m["unscheduled_deaths"], serde_json::json!([]), "{m}");
    assert_eq!(m["frozen_ticks"], 30, "{m}");
    // The listening robot's fresh process (incarnation 1) got the ticks after its restart.
    assert_eq!(
        processes_of(&m, 4),
        vec![
            (0, "killed by signal 9".to_string(), true),
            (1, "exited with code 0".to_string(), false)
        ]
    );
}

/// The system call each of `pids` is blocked in now (`/proc/<pid>/syscall`'s first field;
/// None while it runs).
fn blocked_in(pid: i32) -> Option<i64> {
    let s = std::fs::read_to_string(format!("/proc/{pid}/syscall")).ok()?;
    s.split_whitespace().next()?.parse().ok()
}

#[test]
fn robots_sleep_on_the_bell_and_a_hung_robot_does_not_stop_the_others() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("run");
    let py = python::python().display().to_string();
    let hang = example("misbehave.py").display().to_string();
    // Robot 7 thinks for a minute on its first tick: it never answers.
    let programs = mixed(tmp.path()).replace(
        "]}]",
        &format!("]}},{{robots=\"7\",program=[{py:?},{hang:?},\"slow:60000\"]}}]"),
    );
    let child = start_long_run(
        &dir,
        &[
            "--set",
            &programs,
            "--set",
            "scenario.deadline_ms=300",
            "--set",
            "scenario.unresponsive_ms=1500",
        ],
    );
    let children = children_of(child.id());
    let robot = |id: u32| {
        children
            .iter()
            .find(|(_, c)| {
                c.contains(&format!("--robot {id} "))
                    || (id == 3 && c.contains("goto.py") && !c.contains("listening"))
            })
            .map(|(p, _)| *p)
            .unwrap_or_else(|| panic!("no process of robot {id} in {children:?}"))
    };
    // The hung robot was given up after 1.5 s (it may be gone already): the ticks go on.
    let at = last_tick(&dir);
    wait_until("the run to go on without it", LIMIT, || {
        last_tick(&dir) > at + 30
    });
    let listening = children
        .iter()
        .find(|(_, c)| c.contains("listening_goto.py"))
        .map(|(p, _)| *p)
        .expect("the listening robot's process");
    let c_robot = children
        .iter()
        .find(|(_, c)| c.contains("goto-c"))
        .map(|(p, _)| *p)
        .expect("the C robot's process");
    let on_bell = [
        ("rust robot 0", robot(0)),
        ("python robot 3", robot(3)),
        ("c robot 5", c_robot),
    ];
    // Sample where each robot is blocked: a robot spends most of a tick asleep.
    let mut futex = vec![0usize; on_bell.len() + 1];
    let mut blocked = vec![0usize; on_bell.len() + 1];
    for _ in 0..200 {
        for (i, pid) in on_bell.iter().map(|r| r.1).chain([listening]).enumerate() {
            if let Some(call) = blocked_in(pid) {
                blocked[i] += 1;
                futex[i] += usize::from(call == libc::SYS_futex);
            }
        }
        std::thread::sleep(Duration::from_millis(5));
    }
    for (i, (name, _)) in on_bell.iter().enumerate() {
        assert!(
            blocked[i] >= 50 && futex[i] * 10 >= blocked[i] * 9,
            "{name} sleeps on the bell: futex in {} of {} blocked samples",
            futex[i],
            blocked[i]
        );
    }
    let l = on_bell.len();
    assert!(
        blocked[l] >= 50 && futex[l] * 10 <= blocked[l],
        "the listening robot sleeps in its listener: futex in {} of {} blocked samples",
        futex[l],
        blocked[l]
    );
    unsafe {
        libc::kill(child.id() as i32, libc::SIGINT);
    }
    let out = wait_with_watchdog(child, LIMIT);
    assert_ok(&out);
    let m = metrics(&dir);
    assert_eq!(m["dead"], 1, "{m}");
    assert_eq!(m["unscheduled_deaths"][0]["robot"], 7, "{m}");
    assert_nothing_left(&children, &run_id_of(&children));
}
