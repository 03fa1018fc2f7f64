//! `swarm bench`: the benchmarks live in their own package and binary, `swarm-bench`
//! (`benchmarks/`); this verb only runs it.

use std::os::unix::process::CommandExt;
use std::process::Command;

use anyhow::anyhow;

use crate::cli::BenchArgs;
use crate::error::{SwarmError, SwarmResult};
use crate::processes;

/// The benchmark binary, built beside `swarm` (`cargo build` builds both).
pub const BENCH_BIN: &str = "swarm-bench";

/// Replaces this process with `swarm-bench <args>` (`exec`), found beside `swarm` like
/// `swarm-world` and `swarm-agent`. The benchmark keeps this process's pid, terminal and
/// process group, so Ctrl-C reaches it exactly as it reached `swarm bench` before, its
/// children are this pid's children, and its exit code (0, 1, 2, 130) is `swarm`'s, with
/// nothing to forward. Call it before installing a Ctrl-C handler. Returns only if
/// `swarm-bench` cannot be started.
pub fn bench(args: &BenchArgs) -> SwarmResult<()> {
    let exe = processes::sibling_binary(BENCH_BIN)?;
    // argv[0] names the command as the user typed it, so its usage lines read `swarm bench`.
    let err = Command::new(&exe)
        .arg0("swarm bench")
        .args(&args.args)
        .exec();
    Err(SwarmError::Internal(anyhow!(
        "cannot start {}: {err}",
        exe.display()
    )))
}

#[cfg(test)]
mod tests {
    use crate::cli::{Cli, Cmd};
    use clap::Parser;

    fn passed_on(argv: &[&str]) -> Vec<String> {
        match Cli::try_parse_from(argv).unwrap().command {
            Cmd::Bench(b) => b.args.iter().map(|a| a.to_string_lossy().into()).collect(),
            other => panic!("{other:?}"),
        }
    }

    #[test]
    fn everything_after_bench_goes_to_swarm_bench_untouched() {
        <Cli as clap::CommandFactory>::command().debug_assert();
        assert_eq!(
            passed_on(&["swarm", "bench", "ipc", "--secs", "0.2", "--json"]),
            ["ipc", "--secs", "0.2", "--json"]
        );
        assert_eq!(passed_on(&["swarm", "bench", "--help"]), ["--help"]);
        assert_eq!(
            passed_on(&["swarm", "bench", "swarm", "-h"]),
            ["swarm", "-h"]
        );
        assert!(passed_on(&["swarm", "bench"]).is_empty());
    }
}
