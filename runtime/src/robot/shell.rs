//! The robot process shell: opens the run's services, says hello, then sleeps on the run's
//! bell ([`swarmrt_ipc::bell`]) until the world publishes a tick, answers it, and sleeps again.

use std::time::Duration;

use iceoryx2::port::listener::ListenerWaitError;
use swarmrt_ipc::{self as ipc, IpcError};
use swarmrt_protocol::services::RunServices;
use swarmrt_protocol::{Observation, PROTOCOL_VERSION, RobotState};
use swarmrt_scenario::Config;

use swarmrt_agent::Agent;
use swarmrt_agent::consensus::raft::Persistent;
use swarmrt_agent::consensus::storage::Store;

/// How long a robot sleeps before checking for a termination request when no tick comes
/// (a watchdog interval, not a poll: a tick wakes it immediately).
const IDLE_CHECK: Duration = Duration::from_millis(500);

/// Why the robot loop ended.
#[derive(Debug, PartialEq, Eq)]
pub enum Exit {
    /// The world announced the end of the run.
    Shutdown,
    /// SIGINT or SIGTERM.
    Terminated,
}

/// Runs robot `id` of run `run` until the world shuts down or the process is told to stop.
/// `incarnation` is 0 for the first process of the robot and counts scheduled restarts.
/// `storage` is the run's stable-storage directory: with `consensus.storage` on, the robot
/// restores its persistent Raft state from it and writes that state there before each
/// command leaves (write-ahead). `slot_offset` is the id of the first robot in the
/// observation sample (0 beside the world; a remote host's first robot otherwise).
pub fn run(
    run: &RunServices,
    cfg: &Config,
    id: u32,
    incarnation: u32,
    storage: Option<&std::path::Path>,
    slot_offset: u32,
) -> Result<Exit, IpcError> {
    // Stable storage first: a robot whose storage is corrupt refuses to start
    // (`StoreError::Corrupt`) before it joins the run's services.
    let (store, restored) = open_store(cfg, id, incarnation, storage)?;
    let node = ipc::node(run, &run.robot_node_name(id))?;
    let ports = ipc::RobotPorts::open(&node, run, id)?;
    // With propagation rounds the robot sleeps in its own wake-up listener, which the world
    // notifies for every tick and for the rounds that have frames for it.
    let rounds = if cfg.radio.rounds > 0 {
        Some(ipc::rounds::RobotRounds::open(&node, run, id)?)
    } else {
        None
    };
    let agent = match restored {
        Some(state) => Agent::restore(cfg, id, state, incarnation),
        None => Agent::fresh(cfg, id, incarnation),
    };
    #[cfg(not(feature = "misbehave"))]
    if std::env::var_os("SWARMRT_TEST_MISBEHAVE").is_some() {
        tracing::warn!("SWARMRT_TEST_MISBEHAVE ignored: this robot was built without test hooks");
    }
    let mut robot = Robot {
        cfg,
        id,
        slot_offset,
        agent,
        store,
        ports,
        rounds,
        answered: None,
        #[cfg(feature = "misbehave")]
        misbehave: super::misbehave::Misbehave::from_env(id),
    };
    robot.ports.hello(id)?;
    tracing::debug!("hello sent");
    loop {
        // Read before draining: a tick published after this read rings past it.
        let seen = robot.ports.wait.seen();
        if let Some(exit) = robot.answer_ticks()? {
            return Ok(exit);
        }
        robot.react_to_rounds()?;
        robot.sleep(seen)?;
        if ipc::termination_requested(&node) {
            return Ok(Exit::Terminated);
        }
    }
}

/// The robot's stable storage (`consensus.storage`) and the state restored from it.
fn open_store(
    cfg: &Config,
    id: u32,
    incarnation: u32,
    storage: Option<&std::path::Path>,
) -> Result<(Option<Store>, Option<Persistent>), IpcError> {
    let Some(dir) = storage.filter(|_| swarmrt_agent::consensus::stores_state(cfg)) else {
        return Ok((None, None));
    };
    if incarnation == 0 {
        // The robot's first process: whatever a file there holds is not its state.
        let _ = std::fs::remove_file(dir.join(format!("raft-{id}.state")));
    }
    let (store, state) = Store::open(dir, id)?;
    if let Some(s) = &state {
        tracing::info!(
            term = s.term,
            last_index = s.log.last_index(),
            "restored from stable storage"
        );
    }
    Ok((Some(store), state))
}

/// A robot process between ticks: its core, its storage and its ports.
struct Robot<'a> {
    /// Read by the test hooks alone (feature `misbehave`).
    #[cfg_attr(not(feature = "misbehave"), allow(dead_code))]
    cfg: &'a Config,
    id: u32,
    slot_offset: u32,
    agent: Agent,
    store: Option<Store>,
    ports: ipc::RobotPorts,
    rounds: Option<ipc::rounds::RobotRounds>,
    /// The observation this robot last answered, for the rounds of its tick, and the last
    /// round it reacted to.
    answered: Option<(Box<Observation>, u32)>,
    #[cfg(feature = "misbehave")]
    misbehave: Option<super::misbehave::Misbehave>,
}

impl Robot<'_> {
    /// Answers every tick that arrived, in order; `Some` when the world ended the run.
    fn answer_ticks(&mut self) -> Result<Option<Exit>, IpcError> {
        while let Some(sample) = self.ports.subscriber.receive()? {
            let header = *sample.user_header();
            if header.version != PROTOCOL_VERSION {
                return Err(format!(
                    "world speaks protocol {} but this robot speaks {PROTOCOL_VERSION}",
                    header.version
                )
                .into());
            }
            if header.shutdown != 0 {
                return Ok(Some(Exit::Shutdown));
            }
            let id = self.id;
            let Some(obs) = sample.payload().get((id - self.slot_offset) as usize) else {
                return Err(format!("observation sample has no slot for robot {id}").into());
            };
            // Ticks in which this robot is frozen or restarting (a thawed or fresh process
            // may find one still queued) expect no answer.
            if !RobotState::from_u8(obs.state).is_some_and(RobotState::expects_command) {
                continue;
            }
            let step = self.agent.step(obs);
            if self.rounds.is_some() {
                self.answered = Some((Box::new(*obs), 0));
            }
            drop(sample);
            // Write-ahead: the command is handed out only once its state change is durable.
            let store = &mut self.store;
            let cmd = step.persist_then(|change| match store.as_mut() {
                Some(store) => store.persist(&change),
                None => Ok(()),
            })?;
            #[cfg(feature = "misbehave")]
            let cmd = match self.misbehave {
                Some(m) => m.corrupted(cmd, id, self.cfg, &self.ports)?,
                None => cmd,
            };
            self.ports.send(cmd)?;
        }
        Ok(None)
    }

    /// The rounds of the tick just answered: reacts to the newest one that holds frames for
    /// this robot (the world publishes a round only once all of the previous round's robots
    /// answered, so no round for it is ever skipped).
    fn react_to_rounds(&mut self) -> Result<(), IpcError> {
        let Some(r) = &self.rounds else {
            return Ok(());
        };
        while let Some(sample) = r.subscriber.receive()? {
            let header = *sample.user_header();
            let Some((obs, last)) = self.answered.as_mut() else {
                continue;
            };
            if header.version != PROTOCOL_VERSION
                || header.tick != obs.tick
                || header.round <= *last
            {
                continue;
            }
            let inboxes = sample.payload();
            let Ok(k) = inboxes.binary_search_by_key(&self.id, |b| b.robot) else {
                continue;
            };
            let cmd = self.agent.react(obs, inboxes[k].inbox());
            *last = header.round;
            drop(sample);
            self.ports.send(cmd)?;
        }
        Ok(())
    }

    /// With rounds the world wakes this robot's own listener for every tick and round;
    /// otherwise the robot sleeps on the bell. Either wait also ends on a signal:
    /// SIGTERM/SIGINT (checked by the caller) or the SIGCONT ending a freeze.
    fn sleep(&self, seen: u32) -> Result<(), IpcError> {
        match &self.rounds {
            Some(r) => match r.listener.timed_wait(|_| {}, IDLE_CHECK) {
                Ok(_) | Err(ListenerWaitError::InterruptSignal) => Ok(()),
                Err(e) => Err(e.into()),
            },
            None => {
                self.ports.wait.wait(seen, IDLE_CHECK)?;
                Ok(())
            }
        }
    }
}
