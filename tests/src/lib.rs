//! Support for the end-to-end tests in `tests/tests/`: builds the three binaries once, runs
//! `swarm` with a watchdog, and reads run directories.
#![warn(missing_docs)]

use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::sync::OnceLock;
use std::time::Duration;

/// The workspace root.
pub fn workspace() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).parent().unwrap().to_path_buf()
}

/// Directory holding `swarm`, `swarm-world` and `swarm-agent`, built once per test process
/// with the same profile as the tests (cargo only builds a package's own binaries for its
/// tests, and these live in three packages).
pub fn bin_dir() -> &'static Path {
    static DIR: OnceLock<PathBuf> = OnceLock::new();
    DIR.get_or_init(|| {
        // target/<profile>/deps/<test binary>
        let exe = std::env::current_exe().unwrap();
        let profile_dir = exe.parent().unwrap().parent().unwrap().to_path_buf();
        let release = profile_dir.file_name().is_some_and(|n| n == "release");
        let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".to_string());
        let mut cmd = Command::new(cargo);
        cmd.current_dir(workspace())
            .args(["build", "--quiet", "-p", "swarmrt-orchestrator", "-p", "swarmrt-world", "-p", "swarmrt-agent", "--bins"]);
        if release {
            cmd.arg("--release");
        }
        let status = cmd.status().expect("cargo build runs");
        assert!(status.success(), "building the binaries failed");
        profile_dir
    })
}

/// Path of the `swarm` binary.
pub fn swarm_bin() -> PathBuf {
    bin_dir().join("swarm")
}

/// Runs `swarm args...` from the workspace root; panics if it takes longer than `limit`
/// (the watchdog kills it first, so a hang fails the test instead of stalling CI).
pub fn swarm(args: &[&str], limit: Duration) -> Output {
    let child = Command::new(swarm_bin())
        .current_dir(workspace())
        .args(args)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("swarm starts");
    wait_with_watchdog(child, limit)
}

/// Waits for `child` to finish, killing it and panicking after `limit`.
pub fn wait_with_watchdog(child: std::process::Child, limit: Duration) -> Output {
    let pid = child.id() as i32;
    let (tx, rx) = std::sync::mpsc::channel();
    std::thread::spawn(move || {
        let _ = tx.send(child.wait_with_output());
    });
    match rx.recv_timeout(limit) {
        Ok(out) => out.expect("wait for swarm"),
        Err(_) => {
            unsafe {
                libc::kill(pid, libc::SIGKILL);
            }
            panic!("swarm did not finish within {limit:?}");
        }
    }
}

/// Parsed `metrics.json` of a run directory.
pub fn metrics(dir: &Path) -> serde_json::Value {
    let text = std::fs::read_to_string(dir.join("metrics.json")).expect("metrics.json exists");
    serde_json::from_str(&text).expect("metrics.json parses")
}

/// Bytes of a file in a run directory.
pub fn bytes(dir: &Path, name: &str) -> Vec<u8> {
    std::fs::read(dir.join(name)).unwrap_or_else(|e| panic!("{}/{name}: {e}", dir.display()))
}

/// Files a run left behind in the iceoryx2 root and /dev/shm.
pub fn leftovers(run_id: &str) -> Vec<String> {
    let mut found = Vec::new();
    let root = swarmrt_protocol::services::ipc_root_of(run_id);
    if root.exists() {
        found.push(root.display().to_string());
    }
    let prefix = swarmrt_protocol::services::shm_prefix_of(run_id);
    for e in std::fs::read_dir("/dev/shm").unwrap().flatten() {
        if e.file_name().to_string_lossy().starts_with(&prefix) {
            found.push(e.path().display().to_string());
        }
    }
    found
}

/// Asserts a `swarm` invocation succeeded, showing its stderr if not.
pub fn assert_ok(out: &Output) {
    assert!(
        out.status.success(),
        "swarm failed ({}):\n{}",
        out.status,
        String::from_utf8_lossy(&out.stderr)
    );
}
