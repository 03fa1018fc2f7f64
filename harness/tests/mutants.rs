//! Each known bug of the Raft core (the `mutants` feature, docs/consensus.md) is caught by
//! `swarm fuzz consensus` within a few seeds from a start seed measured to catch it, and the
//! real core holds on those same seeds.

use swarmrt_agent::consensus::raft::{Mutant, set_mutant};
use swarmrt_harness::fuzz::consensus::{draw, run};

/// Mutant, and the first seed (from 0) at which the release fuzzer catches it
/// (`swarm fuzz consensus --seeds 10000 --mutant NAME`).
const CAUGHT_AT: [(&str, u64); 8] = [
    ("vote-for-anyone", 0),
    ("no-up-to-date-check", 5),
    ("keep-conflicting-entries", 2),
    ("commit-earlier-term", 676),
    ("forget-vote-on-restart", 1),
    ("accept-stale-append", 42),
    ("no-step-down", 0),
    ("apply-before-commit", 0),
];

/// A safety failure (a checker violation or a restart that lost state), not liveness.
fn violation(seed: u64) -> Option<String> {
    run(&draw(seed), false)
        .failures
        .into_iter()
        .find(|f| !f.starts_with("liveness"))
}

#[test]
fn every_mutant_is_caught_and_the_real_core_holds_on_the_same_seed() {
    for (name, seed) in CAUGHT_AT {
        let m = Mutant::parse(name).expect("a known mutant");
        set_mutant(Some(m));
        let caught = violation(seed);
        set_mutant(None);
        assert!(caught.is_some(), "{name}: seed {seed} not caught");
        let real = run(&draw(seed), false);
        assert!(
            real.failures.is_empty(),
            "{name}: real core on seed {seed}: {:?}",
            real.failures
        );
    }
}

#[test]
fn the_switch_is_per_thread() {
    set_mutant(Some(Mutant::ApplyBeforeCommit));
    let other = std::thread::spawn(|| run(&draw(0), false).failures)
        .join()
        .expect("thread ran");
    set_mutant(None);
    assert!(other.is_empty(), "{other:?}");
}
