//! Where a robot decides: one folder per behaviour, each owning its parameters, radio
//! message, notes, core and metrics (see [`crate::behaviour`] for the contract and
//! [`crate::registry`] for the machinery).
//!
//! **The list of behaviours.** One line each: `Variant = tag => folder::Type`. The line
//! declares the module, gives the behaviour its variant in [`RadioMsg`] and [`Note`] (then the
//! consensus layer's), and registers its `kind`, parameters and metrics. The tag is the first
//! byte of every frame and note of the behaviour on the wire, and robots in other languages
//! hard-code it (through the generated `bindings/python/swarmrt/_tags.py` and
//! `bindings/c/include/swarmrt_tags.h`): never change one. A new behaviour takes the next
//! unused tag; 6 is the consensus layer's ([`crate::wire::CONSENSUS_TAG`]).

crate::registry::behaviours! {
    Goto = 0 => goto::Goto,
    Formation = 1 => formation::Formation,
    Flocking = 2 => flocking::Flocking,
    Grouping = 3 => grouping::Grouping,
    Planner = 4 => planner::Planner,
    Chain = 5 => chain::Chain,
}
