//! Each user's runs keep their iceoryx2 files under a private base, `/dev/shm/swarmrt-<euid>`
//! (issue 32): another local user can neither list a run, nor read its shared memory, nor
//! move or remove its files; and a base that is not private (another user's, writable by
//! group or others, a symbolic link) is refused before anything is written in it.
//!
//! The refused bases are made under `SWARMRT_SHM_BASE=/dev/shm/swarmrt-test-<random>`, never
//! at the real base, which the runs of tests running beside these share.

use std::os::unix::fs::{MetadataExt, PermissionsExt};
use std::path::{Path, PathBuf};
use std::process::Output;
use std::time::Duration;

use swarmrt_protocol::services::{SHM_BASE_ENV, euid, ipc_base_dir, ipc_root_of, shm_prefix_of};
use swarmrt_tests::stranger::{STRANGER, require_root};
use swarmrt_tests::*;

const LIMIT: Duration = Duration::from_secs(120);
/// `program args...` as another local user ([`STRANGER`], through `setpriv`).
fn as_other(program: &str, args: &[&Path]) -> Output {
    STRANGER
        .command(program)
        .args(args)
        .output()
        .expect("setpriv starts")
}

/// Asserts `out` failed with "Permission denied" or "Operation not permitted".
fn assert_denied(out: &Output, what: &str) {
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        !out.status.success()
            && (err.contains("Permission denied") || err.contains("Operation not permitted")),
        "{what} as uid {}: {} {err:?} {:?}",
        STRANGER.uid,
        out.status,
        String::from_utf8_lossy(&out.stdout)
    );
}

/// A run in the background, stopped (Ctrl-C, then SIGKILL) if the test fails before it
/// stops it itself.
struct Running(Option<std::process::Child>);

impl Drop for Running {
    fn drop(&mut self) {
        if let Some(mut child) = self.0.take() {
            unsafe {
                libc::kill(child.id() as i32, libc::SIGINT);
            }
            let start = std::time::Instant::now();
            while child.try_wait().ok().flatten().is_none() {
                if start.elapsed() > LIMIT {
                    let _ = child.kill();
                    let _ = child.wait();
                    break;
                }
                std::thread::sleep(Duration::from_millis(50));
            }
        }
    }
}

#[test]
fn another_user_can_neither_read_nor_replace_a_running_run() {
    // Acting as another user needs root (CI runs the suite as root): fails here otherwise.
    require_root();
    let other = STRANGER.uid;
    // Acting as someone else for real, before anything that would harm the run if not.
    let who = as_other("id", &[Path::new("-u")]);
    assert_eq!(
        String::from_utf8_lossy(&who.stdout).trim(),
        other.to_string(),
        "setpriv acts as the stranger"
    );
    assert_ne!(other, euid());

    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("run");
    let mut run = Running(Some(start_long_run(&dir, &[])));
    let child = run.0.as_ref().unwrap();
    let children = children_of(child.id());
    let run_id = run_id_of(&children);

    let base = ipc_base_dir();
    let root = ipc_root_of(&run_id);
    assert!(root.is_dir(), "the run's root {} exists", root.display());
    let meta = std::fs::symlink_metadata(&base).unwrap();
    assert!(meta.is_dir());
    assert_eq!(meta.uid(), euid(), "the base is this user's");
    assert_eq!(meta.mode() & 0o777, 0o700, "the base is private");
    let prefix = shm_prefix_of(&run_id);
    let (shared, segments): (Vec<PathBuf>, Vec<PathBuf>) = std::fs::read_dir("/dev/shm")
        .unwrap()
        .flatten()
        .filter(|e| e.file_name().to_string_lossy().starts_with(&prefix))
        .map(|e| e.path())
        .partition(|p| p.extension().is_some_and(|x| x == "global_mgmt"));
    assert!(!segments.is_empty(), "the run has shared-memory segments");
    for s in &segments {
        let mode = std::fs::metadata(s).unwrap().mode() & 0o777;
        assert_eq!(mode, 0o600, "{} is private", s.display());
    }
    // The one exception, iceoryx2's own choice (`enable_global_access`): its node counter
    // (`node.<version>.global_mgmt`, 16 bytes, no data of the run) is 0666 so that every
    // user's processes of an iceoryx2 domain can count nodes.
    assert!(shared.len() <= 1, "{shared:?}");
    let inside: Vec<PathBuf> = std::fs::read_dir(&root)
        .unwrap()
        .flatten()
        .map(|e| e.path())
        .collect();
    assert!(!inside.is_empty(), "iceoryx2 keeps files in the run's root");

    // Nothing can be listed or read...
    assert_denied(&as_other("ls", &[&base]), "ls the base");
    assert_denied(&as_other("ls", &[&root]), "ls the run's root");
    for p in &inside {
        assert_denied(&as_other("ls", &[p]), "ls in the run's root");
    }
    for s in &segments {
        assert_denied(&as_other("cat", &[s]), "cat a segment");
    }
    // ...nor moved away, removed or replaced.
    let aside = base.with_file_name(format!("swarmrt-moved-{}", std::process::id()));
    assert_denied(&as_other("mv", &[&base, &aside]), "mv the base");
    assert_denied(
        &as_other("rm", &[Path::new("-rf"), &root]),
        "rm -rf the root",
    );
    assert_denied(
        &as_other("rm", &[Path::new("-rf"), &base]),
        "rm -rf the base",
    );
    assert!(!aside.exists());
    assert!(root.is_dir() && segments.iter().all(|s| s.exists()));

    // The run never noticed.
    let at = last_tick(&dir);
    wait_until("the run to go on", LIMIT, || last_tick(&dir) > at + 20);
    let child = run.0.take().unwrap();
    unsafe {
        libc::kill(child.id() as i32, libc::SIGINT);
    }
    assert_ok(&wait_with_watchdog(child, LIMIT));
    assert_eq!(metrics(&dir)["unscheduled_deaths"], serde_json::json!([]));
    assert_nothing_left(&children, &run_id);
}

/// A base for one test under `/dev/shm`, never the real one; removed when dropped. Short
/// (`/dev/shm/swarmrt-t<8 hex>`, 26 bytes): iceoryx2's socket paths under a base longer than
/// 27 bytes would not fit, and `swarm` refuses such a base.
struct TestBase(PathBuf);

impl TestBase {
    fn new() -> TestBase {
        use std::hash::{BuildHasher, RandomState};
        let h = RandomState::new().hash_one((std::process::id(), std::time::Instant::now()));
        TestBase(PathBuf::from(format!(
            "/dev/shm/swarmrt-t{:08x}",
            h & 0xffff_ffff
        )))
    }
}

impl Drop for TestBase {
    fn drop(&mut self) {
        let _ = std::fs::remove_file(&self.0);
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

/// `swarm run configs/goto_simple.toml` with its iceoryx2 files under `base`.
fn run_with_base(base: &Path, out: &Path, extra: &[&str]) -> Output {
    let mut args = vec![
        "run",
        "configs/goto_simple.toml",
        "--ticks",
        "50",
        "--out",
        out.to_str().unwrap(),
    ];
    args.extend_from_slice(extra);
    let child = spawn_swarm(&args, &[(SHM_BASE_ENV, base.to_str().unwrap())]);
    wait_with_watchdog(child, LIMIT)
}

/// Asserts `swarm` refused `base` with exactly `line` on one line of its stderr, and left
/// `empty` (the base, or where it points) empty.
fn assert_refused(out: &Output, line: &str, empty: &Path) {
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(
        out.status.code(),
        Some(2),
        "a bad base is the user's to fix: {err}"
    );
    assert!(
        err.lines().any(|l| l.contains(line)),
        "stderr names the path and the reason in one line ({line:?}):\n{err}"
    );
    let left: Vec<_> = std::fs::read_dir(empty).unwrap().flatten().collect();
    assert!(left.is_empty(), "nothing is written in it: {left:?}");
}

#[test]
fn a_base_owned_by_another_user_is_refused() {
    // Giving a directory to another user needs root: fails here otherwise.
    require_root();
    let other = STRANGER.uid;
    let tmp = tempfile::tempdir().unwrap();
    let base = TestBase::new();
    std::fs::create_dir(&base.0).unwrap();
    std::fs::set_permissions(&base.0, std::fs::Permissions::from_mode(0o700)).unwrap();
    std::os::unix::fs::chown(&base.0, Some(other), None).unwrap();
    let out = run_with_base(&base.0, &tmp.path().join("run"), &[]);
    let line = format!(
        "refusing the shared-memory root {}: owned by uid {other}, not by you (uid {}): \
         another user made it first, and only they or root can remove it; set \
         SWARMRT_SHM_BASE to a directory of your own",
        base.0.display(),
        euid()
    );
    assert_refused(&out, &line, &base.0);
}

#[test]
fn a_base_group_or_others_may_write_is_refused() {
    let tmp = tempfile::tempdir().unwrap();
    for mode in [0o770, 0o777] {
        let base = TestBase::new();
        std::fs::create_dir(&base.0).unwrap();
        std::fs::set_permissions(&base.0, std::fs::Permissions::from_mode(mode)).unwrap();
        let out = run_with_base(&base.0, &tmp.path().join(format!("run-{mode:o}")), &[]);
        let line = format!(
            "refusing the shared-memory root {}: group or others may access it \
             (mode {mode:04o}); chmod 700 it",
            base.0.display()
        );
        assert_refused(&out, &line, &base.0);
        // Refused, not silently tightened.
        assert_eq!(std::fs::metadata(&base.0).unwrap().mode() & 0o777, mode);
    }
}

#[test]
fn this_users_base_others_may_only_read_is_made_private() {
    // As iceoryx2 leaves a base it made itself (for a program that opened a run's node
    // without claiming the run first): 0750, nothing in it anyone else could have written.
    let tmp = tempfile::tempdir().unwrap();
    let base = TestBase::new();
    std::fs::create_dir(&base.0).unwrap();
    std::fs::set_permissions(&base.0, std::fs::Permissions::from_mode(0o750)).unwrap();
    let dir = tmp.path().join("run");
    assert_ok(&run_with_base(&base.0, &dir, &[]));
    assert_eq!(std::fs::metadata(&base.0).unwrap().mode() & 0o777, 0o700);
    let left: Vec<_> = std::fs::read_dir(&base.0).unwrap().flatten().collect();
    assert!(left.is_empty(), "the run's root is removed: {left:?}");
}

#[test]
fn a_base_that_is_a_symbolic_link_is_refused() {
    let tmp = tempfile::tempdir().unwrap();
    // Even pointing at a private directory of this user.
    let target = TestBase::new();
    std::fs::create_dir(&target.0).unwrap();
    std::fs::set_permissions(&target.0, std::fs::Permissions::from_mode(0o700)).unwrap();
    let base = TestBase::new();
    std::os::unix::fs::symlink(&target.0, &base.0).unwrap();
    let out = run_with_base(&base.0, &tmp.path().join("run"), &[]);
    let line = format!(
        "refusing the shared-memory root {}: is a symbolic link; remove it",
        base.0.display()
    );
    assert_refused(&out, &line, &target.0);
}

#[test]
fn a_base_set_by_the_environment_is_made_private_and_robots_find_it() {
    let tmp = tempfile::tempdir().unwrap();
    let base = TestBase::new();
    // A Python robot beside the Rust ones: it finds the run through SWARMRT_IPC_CONFIG.
    let goto = swarmrt_tests::python::program("goto.py", &[]);
    let robots = format!("robots.programs=[{{robots=\"0\", program={goto}}}]");
    let dir = tmp.path().join("run");
    let out = run_with_base(&base.0, &dir, &["--set", &robots]);
    assert_ok(&out);
    let m = metrics(&dir);
    assert_eq!(m["ticks"], 50, "{m}");
    assert_eq!(m["rejected"], 0, "{m}");
    assert_eq!(m["unscheduled_deaths"], serde_json::json!([]), "{m}");
    let meta = std::fs::symlink_metadata(&base.0).unwrap();
    assert!(meta.is_dir());
    assert_eq!(meta.mode() & 0o777, 0o700, "made private");
    let left: Vec<_> = std::fs::read_dir(&base.0).unwrap().flatten().collect();
    assert!(left.is_empty(), "the run's root is removed: {left:?}");
    let run_id = m["run_id"].as_str().unwrap();
    let prefix = shm_prefix_of(run_id);
    assert!(
        !std::fs::read_dir("/dev/shm")
            .unwrap()
            .flatten()
            .any(|e| e.file_name().to_string_lossy().starts_with(&prefix)),
        "no segment of the run is left"
    );
}

#[test]
fn a_base_too_long_for_iceoryx2s_socket_paths_is_refused() {
    let tmp = tempfile::tempdir().unwrap();
    let short = TestBase::new();
    let base = TestBase(short.0.with_file_name(format!(
        "{}-and-too-long",
        short.0.file_name().unwrap().to_string_lossy()
    )));
    let out = run_with_base(&base.0, &tmp.path().join("run"), &[]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success());
    let line = format!(
        "refusing the shared-memory root {}: {} bytes long, longer than the 27 iceoryx2's \
         socket paths leave room for; choose a shorter path",
        base.0.display(),
        base.0.as_os_str().len()
    );
    assert!(err.lines().any(|l| l.contains(&line)), "{line:?}:\n{err}");
    assert!(!base.0.exists(), "nothing is made");
}

/// A base that cannot be made (under /proc) is the user's to fix: one line naming it, exit 2
/// (c0b8b90 exited 1, as for an internal failure).
#[test]
fn a_base_that_cannot_be_made_is_a_user_error() {
    let tmp = tempfile::tempdir().unwrap();
    let base = Path::new("/proc/swarmrt-no-such-base");
    let out = run_with_base(base, &tmp.path().join("run"), &[]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    let lines: Vec<&str> = err.lines().filter(|l| !l.trim().is_empty()).collect();
    assert!(
        lines.len() == 1
            && lines[0].contains("cannot create the shared-memory root /proc/swarmrt-no-such-base"),
        "{err}"
    );
}
