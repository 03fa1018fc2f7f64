//! `swarm-agent`: one robot process (started by `swarm run`). The package is a default member
//! of the workspace, so `cargo build` puts it beside `swarm`.
fn main() -> std::process::ExitCode {
    swarmrt_runtime::robot::cli::main()
}
