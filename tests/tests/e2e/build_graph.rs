//! The build graph keeps its promises: the cores link no I/O stack, and the binaries users run
//! carry no test code.
//!
//! The Raft core's known bugs (`mutants`) and the robot's malformed-command hooks
//! (`misbehave`) are features that only test builds turn on; a normal dependency that turned
//! one on would compile it into `swarm-agent` and `swarm` through feature unification.

use std::process::Command;

use swarmrt_tests::workspace;

/// `cargo tree` from the workspace root with `args`; its lines.
fn cargo_tree(args: &[&str]) -> Vec<String> {
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".to_string());
    let out = Command::new(cargo)
        .current_dir(workspace())
        .args(["tree", "--locked", "--prefix", "none"])
        .args(args)
        .output()
        .expect("cargo tree runs");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8_lossy(&out.stdout)
        .lines()
        .map(str::to_string)
        .collect()
}

/// The crates holding the deterministic cores and what reads their records: inputs in,
/// outputs out. Their process shells live in `swarmrt-runtime`, `swarmrt-ipc` and
/// `swarmrt-hosts`.
const CORES: [&str; 7] = [
    "swarmrt-protocol",
    "swarmrt-scenario",
    "swarmrt-planner",
    "swarmrt-world",
    "swarmrt-agent",
    "swarmrt-analysis",
    "swarmrt-harness",
];

/// Shared memory, the network and the command line: what a core must not link.
const IO_STACKS: [&str; 6] = [
    "iceoryx2",
    "iceoryx2-cal",
    "iceoryx2-bb-posix",
    "zenoh",
    "tokio",
    "clap",
];

/// The crates of `list` in `krate`'s dependency tree along `edges` (`normal`, `normal,dev`).
fn found_in(krate: &str, edges: &str, list: &[&str]) -> Vec<String> {
    let mut found: Vec<String> = cargo_tree(&["-p", krate, "-e", edges])
        .iter()
        .filter_map(|l| l.split(' ').next())
        .filter(|name| list.contains(name))
        .map(str::to_string)
        .collect();
    found.sort();
    found.dedup();
    found
}

/// The I/O crates in `krate`'s normal dependency tree.
fn io_stacks_of(krate: &str) -> Vec<String> {
    found_in(krate, "normal", &IO_STACKS)
}

#[test]
fn the_core_crates_link_no_shared_memory_network_or_command_line_stack() {
    for krate in CORES {
        assert_eq!(io_stacks_of(krate), Vec::<String>::new(), "{krate}");
    }
}

/// The crates of the fast lane (`cargo test-fast`, `.cargo/config.toml`).
const FAST_LANE: [&str; 6] = [
    "swarmrt-protocol",
    "swarmrt-scenario",
    "swarmrt-planner",
    "swarmrt-world",
    "swarmrt-agent",
    "swarmrt-harness",
];

/// What the fast lane must not build, tests included: shared memory, the network, the web,
/// a browser, plots and the MCAP container (criterion, a dev-dependency, brings clap: that
/// one is no I/O stack there).
const HEAVY: [&str; 10] = [
    "iceoryx2",
    "zenoh",
    "tokio",
    "hyper",
    "axum",
    "fantoccini",
    "plotters",
    "image",
    "mcap",
    "rustls",
];

/// The heavy crates in `krate`'s normal and dev dependency trees.
fn heavy_in(krate: &str) -> Vec<String> {
    found_in(krate, "normal,dev", &HEAVY)
}

#[test]
fn the_fast_lane_builds_no_network_web_browser_or_plotting_crate() {
    for krate in FAST_LANE {
        assert_eq!(heavy_in(krate), Vec::<String>::new(), "{krate}");
    }
    // The lane is what the alias runs.
    let alias = std::fs::read_to_string(workspace().join(".cargo/config.toml")).unwrap();
    for krate in FAST_LANE {
        assert!(
            alias.contains(&format!("-p {krate}")),
            "test-fast runs {krate}"
        );
    }
}

/// The check can fail: the end-to-end tests, which drive a browser, are seen building one.
#[test]
fn the_heavy_crates_are_seen_where_they_are() {
    let heavy = heavy_in("swarmrt-tests");
    for krate in ["fantoccini", "iceoryx2", "tokio"] {
        assert!(heavy.contains(&krate.to_string()), "{krate} in {heavy:?}");
    }
}

/// The check can fail: the runtime, which is the shells, links them.
#[test]
fn the_shells_are_seen_linking_them() {
    assert_eq!(
        io_stacks_of("swarmrt-runtime"),
        [
            "clap",
            "iceoryx2",
            "iceoryx2-bb-posix",
            "iceoryx2-cal",
            "tokio",
            "zenoh"
        ]
    );
}

/// The features of `swarmrt-agent` in the build of the default members (`swarm`,
/// `swarm-world`, `swarm-agent`, `swarm-host`, `swarm-bench`), as `cargo tree` resolves them.
fn agent_features(extra: &[&str]) -> Vec<String> {
    let mut args = vec!["-p", "swarmrt-orchestrator", "-p", "swarmrt-bins"];
    args.extend(["-p", "swarmrt-benchmarks", "-e", "normal,build,features"]);
    args.extend(["-i", "swarmrt-agent"]);
    args.extend(extra);
    let mut features: Vec<String> = cargo_tree(&args)
        .iter()
        .filter_map(|l| l.strip_prefix("swarmrt-agent feature \""))
        .filter_map(|l| l.split('"').next())
        .map(str::to_string)
        .collect();
    features.sort();
    features.dedup();
    features
}

#[test]
fn the_release_robot_and_swarm_carry_no_mutants_and_no_test_hooks() {
    assert_eq!(agent_features(&[]), ["default"]);
}

/// The check can fail: asking for the mutants build shows the feature.
#[test]
fn the_mutants_build_is_seen_by_the_check() {
    assert_eq!(
        agent_features(&["--features", "swarmrt-orchestrator/mutants"]),
        ["default", "mutants"]
    );
}
