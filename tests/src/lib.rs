//! Support for the end-to-end tests (`tests/tests/e2e/`, one test binary, and the viewer's
//! `tests/tests/viewer.rs`): builds the four binaries once, runs `swarm` with a watchdog, and
//! reads run directories.
#![warn(missing_docs)]

pub mod browser;
pub mod c_robot;
pub mod lab;
pub mod python;
pub mod slurm;
pub mod stranger;

use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::sync::OnceLock;
use std::time::Duration;

/// The workspace root.
pub fn workspace() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .unwrap()
        .to_path_buf()
}

/// Directory holding `swarm`, `swarm-world`, `swarm-agent`, `swarm-bench` and the C robots'
/// `libswarmrt.a`, built once per test process with the same profile as the tests (cargo only
/// builds a package's own binaries for its tests, and these live in other packages).
///
/// They are built as `cargo test --workspace` builds them: with the dev-dependencies' features
/// (the robot's test hooks among them). A plain `cargo build -p ...` resolved features without
/// them, so it compiled most of the graph a second time (syn, serde, hyper... all differ) on
/// a fresh clone; this build is the test build's own, and fresh when the suite runs whole.
///
/// With `SWARMRT_TEST_BIN_DIR` set, its binaries are used as they are (nothing is built): to
/// run a test against another build, e.g. an older commit's, and see it fail there.
pub fn bin_dir() -> &'static Path {
    static DIR: OnceLock<PathBuf> = OnceLock::new();
    DIR.get_or_init(|| {
        if let Some(dir) = std::env::var_os("SWARMRT_TEST_BIN_DIR") {
            return PathBuf::from(dir);
        }
        // target/<profile>/deps/<test binary>
        let exe = std::env::current_exe().unwrap();
        let profile_dir = exe.parent().unwrap().parent().unwrap().to_path_buf();
        let release = profile_dir.file_name().is_some_and(|n| n == "release");
        let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".to_string());
        let mut cmd = Command::new(cargo);
        // Without the variables cargo sets for a running test: ring's build script tracks
        // CARGO_MANIFEST_DIR, so a build that inherited this package's value rebuilt ring and
        // all that hangs on it (45 s on a fresh clone), twice a suite, and once more for the
        // next plain `cargo build`.
        without_test_time_cargo_vars(&mut cmd);
        cmd.current_dir(workspace()).args([
            "build",
            "--quiet",
            "--workspace",
            "--lib",
            "--bins",
            "--tests",
        ]);
        if release {
            cmd.arg("--release");
        }
        let status = cmd.status().expect("cargo build runs");
        assert!(status.success(), "building the binaries failed");
        profile_dir
    })
}

/// `cmd` without the variables cargo set for this test ([`is_test_time_cargo_var`]), for a
/// command that runs cargo itself.
pub fn without_test_time_cargo_vars(cmd: &mut Command) -> &mut Command {
    for (key, _) in std::env::vars_os() {
        if key.to_str().is_some_and(is_test_time_cargo_var) {
            cmd.env_remove(key);
        }
    }
    cmd
}

/// True for the variables cargo sets in a test's environment that describe the package under
/// test (not cargo's configuration, which a nested build must keep).
fn is_test_time_cargo_var(key: &str) -> bool {
    const EXACT: [&str; 8] = [
        "CARGO_MANIFEST_DIR",
        "CARGO_MANIFEST_PATH",
        "CARGO_MANIFEST_LINKS",
        "CARGO_CRATE_NAME",
        "CARGO_BIN_NAME",
        "CARGO_PRIMARY_PACKAGE",
        "CARGO_TARGET_TMPDIR",
        "CARGO_RUSTC_CURRENT_DIR",
    ];
    EXACT.contains(&key) || key.starts_with("CARGO_PKG_") || key.starts_with("CARGO_BIN_EXE_")
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

/// Runs `swarm run <config> --out <dir> <extra>...` (within 10 minutes), asserts it succeeded and
/// returns its metrics.
pub fn run_config(config: &str, dir: &Path, extra: &[&str]) -> serde_json::Value {
    let mut args = vec!["run", config, "--out", dir.to_str().unwrap()];
    args.extend_from_slice(extra);
    assert_ok(&swarm(&args, Duration::from_secs(600)));
    metrics(dir)
}

/// `--set`s for the lossy, late, jittery radio the mode-equality tests use.
pub const LOSSY_RADIO: [&str; 6] = [
    "--set",
    "radio.loss=0.3",
    "--set",
    "radio.delay_ticks=3",
    "--set",
    "radio.jitter_ticks=2",
];

/// Runs `config` for `ticks` with the lossy radio (plus `extra`) as processes and in-process
/// under `tmp`, asserts that each of `files` holds the same bytes in both run directories and
/// that loss happened, and returns the in-process run's metrics.
pub fn assert_modes_agree_with_loss(
    tmp: &Path,
    config: &str,
    ticks: u64,
    extra: &[&str],
    files: &[&str],
) -> serde_json::Value {
    let ticks = ticks.to_string();
    let mut args = vec!["--ticks", ticks.as_str()];
    args.extend_from_slice(&LOSSY_RADIO);
    args.extend_from_slice(extra);
    let run = |dir: &Path, in_process: bool| {
        let mut a = args.clone();
        if in_process {
            a.push("--in-process");
        }
        run_config(config, dir, &a)
    };
    let (a, b) = (tmp.join("processes"), tmp.join("in-process"));
    run(&a, false);
    let m = run(&b, true);
    assert!(m["radio"]["dropped_loss"].as_u64().unwrap() > 0, "{m}");
    for file in files {
        assert!(
            bytes(&a, file) == bytes(&b, file),
            "{config}: {file} differs between modes"
        );
    }
    m
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

/// Live processes whose parent is `parent`, with their command lines (NUL-separated args
/// turned into spaces).
pub fn children_of(parent: u32) -> Vec<(i32, String)> {
    let mut out = Vec::new();
    for e in std::fs::read_dir("/proc").unwrap().flatten() {
        let Ok(pid) = e.file_name().to_string_lossy().parse::<i32>() else {
            continue;
        };
        let Ok(stat) = std::fs::read_to_string(format!("/proc/{pid}/stat")) else {
            continue;
        };
        // Fields after the parenthesised command name: state, ppid, ...
        let Some(rest) = stat.rsplit_once(')').map(|(_, r)| r) else {
            continue;
        };
        let fields: Vec<&str> = rest.split_whitespace().collect();
        if fields.get(1).and_then(|p| p.parse::<u32>().ok()) == Some(parent) && fields[0] != "Z" {
            let cmd = std::fs::read(format!("/proc/{pid}/cmdline")).unwrap_or_default();
            let cmd = String::from_utf8_lossy(&cmd).replace('\0', " ");
            out.push((pid, cmd));
        }
    }
    out.sort();
    out
}

/// True while a process with this pid exists and is not a zombie.
pub fn alive(pid: i32) -> bool {
    std::fs::read_to_string(format!("/proc/{pid}/stat"))
        .ok()
        .and_then(|s| {
            s.rsplit_once(')')
                .map(|(_, r)| r.split_whitespace().next() != Some("Z"))
        })
        .unwrap_or(false)
}

/// Waits until `cond` holds, checking every 20 ms; panics with `what` after `limit`.
pub fn wait_until(what: &str, limit: Duration, mut cond: impl FnMut() -> bool) {
    let start = std::time::Instant::now();
    while !cond() {
        assert!(start.elapsed() < limit, "timed out waiting for {what}");
        std::thread::sleep(Duration::from_millis(20));
    }
}

/// Highest tick written to `trajectory.csv` so far (0 if none).
pub fn last_tick(dir: &Path) -> u64 {
    std::fs::read_to_string(dir.join("trajectory.csv"))
        .ok()
        .and_then(|t| {
            t.lines()
                .rev()
                .find_map(|l| l.split(',').next()?.parse::<u64>().ok())
        })
        .unwrap_or(0)
}

/// Starts a long `swarm run` of `configs/goto_simple.toml` into `dir` (extra args appended)
/// and waits until it has recorded a few ticks, so it is mid-run.
pub fn start_long_run(dir: &Path, extra: &[&str]) -> std::process::Child {
    let mut args = vec![
        "run".to_string(),
        "configs/goto_simple.toml".to_string(),
        "--ticks".to_string(),
        "100000".to_string(),
        "--set".to_string(),
        "scenario.stop_when_done=false".to_string(),
        "--out".to_string(),
        dir.display().to_string(),
    ];
    args.extend(extra.iter().map(|s| s.to_string()));
    let child = Command::new(swarm_bin())
        .current_dir(workspace())
        .args(&args)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("swarm starts");
    wait_until(
        "the run to record 20 ticks",
        Duration::from_secs(60),
        || last_tick(dir) >= 20,
    );
    child
}

/// The run id a running orchestrator gave its children (from their command lines).
pub fn run_id_of(children: &[(i32, String)]) -> String {
    children
        .iter()
        .find_map(|(_, cmd)| {
            let mut it = cmd.split_whitespace();
            it.find(|a| *a == "--run-id")?;
            it.next().map(str::to_string)
        })
        .expect("children carry --run-id")
}

/// Asserts a finished run left nothing behind: none of `children` still runs and no file of
/// `run_id` remains in the iceoryx2 root or /dev/shm.
pub fn assert_nothing_left(children: &[(i32, String)], run_id: &str) {
    for (pid, cmd) in children {
        assert!(!alive(*pid), "process left running: {cmd}");
    }
    assert!(leftovers(run_id).is_empty(), "{:?}", leftovers(run_id));
}

/// True when `program arg` starts and exits 0 (a probe for a tool such as `cc --version`).
pub fn runs(program: &str, arg: &str) -> bool {
    Command::new(program)
        .arg(arg)
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .status()
        .is_ok_and(|s| s.success())
}

/// `apt-get install -y <packages>`, after an `apt-get update` when the first try fails (a
/// fresh image has no package lists), so the README's test command needs no set-up step on a
/// fresh Debian machine. `Err` says which step failed. One install at a time: the tests of one
/// binary run in parallel and dpkg takes a lock that a second apt-get would fail on.
pub fn apt_install(packages: &[&str]) -> Result<(), String> {
    static APT: std::sync::Mutex<()> = std::sync::Mutex::new(());
    let _one_at_a_time = APT.lock().unwrap_or_else(|e| e.into_inner());
    let install = || {
        Command::new("apt-get")
            .args(["install", "-y", "-qq"])
            .args(packages)
            .env("DEBIAN_FRONTEND", "noninteractive")
            .stdin(Stdio::null())
            .status()
            .is_ok_and(|s| s.success())
    };
    let updated = || {
        Command::new("apt-get")
            .args(["update", "-qq"])
            .stdin(Stdio::null())
            .status()
            .is_ok_and(|s| s.success())
    };
    if install() || (updated() && install()) {
        Ok(())
    } else {
        Err(format!("`apt-get install {}` failed", packages.join(" ")))
    }
}

/// Starts `swarm args...` from the workspace root with `env` added, its output captured
/// (finish it with [`wait_with_watchdog`]).
pub fn spawn_swarm(args: &[&str], env: &[(&str, &str)]) -> std::process::Child {
    Command::new(swarm_bin())
        .current_dir(workspace())
        .args(args)
        .envs(env.iter().copied())
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("swarm starts")
}

/// The processes `metrics.json` lists for `robot`: (incarnation, end, scheduled_kill).
pub fn processes_of(m: &serde_json::Value, robot: u64) -> Vec<(u64, String, bool)> {
    m["processes"]
        .as_array()
        .expect("metrics.json lists the processes")
        .iter()
        .filter(|p| p["robot"] == robot)
        .map(|p| {
            (
                p["incarnation"].as_u64().unwrap(),
                p["end"].as_str().unwrap().to_string(),
                p["scheduled_kill"].as_bool().unwrap(),
            )
        })
        .collect()
}

/// Asserts two run directories hold the same `trajectory.csv` and `events.jsonl` bytes.
pub fn assert_same_records(a: &Path, b: &Path, what: &str) {
    for f in ["trajectory.csv", "events.jsonl"] {
        assert!(
            bytes(a, f) == bytes(b, f),
            "{what}: {f} differs between {} and {}",
            a.display(),
            b.display()
        );
    }
}

/// Live processes whose command line mentions `needle`.
pub fn processes_mentioning(needle: &str) -> Vec<(i32, String)> {
    let mut found = Vec::new();
    for e in std::fs::read_dir("/proc").unwrap().flatten() {
        let Ok(pid) = e.file_name().to_string_lossy().parse::<i32>() else {
            continue;
        };
        let cmd = std::fs::read(format!("/proc/{pid}/cmdline")).unwrap_or_default();
        let cmd = String::from_utf8_lossy(&cmd).replace('\0', " ");
        if cmd.contains(needle) && alive(pid) {
            found.push((pid, cmd));
        }
    }
    found
}
