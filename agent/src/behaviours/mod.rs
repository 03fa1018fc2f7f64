//! Where a robot decides: one folder per behaviour, each owning its parameters, radio
//! message, notes, core and metrics (see [`crate::behaviour`] for the contract and
//! [`crate::registry`] for the machinery).
//!
//! **The list of behaviours.** One line each: `Variant => folder::Type`. The line declares the
//! module, gives the behaviour its variant in [`RadioMsg`] and [`Note`] (in line order, then
//! the consensus layer's), and registers its `kind`, parameters and metrics. Keep the order:
//! the variant index is the first byte of every frame and note on the wire.

crate::registry::behaviours! {
    Goto => goto::Goto,
    Formation => formation::Formation,
    Flocking => flocking::Flocking,
    Grouping => grouping::Grouping,
    Planner => planner::Planner,
    Chain => chain::Chain,
}
