//! Property tests of config loading over mutated real configs, random `--set` overrides and
//! random text (issue 5, "Bad input"): loading never panics; an error is one non-empty line
//! that starts with the file name (or `--set`) and names the key; a config that loads is
//! valid and its resolved TOML loads back to the same config.
//!
//! The seed is fixed (see `common::mutate::runner`); explore further with e.g.
//! `PROPTEST_CASES=100000 PROPTEST_RNG_SEED=7 cargo test -p swarmrt-agent --test agent config_fuzz`.

use crate::mutate::{mutated_config, override_arg, random_text, runner};
use proptest::prelude::*;
use swarmrt_agent::registry;
use swarmrt_scenario::ConfigError;
use swarmrt_scenario::error::escape_controls;

const FILE: &str = "fuzz.toml";

/// Loads `text` with `overrides` and checks everything the loader promises about the result.
fn check_load(text: &str, overrides: &[String]) -> Result<(), TestCaseError> {
    match registry::from_toml_str(FILE, text, overrides) {
        Err(e) => check_error(&e),
        Ok(cfg) => {
            prop_assert_eq!(cfg.validate(), Ok(()));
            let resolved = cfg.to_toml();
            match registry::from_toml_str(FILE, &resolved, &[]) {
                Ok(again) => prop_assert_eq!(again, cfg, "round trip through:\n{}", resolved),
                Err(e) => prop_assert!(false, "resolved config refused: {e}\n{resolved}"),
            }
            Ok(())
        }
    }
}

/// One line, non-empty, `<file>: ...`, and the key (when there is one) named.
fn check_error(e: &ConfigError) -> Result<(), TestCaseError> {
    let shown = e.to_string();
    prop_assert!(
        e.file == FILE || e.file == "--set",
        "file {:?}: {}",
        e.file,
        shown
    );
    prop_assert!(
        shown.starts_with(&format!("{}: ", e.file)),
        "does not start with the file: {shown:?}"
    );
    prop_assert!(!e.message.trim().is_empty(), "no message: {shown:?}");
    prop_assert!(
        !shown.chars().any(char::is_control),
        "not one clean line: {shown:?}"
    );
    if !e.key.is_empty() {
        prop_assert!(
            shown.contains(&format!("key `{}`: ", escape_controls(&e.key))),
            "key not named: {shown:?}"
        );
    }
    Ok(())
}

proptest! {
    #![proptest_config(runner(4000))]

    #[test]
    fn mutated_real_configs_load_or_fail_in_one_line((_name, text, _ms) in mutated_config()) {
        check_load(&text, &[])?;
    }
}

proptest! {
    #![proptest_config(runner(3000))]

    #[test]
    fn random_overrides_load_or_fail_in_one_line(
        (_name, text) in prop::sample::select(crate::mutate::real_configs()),
        overrides in prop::collection::vec(override_arg(), 1..4),
    ) {
        check_load(&text, &overrides)?;
    }
}

proptest! {
    #![proptest_config(runner(2000))]

    #[test]
    fn random_text_fails_in_one_line(text in random_text()) {
        check_load(&text, &[])?;
    }
}

#[test]
fn every_real_config_loads_and_round_trips() {
    for (name, text) in crate::mutate::real_configs() {
        let cfg = registry::from_toml_str(&name, &text, &[]).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(registry::from_toml_str(&name, &cfg.to_toml(), &[]), Ok(cfg));
    }
}
