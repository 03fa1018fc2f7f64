//! The header against the library: `tests/c_api.c` is compiled with `swarmrt.h` and with C
//! declarations generated from the Rust functions (`swarmrt::ffi::c_declarations`), so a
//! function whose header declaration drifts from its Rust signature is a compile error
//! ("conflicting types"); then it is linked with `libswarmrt.a` and run.

use std::path::PathBuf;
use std::process::{Command, Stdio};

fn crate_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// `target/<profile>` of this test binary (`target/<profile>/deps/<test>`).
fn profile_dir() -> PathBuf {
    let exe = std::env::current_exe().unwrap();
    exe.parent().unwrap().parent().unwrap().to_path_buf()
}

fn runs(program: &str) -> bool {
    Command::new(program)
        .arg("--version")
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .status()
        .is_ok_and(|s| s.success())
}

/// A C compiler; gcc is installed with apt when there is none (as the end-to-end tests do).
fn cc() -> &'static str {
    if runs("cc") {
        return "cc";
    }
    let install = || {
        Command::new("apt-get")
            .args(["install", "-y", "-qq", "gcc", "libc6-dev"])
            .env("DEBIAN_FRONTEND", "noninteractive")
            .status()
            .is_ok_and(|s| s.success())
    };
    let _ = install()
        || (Command::new("apt-get")
            .args(["update", "-qq"])
            .status()
            .is_ok_and(|s| s.success())
            && install());
    assert!(
        runs("gcc"),
        "no C compiler (`cc`) and `apt-get install gcc` failed"
    );
    "gcc"
}

/// `libswarmrt.a` as this test's profile builds it. `cargo test` builds only the rlib of
/// the library for its tests, so the static library is built here.
fn staticlib() -> PathBuf {
    let profile = profile_dir();
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    let mut cmd = Command::new(cargo);
    cmd.current_dir(crate_dir())
        .args(["build", "--quiet", "-p", "swarmrt-c", "--lib"]);
    if profile.file_name().is_some_and(|n| n == "release") {
        cmd.arg("--release");
    }
    assert!(
        cmd.status().unwrap().success(),
        "building libswarmrt.a failed"
    );
    profile.join("libswarmrt.a")
}

#[test]
fn the_header_declares_every_function_as_the_library_defines_it() {
    let header = std::fs::read_to_string(crate_dir().join("include/swarmrt.h")).unwrap();
    for s in swarmrt::ffi::C_API {
        assert!(
            header.contains(&format!("{}(", s.name)),
            "swarmrt.h does not declare {}",
            s.name
        );
    }
    let tmp = tempfile::tempdir().unwrap();
    std::fs::write(
        tmp.path().join("swarmrt_decls.h"),
        swarmrt::ffi::c_declarations(),
    )
    .unwrap();
    let exe = tmp.path().join("c_api");
    let out = Command::new(cc())
        .args(["-std=c11", "-Wall", "-Wextra", "-Werror", "-I"])
        .arg(crate_dir().join("include"))
        .arg("-I")
        .arg(tmp.path())
        .arg(crate_dir().join("tests/c_api.c"))
        .arg(staticlib())
        .args([
            "-lgcc_s",
            "-lutil",
            "-lrt",
            "-lpthread",
            "-lm",
            "-ldl",
            "-lc",
        ])
        .arg("-o")
        .arg(&exe)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "c_api.c does not compile against swarmrt.h and the library's own signatures:\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let run = Command::new(&exe).output().unwrap();
    assert!(
        run.status.success() && run.stdout == b"ok\n",
        "{}{}",
        String::from_utf8_lossy(&run.stdout),
        String::from_utf8_lossy(&run.stderr)
    );
}

/// A C signature that differs from the library's is caught: the check above is not vacuous.
#[test]
fn a_drifted_declaration_fails_to_compile() {
    let tmp = tempfile::tempdir().unwrap();
    let src = tmp.path().join("drift.c");
    std::fs::write(
        &src,
        format!(
            "#include \"swarmrt.h\"\n{}\nint swarmrt_config_f64(const swarmrt_config_t *, const char *, float *);\n",
            swarmrt::ffi::c_declarations()
        ),
    )
    .unwrap();
    let out = Command::new(cc())
        .args(["-std=c11", "-fsyntax-only", "-I"])
        .arg(crate_dir().join("include"))
        .arg(&src)
        .output()
        .unwrap();
    assert!(!out.status.success(), "a conflicting declaration compiled");
    assert!(
        String::from_utf8_lossy(&out.stderr).contains("conflicting types"),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
}
