//! One file per subcommand.

pub mod bench;
pub mod certs;
pub mod check;
pub mod clean;
pub mod export;
pub mod fuzz;
pub mod plan;
pub mod run;
pub mod sweep;
pub mod tune;
pub mod view;
