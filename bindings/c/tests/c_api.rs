//! The header against the library: `tests/c_api.c` is compiled with `swarmrt.h` and with C
//! declarations generated from the Rust functions (`swarmrt::ffi::c_declarations`), so a
//! function whose header declaration drifts from its Rust signature is a compile error
//! ("conflicting types"); then it is linked with `libswarmrt.a` and run.

use std::path::PathBuf;
use std::process::Command;

use swarmrt_tests::c_robot::{LINK_LIBS, cc, staticlib};

fn crate_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
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
        .args(LINK_LIBS)
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
