//! A Python for the tests of the Python package and of Python robots: a venv under the cargo
//! target directory with the package in `bindings/python` (all its extras, and
//! [`TEST_PACKAGES`]) installed, made once and shared by every test binary.
//!
//! `pip install ./bindings/python` is what a user runs too, so the tests use the package as
//! it installs (a wheel built by maturin, with `iceoryx2` pinned to `Cargo.lock`'s version by
//! its `pyproject.toml`), not the source tree on `PYTHONPATH`. The wheel takes this suite's
//! own build of the binaries (`SWARMRT_WHEEL_BINARIES`) and builds its native module in the
//! same profile, so the suite builds the workspace once. The venv is rebuilt when any file of
//! the package or the `swarm` binary changes (a stamp holds a fingerprint of them), under an
//! exclusive `flock`, so tests that start at the same moment build it once and never use a
//! half-built one. On a fresh Debian
//! machine without Python's venv module, `python3` and `python3-venv` are installed with apt,
//! as the multi-host tests install iproute2 (`lab.rs`).

use std::hash::{Hash, Hasher};
use std::os::fd::AsRawFd;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::sync::OnceLock;

use crate::workspace;

/// PyPI packages the tests' scripts use besides the package (`mcap`:
/// `tests/scripts/read_mcap.py` reads `swarm export --mcap` files with it). Part of the venv's
/// stamp: adding one rebuilds the venv.
pub const TEST_PACKAGES: &[&str] = &["mcap", "pytest", "nbclient", "nbformat", "ipykernel"];

/// The package's directory in the workspace.
pub fn package_dir() -> PathBuf {
    workspace().join("bindings").join("python")
}

/// An example robot program (`examples/python/<name>`), as an absolute path.
pub fn example(name: &str) -> PathBuf {
    workspace().join("examples").join("python").join(name)
}

/// The Python of the tests' venv (`<target>/swarmrt-venv/bin/python`), with the package
/// installed and up to date with its sources; built on first use. Panics saying what failed.
pub fn python() -> &'static Path {
    static PYTHON: OnceLock<PathBuf> = OnceLock::new();
    PYTHON.get_or_init(|| ensure_venv().unwrap_or_else(|e| panic!("the tests' Python venv: {e}")))
}

/// `["<venv python>", "<example>", args...]` as a TOML array, for `robots.program` and
/// `[[robots.programs]]`.
pub fn program(example_name: &str, args: &[&str]) -> String {
    let mut words = vec![
        python().display().to_string(),
        example(example_name).display().to_string(),
    ];
    words.extend(args.iter().map(|a| a.to_string()));
    let quoted: Vec<String> = words.iter().map(|w| format!("{w:?}")).collect();
    format!("[{}]", quoted.join(", "))
}

/// `<target>`: the test binary is `<target>/<profile>/deps/<name>`.
fn target_dir() -> PathBuf {
    let exe = std::env::current_exe().expect("the test binary's path");
    exe.ancestors()
        .nth(3)
        .expect("the test binary lives in <target>/<profile>/deps")
        .to_path_buf()
}

/// A fingerprint of every file of the package (paths and contents), so an edited or
/// regenerated module (`_messages.py`) reinstalls the package.
fn fingerprint(dir: &Path) -> String {
    fn walk(dir: &Path, out: &mut Vec<PathBuf>) {
        let Ok(entries) = std::fs::read_dir(dir) else {
            return;
        };
        for e in entries.flatten() {
            let p = e.path();
            let name = e.file_name();
            // The wheel's staging directory for the binaries (the build writes it).
            if name == "__pycache__"
                || name == "swarmrt.data"
                || name.to_string_lossy().ends_with(".pyc")
            {
                continue;
            }
            if p.is_dir() {
                walk(&p, out);
            } else {
                out.push(p);
            }
        }
    }
    let mut files = Vec::new();
    walk(dir, &mut files);
    files.sort();
    // `DefaultHasher::new()` has fixed keys: the same bytes give the same value in every
    // process (a different toolchain may give another value; that only reinstalls).
    let mut h = std::collections::hash_map::DefaultHasher::new();
    for f in &files {
        f.strip_prefix(dir).unwrap_or(f).hash(&mut h);
        std::fs::read(f).unwrap_or_default().hash(&mut h);
    }
    format!("{:016x} {} files", h.finish(), files.len())
}

/// Runs `cmd`, returning its combined output as the error when it fails.
fn run(cmd: &mut Command, what: &str) -> Result<(), String> {
    let out = cmd
        .stdin(Stdio::null())
        .output()
        .map_err(|e| format!("{what}: cannot start: {e}"))?;
    if out.status.success() {
        Ok(())
    } else {
        Err(format!(
            "{what} failed ({}):\n{}{}",
            out.status,
            String::from_utf8_lossy(&out.stdout),
            String::from_utf8_lossy(&out.stderr)
        ))
    }
}

/// Makes a venv at `venv` with the first of `python3` (on `PATH`) and `/usr/bin/python3` that
/// can; installs Python with apt when neither can.
fn make_venv(venv: &Path) -> Result<(), String> {
    let try_all = || {
        let mut why = Vec::new();
        for py in ["python3", "/usr/bin/python3"] {
            let _ = std::fs::remove_dir_all(venv);
            match run(
                Command::new(py).arg("-m").arg("venv").arg(venv),
                &format!("{py} -m venv"),
            ) {
                Ok(()) => return Ok(()),
                Err(e) => why.push(e),
            }
        }
        Err(why.join("\n"))
    };
    try_all().or_else(|first| {
        crate::apt_install(&["python3", "python3-venv"])
            .map_err(|e| format!("no Python with a venv module ({first}), and {e}"))?;
        try_all()
    })
}

fn ensure_venv() -> Result<PathBuf, String> {
    let target = target_dir();
    let venv = target.join("swarmrt-venv");
    let python = venv.join("bin").join("python");
    let stamp = venv.join(".swarmrt-stamp");
    let pkg = package_dir();

    std::fs::create_dir_all(&target).map_err(|e| format!("{}: {e}", target.display()))?;
    let lock_path = target.join("swarmrt-venv.lock");
    let lock = std::fs::OpenOptions::new()
        .create(true)
        .truncate(false)
        .write(true)
        .open(&lock_path)
        .map_err(|e| format!("{}: {e}", lock_path.display()))?;
    // Held until `lock` drops at the end of this function: one builder at a time across
    // every test process; the others wait, then find the stamp current.
    // SAFETY: flock on a descriptor this function owns.
    if unsafe { libc::flock(lock.as_raw_fd(), libc::LOCK_EX) } != 0 {
        return Err(format!(
            "flock {}: {}",
            lock_path.display(),
            std::io::Error::last_os_error()
        ));
    }

    // The native module is built from the whole workspace: the `swarm` binary of the same
    // build stands for it (its size and time change whenever a crate of it does).
    let bins = crate::bin_dir();
    let built = std::fs::metadata(bins.join("swarm"))
        .map(|m| format!("{} {:?}", m.len(), m.modified().ok()))
        .map_err(|e| format!("{}: {e}", bins.join("swarm").display()))?;
    let profile = if bins.ends_with("release") {
        "release"
    } else {
        "dev"
    };
    // The stamp names the Python too: a venv whose interpreter vanished is rebuilt.
    let want = format!(
        "{}\n{}\n{}\n{built} {profile}",
        fingerprint(&pkg),
        python.display(),
        TEST_PACKAGES.join(" ")
    );
    let current = python.exists() && std::fs::read_to_string(&stamp).is_ok_and(|s| s == want);
    if current {
        return Ok(python);
    }
    let _ = std::fs::remove_file(&stamp);
    make_venv(&venv)?;
    run(
        crate::without_test_time_cargo_vars(&mut Command::new(&python))
            .args([
                "-m",
                "pip",
                "install",
                "--quiet",
                "--disable-pip-version-check",
            ])
            .arg(format!("{}[all]", pkg.display()))
            .args(TEST_PACKAGES)
            .env("PYTHONDONTWRITEBYTECODE", "1")
            .env("SWARMRT_WHEEL_BINARIES", bins)
            .env("SWARMRT_WHEEL_PROFILE", profile),
        &format!("pip install {}", pkg.display()),
    )?;
    // Written last: a build cut short leaves no stamp and is redone.
    std::fs::write(&stamp, want).map_err(|e| format!("{}: {e}", stamp.display()))?;
    drop(lock);
    Ok(python)
}
