//! How the world paces its ticks, and which ways of reaching the robots go together: decided
//! here once, for `swarm run` (which refuses before it writes anything) and `swarm-world`.

use swarmrt_scenario::Config;

/// How the world paces its ticks.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Mode {
    /// Each tick waits for every live robot's answer (or its deadline): replayable.
    LockStep,
    /// One tick every `scenario.dt` of wall-clock time, with whatever commands arrived
    /// (DESIGN section 2): for slow foreign controllers and hardware in the loop.
    Realtime,
}

/// A combination of the config, the pacing and remote hosts that cannot run.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Refusal {
    /// The flag that cannot go with the config: `--realtime` or `--hosts`.
    pub flag: &'static str,
    /// `radio.rounds` of the config.
    pub rounds: u32,
}

impl std::fmt::Display for Refusal {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let flag = self.flag;
        write!(
            f,
            "key `radio.rounds`: expected 0 with {flag}, got {}: propagation rounds need \
             every robot's answer within the tick on this host (drop {flag}, or set radio.rounds = 0)",
            self.rounds
        )
    }
}

impl std::error::Error for Refusal {}

/// Propagation rounds (`radio.rounds` > 0) need every robot on this host, in lock-step: each
/// round waits for the reactions of the robots it woke within the tick.
pub fn refuse_combination(cfg: &Config, mode: Mode, hosts: bool) -> Result<(), Refusal> {
    let flag = match (mode, hosts) {
        _ if cfg.radio.rounds == 0 => return Ok(()),
        (Mode::Realtime, _) => "--realtime",
        (Mode::LockStep, true) => "--hosts",
        (Mode::LockStep, false) => return Ok(()),
    };
    Err(Refusal {
        flag,
        rounds: cfg.radio.rounds,
    })
}
