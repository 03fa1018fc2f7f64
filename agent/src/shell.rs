//! The robot process shell: opens the run's services, says hello, then sleeps in an
//! iceoryx2 listener until the world publishes a tick, answers it, and sleeps again.

use std::time::Duration;

use iceoryx2::prelude::*;
use swarmrt_protocol::config::Config;
use swarmrt_protocol::ipc::{self, IpcError};
use swarmrt_protocol::services::{EVENT_COMMAND, RunServices};
use swarmrt_protocol::{Command, PROTOCOL_VERSION};

use crate::Agent;

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
pub fn run(run: &RunServices, cfg: &Config, id: u32) -> Result<Exit, IpcError> {
    let node = ipc::node(run, &run.robot_node_name(id))?;
    let services = ipc::open_services(&node, run)?;
    let subscriber = services.observations.subscriber_builder().create()?;
    let listener = services.observations_event.listener_builder().create()?;
    let publisher = services.commands.publisher_builder().create()?;
    let notifier = services
        .commands_event
        .notifier_builder()
        .default_event_id(EventId::new(EVENT_COMMAND))
        .create()?;

    let mut agent = Agent::new(cfg, id);
    publisher.send_copy(Command::hello(id, std::process::id()))?;
    notifier.notify()?;
    tracing::debug!("hello sent");

    loop {
        // Drain every sample that arrived; each is one tick to answer, in order.
        while let Some(sample) = subscriber.receive()? {
            let header = *sample.user_header();
            if header.version != PROTOCOL_VERSION {
                return Err(format!(
                    "world speaks protocol {} but this robot speaks {PROTOCOL_VERSION}",
                    header.version
                )
                .into());
            }
            if header.shutdown != 0 {
                return Ok(Exit::Shutdown);
            }
            let Some(obs) = sample.payload().get(id as usize) else {
                return Err(format!("observation sample has no slot for robot {id}").into());
            };
            let cmd = agent.step(obs);
            drop(sample);
            publisher.send_copy(cmd)?;
            notifier.notify()?;
        }
        listener.timed_wait(|_| {}, IDLE_CHECK)?;
        if node.wait(Duration::ZERO).is_err() {
            return Ok(Exit::Terminated);
        }
    }
}
