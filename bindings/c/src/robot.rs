//! One robot process's side of a run, as `runtime/src/robot/shell.rs` does it for the Rust robot,
//! with the decision left to the caller: [`Robot::open`] opens the node and the ports and
//! says hello, [`Robot::next`] sleeps until there is an observation to answer, and
//! [`Robot::send`] answers it.
//!
//! The rules (the same as the Rust robot's):
//!
//! - Every sample queued is drained after a wake-up; each one is a tick. The sample is copied
//!   (this robot's slot only) and released before the next receive: the observation service
//!   lets a subscriber borrow one sample at a time.
//! - A sample of another protocol version is an error; a sample with `shutdown != 0` ends
//!   the run ([`Step::Shutdown`], exit code 0, which means exactly that to the orchestrator).
//! - The robot reads slot `robot - slot_offset` and answers only when the state there is
//!   ACTIVE or DOWN (a thawed or restarted process may find a FROZEN or RESTARTING tick still
//!   queued; the world expects no answer to it).
//! - The wait is a 500 ms watchdog, not a poll; an interrupted wait (EINTR after the SIGCONT
//!   that ends a scheduled freeze) is a spurious wake. Only `node.wait` reporting a
//!   termination request (iceoryx2's SIGTERM/SIGINT handler) ends the loop
//!   ([`Step::Terminated`], exit code 143).

use std::ffi::OsString;
use std::path::PathBuf;
use std::time::Duration;

use iceoryx2::prelude::Node;
use swarmrt_ipc::{self as ipc, RobotPorts, Svc};
use swarmrt_protocol::services::{RunServices, env, valid_run_id};
use swarmrt_protocol::{Command, Observation, PROTOCOL_VERSION, RobotState};

use crate::config::Config;
use crate::error::Error;

/// How long a robot sleeps before checking for a termination request when no tick comes.
const IDLE_CHECK: Duration = Duration::from_millis(500);

/// Exit code of a robot whose world ended the run.
pub const EXIT_SHUTDOWN: i32 = 0;
/// Exit code of a robot that failed (an error, not a signal).
pub const EXIT_FAILED: i32 = 1;
/// Exit code of a robot ended by SIGTERM or SIGINT (128 + 15).
pub const EXIT_TERMINATED: i32 = 143;

/// What the orchestrator tells a robot program in its environment.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct RobotEnv {
    /// `SWARMRT_RUN_ID`.
    pub run_id: String,
    /// `SWARMRT_ROBOT`.
    pub robot: u32,
    /// `SWARMRT_INCARNATION` (0 when unset).
    pub incarnation: u32,
    /// `SWARMRT_CONFIG`: the resolved config.
    pub config: PathBuf,
    /// `SWARMRT_STORAGE`, if set.
    pub storage: Option<PathBuf>,
    /// `SWARMRT_SLOT_OFFSET` (0 when unset).
    pub slot_offset: u32,
    /// `SWARMRT_NODE_NAME` (the run's name for this robot's node when unset).
    pub node_name: String,
}

impl RobotEnv {
    /// Reads the process environment.
    pub fn from_env() -> Result<RobotEnv, Error> {
        RobotEnv::from_lookup(|k| std::env::var_os(k))
    }

    /// Reads the variables through `var` (the process environment, or a test's map).
    pub fn from_lookup(var: impl Fn(&str) -> Option<OsString>) -> Result<RobotEnv, Error> {
        let text = |name: &'static str| -> Result<Option<String>, Error> {
            match var(name) {
                None => Ok(None),
                Some(v) => v.into_string().map(Some).map_err(|_| Error::Env {
                    var: name,
                    message: "not valid UTF-8".into(),
                }),
            }
        };
        let required = |name: &'static str| -> Result<String, Error> {
            text(name)?.ok_or(Error::Env {
                var: name,
                message: "not set (is this program started by `swarm run`?)".into(),
            })
        };
        let number = |name: &'static str, v: &str| -> Result<u32, Error> {
            v.parse().map_err(|_| Error::Env {
                var: name,
                message: format!("expected a non-negative integer, found {v:?}"),
            })
        };
        let run_id = required(env::RUN_ID)?;
        if !valid_run_id(&run_id) {
            return Err(Error::Env {
                var: env::RUN_ID,
                message: format!("expected 1-32 lower-case hex digits, found {run_id:?}"),
            });
        }
        let robot = number(env::ROBOT, &required(env::ROBOT)?)?;
        let optional = |name: &'static str| -> Result<u32, Error> {
            text(name)?.map_or(Ok(0), |v| number(name, &v))
        };
        let incarnation = optional(env::INCARNATION)?;
        let slot_offset = optional(env::SLOT_OFFSET)?;
        if slot_offset > robot {
            return Err(Error::Env {
                var: env::SLOT_OFFSET,
                message: format!("{slot_offset} is past this robot's id {robot}"),
            });
        }
        let config = PathBuf::from(var(env::CONFIG).ok_or(Error::Env {
            var: env::CONFIG,
            message: "not set (is this program started by `swarm run`?)".into(),
        })?);
        let storage = var(env::STORAGE).map(PathBuf::from);
        let node_name = text(env::NODE_NAME)?
            .unwrap_or_else(|| RunServices::new(&run_id).robot_node_name(robot));
        Ok(RobotEnv {
            run_id,
            robot,
            incarnation,
            config,
            storage,
            slot_offset,
            node_name,
        })
    }
}

/// How [`Robot::next`] ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Step {
    /// An observation to answer (with exactly one [`Robot::send`]).
    Observation,
    /// The world ended the run: exit with [`EXIT_SHUTDOWN`].
    Shutdown,
    /// SIGTERM or SIGINT: exit with [`EXIT_TERMINATED`].
    Terminated,
}

/// A robot joined to a run. Not thread-safe: one thread drives it.
pub struct Robot {
    // Ports before the node: fields drop in order, and the ports belong to the node.
    ports: RobotPorts,
    node: Node<Svc>,
    env: RobotEnv,
    config: Config,
    /// How the run ended for this robot, once it has (`next` then says the same again).
    ended: Option<Step>,
}

impl Robot {
    /// Joins the run the environment names: loads the config, creates the node and the
    /// ports, and says hello.
    pub fn open(env: RobotEnv) -> Result<Robot, Error> {
        let config = Config::load(&env.config)?;
        if let Ok(Some(count)) = config.i64("robots.count")
            && i64::from(env.robot) >= count
        {
            return Err(Error::Env {
                var: env::ROBOT,
                message: format!("robot {} is past robots.count = {count}", env.robot),
            });
        }
        let run = RunServices::new(&env.run_id);
        let node = ipc::node(&run, &env.node_name)?;
        let ports = RobotPorts::open(&node, &run, env.robot)?;
        ports.hello(env.robot)?;
        Ok(Robot {
            ports,
            node,
            env,
            config,
            ended: None,
        })
    }

    /// What the environment said.
    pub fn env(&self) -> &RobotEnv {
        &self.env
    }

    /// The run's resolved config.
    pub fn config(&self) -> &Config {
        &self.config
    }

    /// Sleeps until there is an observation to answer and copies it into `out`, or until the
    /// run ends for this robot. Once it has ended, says so again without waiting.
    pub fn next(&mut self, out: &mut Observation) -> Result<Step, Error> {
        if let Some(end) = self.ended {
            return Ok(end);
        }
        let slot = (self.env.robot - self.env.slot_offset) as usize;
        loop {
            // Read before draining: a tick published after this read rings past it.
            let seen = self.ports.wait.seen();
            // Drain every sample that arrived; each is one tick to answer, in order.
            while let Some(sample) = self
                .ports
                .subscriber
                .receive()
                .map_err(|e| Error::Ipc(format!("receive: {e:?}")))?
            {
                let header = *sample.user_header();
                if header.version != PROTOCOL_VERSION {
                    return Err(Error::Protocol(format!(
                        "world speaks protocol {} but this library speaks {PROTOCOL_VERSION}",
                        header.version
                    )));
                }
                if header.shutdown != 0 {
                    self.ended = Some(Step::Shutdown);
                    return Ok(Step::Shutdown);
                }
                let Some(obs) = sample.payload().get(slot) else {
                    return Err(Error::Protocol(format!(
                        "observation sample has no slot for robot {}",
                        self.env.robot
                    )));
                };
                // Ticks in which this robot is frozen or restarting expect no answer.
                if !RobotState::from_u8(obs.state).is_some_and(RobotState::expects_command) {
                    continue;
                }
                *out = *obs;
                return Ok(Step::Observation);
            }
            // Sleeps on the run's bell; a signal ends the wait too: SIGTERM/SIGINT (checked
            // below) or the SIGCONT ending a freeze.
            self.ports
                .wait
                .wait(seen, IDLE_CHECK)
                .map_err(|e| Error::Ipc(format!("wait: {e}")))?;
            if ipc::termination_requested(&self.node) {
                self.ended = Some(Step::Terminated);
                return Ok(Step::Terminated);
            }
        }
    }

    /// Publishes `cmd` and wakes the world.
    pub fn send(&self, cmd: &Command) -> Result<(), Error> {
        Ok(self.ports.send(*cmd)?)
    }
}

/// The exit code for how the loop ended: `Ok(Shutdown)` 0, `Ok(Terminated)` 143, an error 1.
pub fn exit_code(step: Result<Step, &Error>) -> i32 {
    match step {
        Ok(Step::Shutdown) => EXIT_SHUTDOWN,
        Ok(Step::Terminated) => EXIT_TERMINATED,
        Ok(Step::Observation) | Err(_) => EXIT_FAILED,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::collections::BTreeMap;

    fn lookup(vars: &[(&str, &str)]) -> impl Fn(&str) -> Option<OsString> {
        let map: BTreeMap<String, OsString> = vars
            .iter()
            .map(|(k, v)| (k.to_string(), OsString::from(v)))
            .collect();
        move |k| map.get(k).cloned()
    }

    #[test]
    fn the_environment_of_a_robot_program_is_read() {
        let e = RobotEnv::from_lookup(lookup(&[
            (env::RUN_ID, "00ab"),
            (env::ROBOT, "3"),
            (env::INCARNATION, "2"),
            (env::CONFIG, "/r/config.toml"),
            (env::STORAGE, "/r/storage"),
            (env::SLOT_OFFSET, "1"),
        ]))
        .unwrap();
        assert_eq!(e.robot, 3);
        assert_eq!(e.incarnation, 2);
        assert_eq!(e.slot_offset, 1);
        assert_eq!(e.config, PathBuf::from("/r/config.toml"));
        assert_eq!(e.storage, Some(PathBuf::from("/r/storage")));
        assert_eq!(e.node_name, RunServices::new("00ab").robot_node_name(3));
        let minimal = RobotEnv::from_lookup(lookup(&[
            (env::RUN_ID, "00ab"),
            (env::ROBOT, "0"),
            (env::CONFIG, "c.toml"),
            (env::NODE_NAME, "me"),
        ]))
        .unwrap();
        assert_eq!((minimal.incarnation, minimal.slot_offset), (0, 0));
        assert_eq!(minimal.node_name, "me");
    }

    #[test]
    fn a_missing_or_bad_variable_is_named() {
        let base = [
            (env::RUN_ID, "00ab"),
            (env::ROBOT, "3"),
            (env::CONFIG, "/r/config.toml"),
        ];
        for (drop, name) in [(0, env::RUN_ID), (1, env::ROBOT), (2, env::CONFIG)] {
            let mut vars = base.to_vec();
            vars.remove(drop);
            let e = RobotEnv::from_lookup(lookup(&vars)).unwrap_err();
            assert!(e.to_string().starts_with(name), "{e}");
            assert!(e.to_string().contains("not set"), "{e}");
        }
        for (var, value) in [
            (env::RUN_ID, "../x"),
            (env::ROBOT, "-1"),
            (env::INCARNATION, "x"),
            (env::SLOT_OFFSET, "4"),
        ] {
            let mut vars = base.to_vec();
            vars.retain(|(k, _)| *k != var);
            vars.push((var, value));
            let e = RobotEnv::from_lookup(lookup(&vars)).unwrap_err();
            assert!(e.to_string().starts_with(var), "{var}: {e}");
        }
    }

    #[test]
    fn opening_a_run_that_does_not_exist_fails_cleanly() {
        let dir = tempfile::tempdir().unwrap();
        let cfg = dir.path().join("config.toml");
        std::fs::write(&cfg, "[robots]\ncount = 2\n").unwrap();
        let env = |robot: u32| RobotEnv {
            // A run id no world ever created.
            run_id: format!("{:x}", 0xc0de_0000_u64 + std::process::id() as u64),
            robot,
            incarnation: 0,
            config: cfg.clone(),
            storage: None,
            slot_offset: 0,
            node_name: format!("swarmrt-c-test-{}", std::process::id()),
        };
        let e = Robot::open(env(2)).err().unwrap();
        assert!(e.to_string().contains("past robots.count = 2"), "{e}");
        let e = Robot::open(env(1)).err().unwrap();
        assert!(e.to_string().starts_with("iceoryx2:"), "{e}");
        let run_id = env(1).run_id;
        swarmrt_ipc::cleanup::remove_run(&run_id);
        assert_eq!(
            swarmrt_ipc::cleanup::leftovers(&run_id),
            Vec::<String>::new()
        );
        assert_eq!(exit_code(Err(&e)), EXIT_FAILED);
        assert_eq!(exit_code(Ok(Step::Shutdown)), EXIT_SHUTDOWN);
        assert_eq!(exit_code(Ok(Step::Terminated)), EXIT_TERMINATED);
    }
}
