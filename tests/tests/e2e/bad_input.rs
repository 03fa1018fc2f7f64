//! A bad config is one clear line naming the file and key, exit code 2, never a panic.

use std::time::Duration;
use swarmrt_tests::swarm;

const LIMIT: Duration = Duration::from_secs(60);

fn refused(args: &[&str], must_mention: &[&str]) {
    let out = swarm(args, LIMIT);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{args:?} -> {err}");
    assert!(!err.contains("panicked"), "{err}");
    assert_eq!(err.trim().lines().count(), 1, "one line: {err}");
    for m in must_mention {
        assert!(err.contains(m), "{args:?}: expected {m:?} in {err}");
    }
}

#[test]
fn unknown_key() {
    let tmp = tempfile::tempdir().unwrap();
    let p = tmp.path().join("typo.toml");
    let text = std::fs::read_to_string(swarmrt_tests::workspace().join("configs/goto_simple.toml"))
        .unwrap();
    std::fs::write(&p, text.replace("capacity = 4", "capacty = 4")).unwrap();
    refused(
        &["check", p.to_str().unwrap()],
        &["typo.toml", "radio.capacty", "unknown field"],
    );
}

#[test]
fn wrong_type() {
    refused(
        &[
            "check",
            "configs/goto_simple.toml",
            "--set",
            "robots.count=\"nine\"",
        ],
        &["goto_simple.toml", "robots.count"],
    );
}

#[test]
fn negative_count() {
    refused(
        &[
            "run",
            "configs/goto_simple.toml",
            "--set",
            "robots.count=-3",
        ],
        &["robots.count"],
    );
}

#[test]
fn loss_above_one_names_its_bounds() {
    refused(
        &["run", "configs/goto_simple.toml", "--set", "radio.loss=1.5"],
        &["radio.loss", "[0, 1]"],
    );
}

#[test]
fn missing_file_and_broken_toml() {
    refused(
        &["check", "configs/does_not_exist.toml"],
        &["does_not_exist.toml"],
    );
    let tmp = tempfile::tempdir().unwrap();
    let p = tmp.path().join("broken.toml");
    std::fs::write(&p, "[scenario\nname = 1").unwrap();
    refused(&["check", p.to_str().unwrap()], &["broken.toml", "TOML"]);
}

#[test]
fn more_robots_than_the_map_has_room_for() {
    refused(
        &[
            "run",
            "configs/goto_simple.toml",
            "--set",
            "robots.count=5000",
        ],
        &["robots.start", "5000"],
    );
}

#[test]
fn issue_5_infinitely_wide_rectangle_is_refused_not_a_panic() {
    // Finite corners whose difference overflows: parry's BVH build used to panic (exit 101).
    refused(
        &[
            "check",
            "configs/goto_simple.toml",
            "--set",
            "map.rectangles=[{ x_min = -1e308, y_min = 1.0, x_max = 1e308, y_max = 2.0 }]",
        ],
        &[
            "goto_simple.toml",
            "map.rectangles[0].x_min",
            "[-1000000, 1000000]",
        ],
    );
}

#[test]
fn issue_5_newline_in_a_key_stays_on_one_line() {
    refused(
        &[
            "check",
            "configs/goto_simple.toml",
            "--set",
            "radio.lo\nss=1",
        ],
        &["radio.lo\\nss", "unknown field"],
    );
}

#[test]
fn issue_5_seed_beyond_toml_integers_is_named_not_called_a_string() {
    // `--seed` takes any u64, but TOML (and so the config) holds at most i64::MAX; the error
    // said "invalid type: string".
    refused(
        &[
            "run",
            "configs/goto_simple.toml",
            "--seed",
            "18446744073709551615",
        ],
        &[
            "scenario.seed",
            "9223372036854775807",
            "18446744073709551615",
        ],
    );
}

// Issue 48: bounded inputs. Each test below performs what the attack did against c0b8b90 and
// failed there (exit 101, an out-of-memory read, a hang, exit 0 or exit 1).

/// `swarm args...` run from `cwd` (so nothing lands in the workspace), with its address
/// space capped at 2 GiB so that a read without a bound fails instead of filling the
/// machine's memory, killed after `limit`.
fn swarm_capped(cwd: &std::path::Path, args: &[&str], limit: Duration) -> std::process::Output {
    use std::os::unix::process::CommandExt;
    use std::process::{Command, Stdio};
    let mut cmd = Command::new(swarmrt_tests::swarm_bin());
    cmd.current_dir(cwd)
        .args(args)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped());
    // SAFETY: setrlimit is async-signal-safe; the closure allocates nothing.
    unsafe {
        cmd.pre_exec(|| {
            let cap = libc::rlimit {
                rlim_cur: 2 << 30,
                rlim_max: 2 << 30,
            };
            if libc::setrlimit(libc::RLIMIT_AS, &cap) != 0 {
                return Err(std::io::Error::last_os_error());
            }
            Ok(())
        });
    }
    swarmrt_tests::wait_with_watchdog(cmd.spawn().expect("swarm starts"), limit)
}

/// Exit 2, one line, no panic, mentioning each of `must_mention`.
fn refused_output(out: &std::process::Output, what: &str, must_mention: &[&str]) {
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(
        out.status.code(),
        Some(2),
        "{what}: {} -> {err}",
        out.status
    );
    assert!(!err.contains("panicked"), "{what}: {err}");
    assert_eq!(err.trim().lines().count(), 1, "{what}: one line: {err}");
    for m in must_mention {
        assert!(err.contains(m), "{what}: expected {m:?} in {err}");
    }
}

fn goto_simple() -> String {
    std::fs::read_to_string(swarmrt_tests::workspace().join("configs/goto_simple.toml")).unwrap()
}

#[test]
fn issue_48_a_degenerate_polygon_is_refused_with_its_index_not_a_parry_panic() {
    // Exit 101 and a backtrace at c0b8b90: parry2d's hull asserts on repeated points...
    refused(
        &[
            "check",
            "configs/goto_simple.toml",
            "--set",
            "map.polygons=[{points=[[1.0,1.0],[1.0,1.0],[1.0,1.0]]}]",
        ],
        &[
            "goto_simple.toml",
            "key `map.polygons[0].points`",
            "at least 3 distinct points",
            "got 1 distinct of its 3 points",
        ],
    );
    // ... and indexes out of bounds on points whose distances square to zero.
    refused(
        &[
            "check",
            "configs/goto_simple.toml",
            "--set",
            "map.polygons=[{points=[[2.0,2.0],[3.0,2.0],[2.0,3.0]]}, {points=[[0.0,0.0],[5e-324,0.0],[0.0,5e-324]]}]",
        ],
        &["key `map.polygons[1].points`", "on one line"],
    );
    refused(
        &[
            "run",
            "configs/goto_simple.toml",
            "--in-process",
            "--set",
            "map.polygons=[{points=[[1.0,1.0],[1.0,1.0],[2.0,2.0]]}]",
        ],
        &[
            "key `map.polygons[0].points`",
            "got 2 distinct of its 3 points",
        ],
    );
}

#[test]
fn issue_48_dev_zero_as_a_config_is_refused_at_once() {
    // c0b8b90 read /dev/zero until memory ran out (here: until the 2 GiB cap aborted it).
    let tmp = tempfile::tempdir().unwrap();
    for verb in ["check", "run", "sweep"] {
        let mut args = vec![verb, "/dev/zero"];
        if verb == "sweep" {
            args.extend(["--vary", "radio.loss=0,0.1"]);
        }
        let out = swarm_capped(tmp.path(), &args, LIMIT);
        refused_output(
            &out,
            &format!("{verb} /dev/zero"),
            &["/dev/zero", "a character device, not a regular file"],
        );
    }
}

#[test]
fn issue_48_a_fifo_as_a_config_is_refused_without_waiting_for_a_writer() {
    // c0b8b90 blocked in open() for ever, deaf to SIGTERM; the watchdog stops a hang here.
    let tmp = tempfile::tempdir().unwrap();
    let fifo = tmp.path().join("config.toml");
    let c = std::ffi::CString::new(fifo.to_str().unwrap()).unwrap();
    // SAFETY: mkfifo on a NUL-terminated path.
    assert_eq!(unsafe { libc::mkfifo(c.as_ptr(), 0o600) }, 0);
    for verb in ["check", "run"] {
        let out = swarm_capped(tmp.path(), &[verb, "config.toml"], Duration::from_secs(30));
        refused_output(
            &out,
            &format!("{verb} on a FIFO"),
            &["config.toml", "a FIFO (named pipe), not a regular file"],
        );
    }
}

#[test]
fn issue_48_a_100_mb_name_is_refused_by_the_file_size() {
    // c0b8b90 accepted it (and then spent minutes drawing it into the plots).
    let tmp = tempfile::tempdir().unwrap();
    let p = tmp.path().join("long_name.toml");
    std::fs::write(
        &p,
        goto_simple().replace("goto_simple", &"n".repeat(100_000_000)),
    )
    .unwrap();
    let out = swarm_capped(tmp.path(), &["check", "long_name.toml"], LIMIT);
    refused_output(
        &out,
        "check of a 100 MB name",
        &[
            "long_name.toml",
            "expected at most 1048576 bytes (1 MiB), got 100000",
        ],
    );
    assert!(out.stdout.is_empty(), "nothing printed");
}

#[test]
fn issue_48_a_300_character_name_is_refused_before_any_directory_is_made() {
    // c0b8b90 exited 1: the run directory's name was too long for the file system.
    let tmp = tempfile::tempdir().unwrap();
    let config = swarmrt_tests::workspace().join("configs/goto_simple.toml");
    let name = format!("scenario.name={}", "a".repeat(300));
    let config = config.to_str().unwrap();
    for args in [
        vec!["check", config, "--set", &name],
        vec![
            "run",
            config,
            "--in-process",
            "--ticks",
            "3",
            "--set",
            &name,
        ],
    ] {
        let verb = args[0];
        let out = swarm_capped(tmp.path(), &args, LIMIT);
        refused_output(
            &out,
            &format!("{verb} with a 300-character name"),
            &[
                "goto_simple.toml",
                "key `scenario.name`",
                "at most 64 bytes",
                "got 300 bytes",
            ],
        );
    }
    assert_eq!(
        std::fs::read_dir(tmp.path()).unwrap().count(),
        0,
        "no runs/ made"
    );
}

/// `goto_simple` with one polygon of `n` vertices on a circle in the robots' way.
fn polygon_config(n: usize) -> String {
    let points: Vec<String> = (0..n)
        .map(|i| {
            let a = i as f64 * std::f64::consts::TAU / n as f64;
            format!("[{:.6}, {:.6}]", 5.0 + a.cos(), 5.5 + a.sin())
        })
        .collect();
    let text = goto_simple();
    let (head, rest) = text.split_once("polygons = [").unwrap();
    let (_, rest) = rest.split_once("\n]").unwrap();
    format!(
        "{head}polygons = [\n  {{ points = [{}] }},\n]{rest}",
        points.join(", ")
    )
}

#[test]
fn issue_48_a_million_vertex_polygon_is_refused_and_one_at_the_cap_runs() {
    // c0b8b90 accepted 1,000,000 vertices; its 3-tick run did not finish in a minute.
    let tmp = tempfile::tempdir().unwrap();
    std::fs::write(tmp.path().join("million.toml"), polygon_config(1_000_000)).unwrap();
    let out = swarm_capped(
        tmp.path(),
        &[
            "run",
            "million.toml",
            "--ticks",
            "3",
            "--in-process",
            "--out",
            "run",
        ],
        LIMIT,
    );
    refused_output(
        &out,
        "a 1,000,000-vertex polygon",
        &["million.toml", "at most 1048576 bytes"],
    );
    // Within the file bound, the vertex bound holds.
    std::fs::write(tmp.path().join("over.toml"), polygon_config(257)).unwrap();
    let out = swarm_capped(tmp.path(), &["check", "over.toml"], LIMIT);
    refused_output(
        &out,
        "a 257-vertex polygon",
        &[
            "over.toml",
            "key `map.polygons[0].points`",
            "3 to 256 points [x, y], got 257",
        ],
    );
    // At the bound, a short run (as processes, and in-process) finishes well within the
    // watchdog.
    std::fs::write(tmp.path().join("cap.toml"), polygon_config(256)).unwrap();
    for extra in [&["--in-process"][..], &[]] {
        let mut args = vec!["run", "cap.toml", "--ticks", "3", "--out"];
        let out_dir = format!("cap{}", extra.len());
        args.push(&out_dir);
        args.extend_from_slice(extra);
        let out = swarm_capped(tmp.path(), &args, LIMIT);
        assert!(
            out.status.success(),
            "{args:?}: {}",
            String::from_utf8_lossy(&out.stderr)
        );
    }
}

#[test]
fn issue_48_an_empty_robot_program_is_refused_as_documented() {
    // c0b8b90 accepted `robots.program = []` (docs/config.md: "a command line whose first
    // word is a program").
    refused(
        &[
            "check",
            "configs/goto_simple.toml",
            "--set",
            "robots.program=[]",
        ],
        &[
            "goto_simple.toml",
            "key `robots.program`",
            "got [] (for the built-in robot leave the key out or write [\"swarm-agent\"])",
        ],
    );
    let tmp = tempfile::tempdir().unwrap();
    let p = tmp.path().join("empty_program.toml");
    std::fs::write(
        &p,
        goto_simple().replace("[robots]\n", "[robots]\nprogram = []\n"),
    )
    .unwrap();
    refused(
        &["run", p.to_str().unwrap(), "--ticks", "3"],
        &["empty_program.toml", "key `robots.program`"],
    );
}

#[test]
fn issue_48_a_working_directory_removed_under_the_shell_is_a_user_error() {
    // c0b8b90 exited 1 with a bare "No such file or directory (os error 2)".
    let tmp = tempfile::tempdir().unwrap();
    let gone = tmp.path().join("gone");
    std::fs::create_dir(&gone).unwrap();
    let config = swarmrt_tests::workspace().join("configs/goto_simple.toml");
    let out = {
        use std::os::unix::process::CommandExt;
        use std::process::{Command, Stdio};
        let gone = gone.clone();
        let mut cmd = Command::new(swarmrt_tests::swarm_bin());
        cmd.args(["check", config.to_str().unwrap()])
            .stdin(Stdio::null())
            .stdout(Stdio::piped())
            .stderr(Stdio::piped());
        let c = std::ffi::CString::new(gone.to_str().unwrap()).unwrap();
        // SAFETY: chdir and rmdir are async-signal-safe; `c` is NUL-terminated.
        unsafe {
            cmd.pre_exec(move || {
                if libc::chdir(c.as_ptr()) != 0 || libc::rmdir(c.as_ptr()) != 0 {
                    return Err(std::io::Error::last_os_error());
                }
                Ok(())
            });
        }
        swarmrt_tests::wait_with_watchdog(cmd.spawn().expect("swarm starts"), LIMIT)
    };
    refused_output(
        &out,
        "check from a removed directory",
        &["goto_simple.toml", "the current directory is gone"],
    );
}
