//! Another user of the same host attacks a run (docs/security.md, "Local users"): as uid
//! 47123 (`swarmrt_tests::stranger`), with the shell tools anyone has. Each test performs an
//! attack that worked against c0b8b90 and checks that it now fails and the run goes on.

use std::path::Path;
use std::process::Command;
use std::time::Duration;

use swarmrt_tests::stranger::{STRANGER, quote};
use swarmrt_tests::{
    assert_nothing_left, children_of, last_tick, run_id_of, swarm_bin, wait_until,
    wait_with_watchdog, workspace,
};

/// The shared-memory segments of `run_id` in /dev/shm.
fn segments(run_id: &str) -> Vec<String> {
    let prefix = swarmrt_protocol::services::shm_prefix_of(run_id);
    let mut found: Vec<String> = std::fs::read_dir("/dev/shm")
        .unwrap()
        .flatten()
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .filter(|n| n.starts_with(&prefix))
        .collect();
    found.sort();
    found
}

/// A run whose robot 0 thinks 250 ms a tick (so ticks come at ~4/s and the attack lands well
/// before `restart_tick`), robot 2 restarted at `restart_tick`, in `dir`.
fn slow_run_with_restart(dir: &Path, restart_tick: u64) -> std::process::Child {
    Command::new(swarm_bin())
        .current_dir(workspace())
        .args(["run", "configs/goto_simple.toml", "--out"])
        .arg(dir)
        .args([
            "--ticks",
            &(restart_tick + 30).to_string(),
            "--set",
            "scenario.stop_when_done=false",
            "--set",
            &format!("faults.restart=[{{tick={restart_tick},robot=2,down_ticks=5}}]"),
        ])
        .env("SWARMRT_TEST_MISBEHAVE", "0:slow")
        .stdin(std::process::Stdio::null())
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .expect("swarm starts")
}

/// c0b8b90: iceoryx2 made the run's `..._node.0_10_0.global_mgmt` segment 0666; truncated by
/// another user, it made every later node creation wait for ever, so the scheduled restart
/// hung the robot and the world with it. Now no segment of the run can be truncated by
/// another user, and the restart happens.
#[test]
fn another_user_cannot_truncate_a_runs_segments_and_a_restart_after_the_attempt_goes_on() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("run");
    let restart = 24;
    let child = slow_run_with_restart(&dir, restart);
    let pid = child.id();
    wait_until("the run to record 2 ticks", Duration::from_secs(60), || {
        last_tick(&dir) >= 2
    });
    let kids = children_of(pid);
    let run_id = run_id_of(&kids);
    let before = segments(&run_id);
    assert!(
        before.iter().any(|n| n.ends_with("global_mgmt")),
        "the run has its management segment: {before:?}"
    );
    // The attack: truncate every segment of the run to nothing.
    let script = format!(
        "for f in /dev/shm/{}*; do truncate -s 0 \"$f\" && echo \"truncated $f\"; done; true",
        swarmrt_protocol::services::shm_prefix_of(&run_id)
    );
    let out = STRANGER.sh(&script, Duration::from_secs(30));
    let said = String::from_utf8_lossy(&out.stdout);
    let attacked_at = last_tick(&dir);
    assert!(
        attacked_at < restart,
        "the attack must come before the restart at tick {restart} to test it (came at {attacked_at})"
    );
    assert!(
        !said.contains("truncated"),
        "another user truncated a segment of the run:\n{said}"
    );
    for name in &before {
        let meta = std::fs::metadata(Path::new("/dev/shm").join(name));
        if let Ok(m) = meta {
            use std::os::unix::fs::PermissionsExt;
            assert_eq!(
                m.permissions().mode() & 0o077,
                0,
                "{name} is open to group or others"
            );
        }
    }
    // The run goes on through the restart and ends by itself.
    let out = wait_with_watchdog(child, Duration::from_secs(120));
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let m = swarmrt_tests::metrics(&dir);
    let restarted = swarmrt_tests::processes_of(&m, 2);
    assert!(
        restarted
            .iter()
            .any(|(incarnation, _, _)| *incarnation == 1),
        "robot 2 was restarted: {restarted:?}"
    );
    assert_nothing_left(&kids, &run_id);
}

/// A refused base says what the user can do: another user who made `/dev/shm/swarmrt-<uid>`
/// first cannot be removed by its victim (sticky /dev/shm), so the line names
/// `SWARMRT_SHM_BASE` and root rather than "remove it".
#[test]
fn a_base_squatted_by_another_user_is_refused_with_what_to_do() {
    let base = format!("/dev/shm/sq-{}", std::process::id());
    let _ = std::fs::remove_dir_all(&base);
    // The stranger makes the victim's base first.
    let out = STRANGER.sh(
        &format!("mkdir -m 700 {}", quote(&base)),
        Duration::from_secs(10),
    );
    assert!(out.status.success(), "{out:?}");
    let run = Command::new(swarm_bin())
        .current_dir(workspace())
        .args(["run", "configs/goto_simple.toml", "--ticks", "3", "--out"])
        .arg(Path::new(&std::env::temp_dir()).join(format!("sq-run-{}", std::process::id())))
        .env("SWARMRT_SHM_BASE", &base)
        .stdin(std::process::Stdio::null())
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let out = wait_with_watchdog(run, Duration::from_secs(60));
    let _ = std::fs::remove_dir_all(&base);
    let _ = std::fs::remove_dir_all(
        Path::new(&std::env::temp_dir()).join(format!("sq-run-{}", std::process::id())),
    );
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(
        err.contains("another user made it first") && err.contains("SWARMRT_SHM_BASE"),
        "{err}"
    );
    assert_eq!(err.trim().lines().count(), 1, "one line: {err}");
}

/// A login session's `$XDG_RUNTIME_DIR` (a tmpfs of the user's own, which no one else can
/// create first) holds the run's files when it exists, instead of the world-writable
/// /dev/shm; and nothing is left there after the run.
#[test]
fn a_private_xdg_runtime_dir_is_preferred_for_the_base() {
    use std::os::unix::fs::PermissionsExt;
    let xdg = format!("/dev/shm/x{}", std::process::id());
    let _ = std::fs::remove_dir_all(&xdg);
    std::fs::create_dir(&xdg).unwrap();
    std::fs::set_permissions(&xdg, std::fs::Permissions::from_mode(0o700)).unwrap();
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("run");
    let child = Command::new(swarm_bin())
        .current_dir(workspace())
        .args([
            "run",
            "configs/goto_simple.toml",
            "--ticks",
            "100000",
            "--set",
            "scenario.stop_when_done=false",
            "--out",
        ])
        .arg(&dir)
        .env("XDG_RUNTIME_DIR", &xdg)
        .env_remove("SWARMRT_SHM_BASE")
        .stdin(std::process::Stdio::null())
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let pid = child.id();
    wait_until("the run to record 5 ticks", Duration::from_secs(60), || {
        last_tick(&dir) >= 5
    });
    let run_id = run_id_of(&children_of(pid));
    let root = Path::new(&xdg).join("swarmrt").join(&run_id);
    let in_xdg = root.is_dir();
    let mode = std::fs::metadata(Path::new(&xdg).join("swarmrt"))
        .map(|m| m.permissions().mode() & 0o777)
        .unwrap_or(0);
    // SAFETY: SIGINT to the orchestrator we started.
    unsafe { libc::kill(pid as i32, libc::SIGINT) };
    let out = wait_with_watchdog(child, Duration::from_secs(60));
    let left = std::fs::read_dir(Path::new(&xdg).join("swarmrt"))
        .map(|d| d.count())
        .unwrap_or(0);
    let _ = std::fs::remove_dir_all(&xdg);
    assert!(in_xdg, "the run's root is not under {xdg}/swarmrt");
    assert_eq!(mode, 0o700);
    assert_eq!(left, 0, "the run left files in {xdg}/swarmrt");
    assert!(
        out.status.success() || out.status.code() == Some(130),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
}

/// `swarm run --out <dir>` as the test's user, within a minute.
fn run_into(out: &Path, extra: &[&str]) -> std::process::Output {
    let child = Command::new(swarm_bin())
        .current_dir(workspace())
        .args(["run", "configs/goto_simple.toml", "--ticks", "5", "--out"])
        .arg(out)
        .args(extra)
        .stdin(std::process::Stdio::null())
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .expect("swarm starts");
    wait_with_watchdog(child, Duration::from_secs(60))
}

/// The victim's project: a directory of this user holding its own `config.toml`.
fn victims_project(under: &Path) -> std::path::PathBuf {
    let project = under.join("victim-project");
    std::fs::create_dir_all(&project).unwrap();
    std::fs::write(project.join("config.toml"), "# the victim's own config\n").unwrap();
    std::fs::write(project.join("metrics.json"), "{\"mine\": true}\n").unwrap();
    project
}

fn assert_untouched(project: &Path) {
    assert_eq!(
        std::fs::read_to_string(project.join("config.toml")).unwrap(),
        "# the victim's own config\n"
    );
    assert_eq!(
        std::fs::read_to_string(project.join("metrics.json")).unwrap(),
        "{\"mine\": true}\n"
    );
    let names: Vec<String> = std::fs::read_dir(project)
        .unwrap()
        .flatten()
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .collect();
    assert_eq!(
        names.len(),
        2,
        "the run wrote into the victim's project: {names:?}"
    );
}

/// c0b8b90: `--out` accepted an empty directory another user owned and anyone could write,
/// under /tmp; swapped for a link to the victim's project after the run marked it, it made
/// the run overwrite the victim's own `config.toml` and write every record there. Now such
/// a directory is refused before anything is written, however the stranger swaps it.
#[test]
fn an_out_another_user_owns_or_can_write_is_refused_and_a_swap_redirects_nothing() {
    let tmp = swarmrt_tests::stranger::OpenScratch::new("out-attack");
    let project = victims_project(&tmp.0);
    // The stranger's trap: a world-writable empty directory of theirs in a sticky directory.
    let sticky = tmp.0.join("shared");
    std::fs::create_dir(&sticky).unwrap();
    use std::os::unix::fs::PermissionsExt;
    std::fs::set_permissions(&sticky, std::fs::Permissions::from_mode(0o1777)).unwrap();
    let trap = sticky.join("run");
    let out = STRANGER.sh(
        &format!("mkdir -m 777 {}", quote(&trap.display().to_string())),
        Duration::from_secs(10),
    );
    assert!(out.status.success(), "{out:?}");
    // Swapping it for a link to the victim's project, over and over, while the run starts.
    let swapper = STRANGER
        .command("sh")
        .arg("-c")
        .arg(format!(
            "t={t}; p={p}; end=$(( $(date +%s) + 20 )); while [ $(date +%s) -lt $end ]; do \
             mv \"$t\" \"$t.old\" 2>/dev/null; ln -s \"$p\" \"$t\" 2>/dev/null; \
             rm -f \"$t\" 2>/dev/null; mv \"$t.old\" \"$t\" 2>/dev/null; done",
            t = quote(&trap.display().to_string()),
            p = quote(&project.display().to_string()),
        ))
        .spawn()
        .unwrap();
    for _ in 0..5 {
        let out = run_into(&trap, &[]);
        let err = String::from_utf8_lossy(&out.stderr);
        if out.status.success() {
            // The run caught the name free mid-swap and made the directory itself: then it
            // is this user's own real directory, and the records are in it.
            use std::os::unix::fs::MetadataExt;
            let meta = std::fs::symlink_metadata(&trap).unwrap();
            assert!(meta.is_dir() && meta.uid() == 0, "{meta:?}");
            assert!(trap.join("trajectory.csv").is_file());
            break;
        }
        assert_eq!(out.status.code(), Some(2), "{err}");
        assert!(err.contains("refusing"), "{err}");
        assert_eq!(err.trim().lines().count(), 1, "one line: {err}");
    }
    let mut swapper = swapper;
    let _ = swapper.kill();
    let _ = swapper.wait();
    assert_untouched(&project);

    // Not theirs, but open to everyone (mode 0777): refused too, with what to do.
    let open = tmp.0.join("open");
    std::fs::create_dir(&open).unwrap();
    std::fs::set_permissions(&open, std::fs::Permissions::from_mode(0o777)).unwrap();
    let out = run_into(&open, &[]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(
        err.contains("group or others may write it (mode 0777)"),
        "{err}"
    );
    assert_eq!(
        std::fs::read_dir(&open).unwrap().count(),
        0,
        "nothing written"
    );
}

/// A directory of the stranger on the way to `--out` (not sticky-safe: they may rename what
/// it holds) is refused, for `swarm sweep`, `swarm tune` and `swarm export` as for `run`.
#[test]
fn every_output_under_a_directory_another_user_controls_is_refused() {
    let tmp = swarmrt_tests::stranger::OpenScratch::new("out-parent");
    let theirs = tmp.0.join("theirs");
    STRANGER.own(&theirs, 0o755);
    // The victim's own directory inside it: the stranger can still swap it.
    let inside = theirs.join("mine");
    std::fs::create_dir(&inside).unwrap();
    let run = tempfile::tempdir().unwrap();
    let done = run_into(&run.path().join("r"), &[]);
    assert!(
        done.status.success(),
        "{}",
        String::from_utf8_lossy(&done.stderr)
    );
    let r = run.path().join("r");
    let cases: Vec<Vec<String>> = vec![
        vec![
            "run".into(),
            "configs/goto_simple.toml".into(),
            "--ticks".into(),
            "3".into(),
            "--out".into(),
            inside.display().to_string(),
        ],
        vec![
            "sweep".into(),
            "configs/goto_simple.toml".into(),
            "--vary".into(),
            "radio.loss=0.0".into(),
            "--set".into(),
            "scenario.ticks=3".into(),
            "--in-process".into(),
            "--out".into(),
            inside.join("sweep").display().to_string(),
        ],
        vec![
            "tune".into(),
            "configs/goto_simple.toml".into(),
            "--param".into(),
            "radio.loss=0:0.5".into(),
            "--fitness".into(),
            "collisions".into(),
            "--iterations".into(),
            "1".into(),
            "--particles".into(),
            "2".into(),
            "--set".into(),
            "scenario.ticks=3".into(),
            "--in-process".into(),
            "--out".into(),
            inside.join("tune").display().to_string(),
        ],
        vec![
            "export".into(),
            r.display().to_string(),
            "--mcap".into(),
            inside.join("run.mcap").display().to_string(),
        ],
    ];
    for args in cases {
        let child = Command::new(swarm_bin())
            .current_dir(workspace())
            .args(&args)
            .stdin(std::process::Stdio::null())
            .stdout(std::process::Stdio::piped())
            .stderr(std::process::Stdio::piped())
            .spawn()
            .unwrap();
        let out = wait_with_watchdog(child, Duration::from_secs(120));
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "swarm {}: {err}", args[0]);
        assert!(
            err.contains("is owned by uid 47123"),
            "swarm {}: {err}",
            args[0]
        );
        assert_eq!(
            std::fs::read_dir(&inside).unwrap().count(),
            0,
            "swarm {} wrote into it",
            args[0]
        );
    }
}
