//! The `robots.program` and `[[robots.programs]]` values as written: the types `[robots]`
//! holds. Which program a robot runs, and the checks, are `program.rs`'s.

use std::ops::Range;

use serde::{Deserialize, Deserializer, Serialize};

/// The name that means the built-in Rust robot, in `program[0]`.
pub const BUILTIN: &str = "swarm-agent";

/// What a command line must be, for errors.
pub(crate) const COMMAND_LINE: &str =
    "a command line like [\"python3\", \"robot.py\"] whose first word is a program";

/// `robots.program` as written: a command line, never `[]`. Left out, the robots run the
/// built-in `swarm-agent`; an empty list would mean the same silently, so it is refused as
/// the reference says, with the two ways to ask for the built-in robot.
pub fn command_line<'de, D: Deserializer<'de>>(d: D) -> Result<Vec<String>, D::Error> {
    let argv = Vec::<String>::deserialize(d)?;
    if argv.is_empty() {
        return Err(serde::de::Error::custom(format!(
            "expected {COMMAND_LINE}, got [] (for the built-in robot leave the key out or \
             write [\"{BUILTIN}\"])"
        )));
    }
    Ok(argv)
}

/// One `[[robots.programs]]` entry: a program for some robots.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ProgramFor {
    /// One robot id (`3`, `"3"`) or a range of ids, end excluded (`"0..4"`).
    pub robots: RobotIds,
    /// The command line (program and leading arguments).
    pub program: Vec<String>,
}

/// One robot id or a range of them.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(untagged)]
pub enum RobotIds {
    /// One id.
    One(u32),
    /// `"3"` or `"0..4"` (end excluded).
    Text(String),
}

impl RobotIds {
    /// The ids, or what was expected.
    pub fn range(&self) -> Result<Range<u32>, String> {
        let bad = |s: &str| format!("expected a robot id or a range like \"0..4\", found {s:?}");
        match self {
            RobotIds::One(id) => Ok(*id..id.saturating_add(1)),
            RobotIds::Text(s) => match s.split_once("..") {
                None => s
                    .trim()
                    .parse::<u32>()
                    .map(|id| id..id.saturating_add(1))
                    .map_err(|_| bad(s)),
                Some((a, b)) => {
                    let a: u32 = a.trim().parse().map_err(|_| bad(s))?;
                    let b: u32 = b.trim().parse().map_err(|_| bad(s))?;
                    if a >= b {
                        return Err(format!("the range {s:?} is empty"));
                    }
                    Ok(a..b)
                }
            },
        }
    }
}
