//! `swarm-world`: the world process of one run (started by `swarm run`). It hands the world
//! the robots' vocabulary, so the world crate depends on no behaviour. The package is a
//! default member of the workspace, so `cargo build` puts it beside `swarm`.
fn main() -> std::process::ExitCode {
    swarmrt_runtime::world::cli::main(swarmrt_agent::registry::VOCABULARY)
}
