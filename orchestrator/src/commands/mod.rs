//! One file per subcommand.

pub mod check;
pub mod clean;
pub mod run;
