//! The C side of the C-robot tests (`tests/tests/e2e/c_robots.rs`): a C compiler (installed with
//! apt when missing), `libswarmrt.a` (package `swarmrt-c`) built once per test process with the
//! tests' profile, and C programs compiled against it, among them `examples/c/goto.c`.

use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::OnceLock;

use crate::workspace;

/// Flags every C program of the tests is compiled with. `-ffp-contract=off`: no `a * b + c`
/// becomes a fused multiply-add, which Rust never does; no `-ffast-math`.
pub const CFLAGS: &[&str] = &[
    "-std=c11",
    "-O2",
    "-ffp-contract=off",
    "-fno-fast-math",
    "-Wall",
    "-Wextra",
];

/// What a program linked with `libswarmrt.a` also links: the native libraries of Rust's
/// standard library (`cargo rustc -p swarmrt-c -- --print native-static-libs`).
pub const LINK_LIBS: &[&str] = &[
    "-lgcc_s",
    "-lutil",
    "-lrt",
    "-lpthread",
    "-lm",
    "-ldl",
    "-lc",
];

/// `target/<profile>` of the running test binary (`target/<profile>/deps/<test>`).
pub fn profile_dir() -> PathBuf {
    let exe = std::env::current_exe().expect("the test binary has a path");
    exe.parent()
        .and_then(Path::parent)
        .expect("test binaries live in target/<profile>/deps")
        .to_path_buf()
}

/// `bindings/c/include`: `swarmrt.h` and the generated `swarmrt_messages.h`.
pub fn include_dir() -> PathBuf {
    workspace().join("bindings/c/include")
}

/// Where the tests put the C programs they build (`target/<profile>/c-robots`).
pub fn out_dir() -> PathBuf {
    profile_dir().join("c-robots")
}

/// The C compiler (`cc`), installing gcc with apt once per test process when there is none,
/// so the README's test command needs no set-up step on a fresh Debian machine.
pub fn cc() -> &'static str {
    static CC: OnceLock<Result<&'static str, String>> = OnceLock::new();
    let found = CC.get_or_init(|| {
        for c in ["cc", "gcc"] {
            if crate::runs(c, "--version") {
                return Ok(c);
            }
        }
        let ok = crate::apt_install(&["gcc", "libc6-dev"]).is_ok();
        if ok && crate::runs("gcc", "--version") {
            Ok("gcc")
        } else {
            Err("no C compiler (`cc`) and `apt-get install gcc` failed".into())
        }
    });
    match found {
        Ok(c) => c,
        Err(e) => panic!("{e}"),
    }
}

/// `libswarmrt.a`, built with the binaries by [`crate::bin_dir`] (the test build's own
/// features: a `cargo build -p swarmrt-c` of its own resolved others and recompiled its
/// dependencies, ~45 s of `c_api` on a fresh clone).
pub fn staticlib() -> &'static Path {
    static LIB: OnceLock<PathBuf> = OnceLock::new();
    LIB.get_or_init(|| {
        let lib = crate::bin_dir().join("libswarmrt.a");
        assert!(lib.exists(), "{} was not built", lib.display());
        lib
    })
}

/// Compiles `sources` with [`CFLAGS`] (and `-I` the include directory, plus `extra`
/// arguments) into `out_dir()/<name>`, linked with `libswarmrt.a` when `link` is true, and
/// returns the executable's path. Panics with the compiler's output on failure. The file
/// appears whole (written aside, then renamed), so parallel test processes never run a
/// half-written one.
pub fn compile(name: &str, sources: &[&Path], extra: &[&str], link: bool) -> PathBuf {
    let dir = out_dir();
    std::fs::create_dir_all(&dir).expect("create target/<profile>/c-robots");
    let exe = dir.join(name);
    let tmp = dir.join(format!(".{name}.{}.tmp", std::process::id()));
    let mut cmd = Command::new(cc());
    cmd.args(CFLAGS)
        .arg("-I")
        .arg(include_dir())
        .args(extra)
        .args(sources);
    if link {
        cmd.arg(staticlib()).args(LINK_LIBS);
    }
    let out = cmd
        .arg("-o")
        .arg(&tmp)
        .output()
        .expect("the C compiler runs");
    assert!(
        out.status.success(),
        "compiling {name} failed:\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    std::fs::rename(&tmp, &exe).expect("move the executable into place");
    exe
}

/// `examples/c/goto.c` built and linked, once per test process: an absolute path for
/// `robots.program`.
pub fn goto_c() -> &'static Path {
    static EXE: OnceLock<PathBuf> = OnceLock::new();
    EXE.get_or_init(|| {
        compile(
            "goto-c",
            &[&workspace().join("examples/c/goto.c")],
            &[],
            true,
        )
    })
}

/// `--set` value making every robot run `program`.
pub fn program_for_all(program: &Path) -> String {
    format!("robots.program=[{:?}]", program.display().to_string())
}

/// `--set` value making the robots of each `(ids, program)` run it: `ids` is a robot id or
/// a range like `"0..4"` (end excluded); the other robots stay the built-in Rust robot.
pub fn programs_for(entries: &[(&str, &Path)]) -> String {
    let list: Vec<String> = entries
        .iter()
        .map(|(ids, p)| format!("{{robots={ids:?},program=[{:?}]}}", p.display().to_string()))
        .collect();
    format!("robots.programs=[{}]", list.join(","))
}
