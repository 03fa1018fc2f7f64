//! `swarm-world`: the world process of one run (started by `swarm run`). Lives in this
//! package so that building `swarm` always builds it beside it.
fn main() -> std::process::ExitCode {
    swarmrt_world::cli::main(swarmrt_agent::registry::VOCABULARY)
}
