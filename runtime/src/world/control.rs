//! The world's lines with the orchestrator: reports on stdout, control lines from stdin
//! (relayed by a small thread that wakes the loop), and the sleep both wake.

use std::collections::BTreeSet;
use std::io::Write;
use std::time::Duration;

use crossbeam_channel::{Receiver, TryRecvError};
use iceoryx2::port::listener::{Listener, ListenerWaitError};
use iceoryx2::prelude::*;
use swarmrt_ipc::{self as ipc, IpcError};
use swarmrt_protocol::control::{Control, WorldReport};
use swarmrt_protocol::services::RunServices;
use swarmrt_world::World;

use super::answers::Hellos;

/// Sleeps until the command event fires or `timeout` passes. A termination signal arriving
/// during the wait is a request to stop (`Ok(true)`), not a failure; any other interruption
/// (the EINTR Linux returns after SIGSTOP and SIGCONT) is a spurious wake.
pub(super) fn wait(
    listener: &Listener<ipc::Svc>,
    node: &Node<ipc::Svc>,
    timeout: Duration,
) -> Result<bool, IpcError> {
    match listener.timed_wait(|_| {}, timeout) {
        Ok(_) | Err(ListenerWaitError::InterruptSignal) => Ok(ipc::termination_requested(node)),
        Err(e) => Err(e.into()),
    }
}

/// Tells the orchestrator, one line on stdout.
pub(super) fn report(r: &WorldReport) {
    let mut out = std::io::stdout().lock();
    // If the orchestrator is gone there is nobody to tell; the run still finishes its records.
    let _ = out.write_all(r.to_line().as_bytes());
    let _ = out.flush();
}

/// Relays control lines from stdin to the main loop and wakes it through the command event.
pub(super) fn spawn_control_thread(run: &RunServices) -> Result<Receiver<Control>, IpcError> {
    let (tx, rx) = crossbeam_channel::unbounded();
    let eof = tx.clone();
    ipc::lines::read_json_lines(
        std::io::stdin(),
        "the orchestrator".into(),
        move |c: Control| tx.send(c).is_ok(),
        // EOF: the orchestrator is gone; finish the records and stop.
        move || {
            let _ = eof.send(Control::Stop);
        },
    );
    ipc::wake_relay(run, format!("{}-control", run.world_node_name()), rx)
}

/// Marks a robot that answered nothing for `scenario.unresponsive_ms` dead and asks the
/// orchestrator to kill its process: a hung robot must not hang the run.
pub(super) fn give_up(world: &mut World, robot: u32, waited: Duration, why: &str) {
    let waited_ms = waited.as_millis() as u64;
    tracing::warn!(
        robot,
        waited_ms,
        "robot unresponsive ({why}); marking it dead"
    );
    world.mark_dead(robot, &format!("unresponsive: {why} for {waited_ms} ms"));
    report(&WorldReport::Unresponsive { robot, waited_ms });
}

/// Applies pending control messages; returns true when the run must stop.
pub(super) fn drain_control(
    control: &Receiver<Control>,
    node: &Node<ipc::Svc>,
    world: &mut World,
    hellos: &mut Hellos,
    pending: &mut BTreeSet<u32>,
) -> Result<bool, IpcError> {
    let mut stop = false;
    loop {
        match control.try_recv() {
            Ok(Control::RobotDied { robot, reason }) => {
                world.mark_dead(robot, &reason);
                hellos.forget(robot);
                pending.remove(&robot);
                // The orchestrator has reaped it, so iceoryx2 sees its node as dead: drop its
                // ports, returning the observation samples its queue still held.
                let cleaned = node.try_cleanup_dead_nodes();
                tracing::debug!(robot, ?cleaned, "dead robot's node cleaned up");
            }
            Ok(Control::Reaped { robot }) => {
                let cleaned = node.try_cleanup_dead_nodes();
                tracing::debug!(robot, ?cleaned, "faulted robot's old node cleaned up");
            }
            Ok(Control::Stop) => stop = true,
            Err(TryRecvError::Empty) => return Ok(stop),
            Err(TryRecvError::Disconnected) => return Ok(true),
        }
    }
}
