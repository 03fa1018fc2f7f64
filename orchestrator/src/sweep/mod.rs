//! The pieces of `swarm sweep` (the command itself is `commands/sweep.rs`): what to run
//! ([`plan`]), running it ([`runner`]), the rows ([`table`]), their statistics ([`stats`]) and
//! what is drawn and written from them ([`figure`], [`report`]).

pub mod figure;
pub mod plan;
pub mod report;
pub mod runner;
pub mod stats;
pub mod table;
