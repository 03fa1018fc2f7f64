//! Where a robot decides: one folder per behaviour, each owning its parameters, radio
//! message, notes, core and metrics (see [`crate::behaviour`] for the contract and
//! [`crate::registry`] for the list).

pub mod formation;
pub mod goto;
