//! `swarm-host`: runs a group of a run's robots on this host (started by `swarm run --hosts`
//! through the host's launcher).

fn main() -> std::process::ExitCode {
    swarmrt_runtime::host::main()
}
