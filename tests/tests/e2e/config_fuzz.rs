//! Config fuzzing past the loader (issue 5, "Bad input"): every mutated config that loads
//! builds its world or is refused with a key, and `swarm check` / `swarm run` on mutated
//! configs exit 0 or 2, never 1, never a panic or a signal, with one line naming the file.
//!
//! The mutations are those of `agent/tests/config_fuzz.rs`, from a fixed seed; explore
//! further with `PROPTEST_CASES` and `PROPTEST_RNG_SEED`.

#[path = "../../../scenario/tests/common/hostile.rs"]
mod hostile;
#[path = "../../../agent/tests/common/mutate.rs"]
mod mutate;

use std::path::Path;
use std::process::Output;
use std::time::Duration;

use mutate::{geometry_override, mutated_config, override_arg, renumbered_config, runner};
use proptest::prelude::*;
use swarmrt_agent::registry;
use swarmrt_scenario::{Config, ConfigError};
use swarmrt_tests::swarm;
use swarmrt_world::World;

const LIMIT: Duration = Duration::from_secs(60);

proptest! {
    #![proptest_config(runner(500))]

    /// In process, so it can run many cases: what the protocol accepts, the world builds or
    /// refuses with a key and a one-line message (robots that do not fit the map, a polygon
    /// without area), never with a panic.
    #[test]
    fn every_config_that_loads_builds_its_world_or_names_the_key(
        (_name, text, _ms) in mutated_config(),
        overrides in prop::collection::vec(override_arg(), 0..2),
    ) {
        if let Ok(cfg) = registry::from_toml_str("fuzz.toml", &text, &overrides)
            && let Err(e) = World::new(&cfg, registry::VOCABULARY)
        {
            prop_assert!(!e.key.is_empty(), "{e:?}");
            prop_assert!(
                !e.message.is_empty() && !e.message.chars().any(char::is_control),
                "{e:?}"
            );
        }
    }
}

proptest! {
    #![proptest_config(runner(1000))]

    /// Whole shapes set at once with huge, tiny or non-finite numbers: the map is built or
    /// refused with a key, never with a panic inside the geometry library.
    #[test]
    fn extreme_geometry_builds_its_world_or_names_the_key(
        (_name, text) in prop::sample::select(mutate::real_configs()),
        overrides in prop::collection::vec(geometry_override(), 1..4),
    ) {
        if let Ok(cfg) = registry::from_toml_str("fuzz.toml", &text, &overrides)
            && let Err(e) = World::new(&cfg, registry::VOCABULARY)
        {
            prop_assert!(!e.key.is_empty(), "{e:?}");
        }
    }
}

/// What `swarm check` does to a scenario, step by step as
/// `swarmrt_harness::config::load_run_config` does it (this crate does not depend on the
/// harness): read the file with its `--set`s and validate, resolve `[behaviour]`, build the
/// world (its map and start layout), find the robot programs from `cwd`.
fn load_as_swarm_check(path: &Path, set: &[String], cwd: &Path) -> Result<Config, ConfigError> {
    let file = path.display().to_string();
    let mut cfg = registry::load(path, set)?;
    World::new(&cfg, registry::VOCABULARY)
        .map_err(|e| ConfigError::new(&file, e.key, e.message))?;
    swarmrt_scenario::program::resolve(&mut cfg, &file, cwd)?;
    Ok(cfg)
}

proptest! {
    #![proptest_config(hostile::runner(300))]

    /// Issue 48: hostile mutations of the real configs and hostile `--set`s (extreme and
    /// non-finite numbers, long strings, wrong types, arrays past their bounds, degenerate
    /// obstacles) pass everything `swarm check` does, or are refused in one short line naming
    /// the file; never a panic. What is accepted, the world and robot processes accept: the
    /// resolved config, written as a run directory holds it, loads and builds again.
    #[test]
    fn hostile_configs_pass_every_check_or_are_refused_in_one_short_line(case in hostile::case()) {
        let tmp = tempfile::tempdir().unwrap();
        let path = tmp.path().join(&case.name);
        std::fs::write(&path, &case.text).unwrap();
        match load_as_swarm_check(&path, &case.overrides, tmp.path()) {
            Ok(cfg) => {
                let resolved = tmp.path().join("config.toml");
                std::fs::write(&resolved, cfg.to_toml()).unwrap();
                let (_, mut again) = swarmrt_scenario::process::load_run("00ab", &resolved)
                    .map_err(|e| TestCaseError::fail(format!("{:?}: world refused {e}", case.what)))?;
                registry::resolve(&mut again, "config.toml")
                    .map_err(|e| TestCaseError::fail(format!("{:?}: robots refused {e}", case.what)))?;
                prop_assert!(World::new(&again, registry::VOCABULARY).is_ok(), "{:?}", case.what);
                for id in [0, again.robots.count - 1] {
                    prop_assert!(registry::brain(&again, id).is_ok(), "{:?}", case.what);
                }
            }
            Err(e) => {
                let shown = e.to_string();
                let n = shown.chars().count();
                prop_assert!(n <= 2048, "{:?}: {n} characters", case.what);
                prop_assert!(!shown.chars().any(char::is_control), "{:?}: {shown:?}", case.what);
                prop_assert!(
                    e.file == path.display().to_string() || e.file == "--set",
                    "{:?}: {shown}",
                    case.what
                );
            }
        }
    }
}

/// Exit 0, or exit 2 with exactly one non-empty stderr line naming `file`; never a panic.
fn check_exit(out: &Output, file: &Path, what: &str) -> Result<(), TestCaseError> {
    let err = String::from_utf8_lossy(&out.stderr);
    prop_assert!(!err.contains("panicked"), "{what}: {err}");
    match out.status.code() {
        Some(0) => {}
        Some(2) => {
            let lines: Vec<&str> = err.lines().collect();
            prop_assert_eq!(lines.len(), 1, "{}: one line: {}", what, err);
            prop_assert!(!lines[0].trim().is_empty(), "{what}: empty line");
            prop_assert!(
                lines[0].contains(&file.display().to_string()),
                "{what}: file not named: {err}"
            );
        }
        other => prop_assert!(false, "{what}: exit {other:?} ({}): {err}", out.status),
    }
    Ok(())
}

proptest! {
    #![proptest_config(runner(48))]

    /// Through the real binary: `swarm check`, and for a config it accepts, a three-tick
    /// in-process `swarm run`.
    #[test]
    fn swarm_check_and_run_exit_0_or_2_with_one_line((name, text, ms) in mutated_config()) {
        let tmp = tempfile::tempdir().unwrap();
        let file = tmp.path().join(&name);
        std::fs::write(&file, &text).unwrap();
        let path = file.to_str().unwrap();
        let what = format!("{name} mutated by {ms:?}");
        let out = swarm(&["check", path], LIMIT);
        check_exit(&out, &file, &format!("check {what}"))?;
        if out.status.success() {
            let run_dir = tmp.path().join("run");
            let out = swarm(
                &["run", path, "--ticks", "3", "--in-process", "--out", run_dir.to_str().unwrap()],
                LIMIT,
            );
            check_exit(&out, &file, &format!("run {what}"))?;
        }
    }
}

proptest! {
    #![proptest_config(runner(16))]

    /// Three-tick in-process runs of configs with a few numbers changed (most still load):
    /// they run (exit 0) or are refused in one line (exit 2).
    #[test]
    fn swarm_run_of_renumbered_configs_exits_0_or_2((name, text, ms) in renumbered_config()) {
        let tmp = tempfile::tempdir().unwrap();
        let file = tmp.path().join(&name);
        std::fs::write(&file, &text).unwrap();
        let run_dir = tmp.path().join("run");
        let out = swarm(
            &[
                "run",
                file.to_str().unwrap(),
                "--ticks",
                "3",
                "--in-process",
                "--out",
                run_dir.to_str().unwrap(),
            ],
            LIMIT,
        );
        check_exit(&out, &file, &format!("run {name} mutated by {ms:?}"))?;
    }
}
