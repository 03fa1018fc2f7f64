//! Build script of the crates with binaries (`swarm`, `swarm-world`, `swarm-agent`,
//! `swarm-host`, `swarm-bench`): in release builds their debug sections (line tables only,
//! see the workspace's release profile) are linked zlib-compressed, so panics and backtraces
//! still name file and line while `swarm-agent` is a fraction of its former 147 MB. Rust's
//! backtraces, gdb and perf read compressed sections.

fn main() {
    println!("cargo:rerun-if-changed=../build/compress_debug.rs");
    println!("cargo:rerun-if-env-changed=PROFILE");
    if std::env::var("PROFILE").as_deref() == Ok("release") {
        println!("cargo:rustc-link-arg-bins=-Wl,--compress-debug-sections=zlib");
    }
}
