//! The robot process shell: opens the run's services, says hello, then sleeps in an
//! iceoryx2 listener until the world publishes a tick, answers it, and sleeps again.

use std::time::Duration;

use iceoryx2::port::listener::ListenerWaitError;
use swarmrt_protocol::ipc::{self, IpcError};
use swarmrt_protocol::services::RunServices;
use swarmrt_protocol::{PROTOCOL_VERSION, RobotState};
use swarmrt_scenario::Config;

use crate::Agent;
use crate::consensus::storage::Store;

/// How long a robot sleeps before checking for a termination request when no tick comes
/// (a watchdog interval, not a poll: a tick wakes it immediately).
const IDLE_CHECK: Duration = Duration::from_millis(500);

/// Environment variable that makes one robot send malformed commands, for tests of the
/// world's input checks: `<robot>:<mode>` with mode `nan` (NaN speed), `inf` (infinite turn
/// rate), `fast` (a speed far past the limit), `wrong-tick`, `wrong-version`, `impersonate`
/// (claims another robot's id), `double` (answers every tick twice), `bad-frame` (an outbox
/// length past the maximum), `oversized-frame` (a frame length past the payload size),
/// `garbage-frame` (a payload that is no message), `frame-to-nobody` (a unicast to an unknown
/// robot), `garbage-notes` (a report that does not decode), `panic` (panics at tick 20) or
/// `slow` (thinks 250 ms per tick, for `--realtime` runs).
pub const MISBEHAVE_ENV: &str = "SWARMRT_TEST_MISBEHAVE";

/// How a misbehaving robot corrupts its commands.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Misbehave {
    Nan,
    Inf,
    Fast,
    WrongTick,
    WrongVersion,
    Impersonate,
    Double,
    BadFrame,
    OversizedFrame,
    GarbageFrame,
    FrameToNobody,
    GarbageNotes,
    Panic,
    Slow,
}

fn misbehave_for(id: u32) -> Option<Misbehave> {
    let spec = std::env::var(MISBEHAVE_ENV).ok()?;
    let (robot, mode) = spec.split_once(':')?;
    if robot.parse::<u32>().ok()? != id {
        return None;
    }
    match mode {
        "nan" => Some(Misbehave::Nan),
        "inf" => Some(Misbehave::Inf),
        "fast" => Some(Misbehave::Fast),
        "wrong-tick" => Some(Misbehave::WrongTick),
        "wrong-version" => Some(Misbehave::WrongVersion),
        "impersonate" => Some(Misbehave::Impersonate),
        "double" => Some(Misbehave::Double),
        "bad-frame" => Some(Misbehave::BadFrame),
        "oversized-frame" => Some(Misbehave::OversizedFrame),
        "garbage-frame" => Some(Misbehave::GarbageFrame),
        "frame-to-nobody" => Some(Misbehave::FrameToNobody),
        "garbage-notes" => Some(Misbehave::GarbageNotes),
        "panic" => Some(Misbehave::Panic),
        "slow" => Some(Misbehave::Slow),
        _ => None,
    }
}

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
    let node = ipc::node(run, &run.robot_node_name(id))?;
    let ports = ipc::RobotPorts::open(&node, run)?;

    let (mut store, restored) = match storage {
        Some(dir) if crate::consensus::stores_state(cfg) => {
            if incarnation == 0 {
                // The robot's first process: whatever a file there holds is not its state.
                let _ = std::fs::remove_file(dir.join(format!("raft-{id}.state")));
            }
            let (store, state) = Store::open(dir, id)?;
            (Some(store), state)
        }
        _ => (None, None),
    };
    if let Some(s) = &restored {
        tracing::info!(
            term = s.term,
            last_index = s.log.last_index(),
            "restored from stable storage"
        );
    }
    let mut agent = match restored {
        Some(state) => Agent::restore(cfg, id, state, incarnation),
        None => Agent::fresh(cfg, id, incarnation),
    };
    let misbehave = misbehave_for(id);
    if let Some(m) = misbehave {
        tracing::warn!(?m, "test hook: this robot sends malformed commands");
    }
    ports.hello(id)?;
    tracing::debug!("hello sent");

    loop {
        // Drain every sample that arrived; each is one tick to answer, in order.
        while let Some(sample) = ports.subscriber.receive()? {
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
            let Some(obs) = sample.payload().get((id - slot_offset) as usize) else {
                return Err(format!("observation sample has no slot for robot {id}").into());
            };
            // Ticks in which this robot is frozen or restarting (a thawed or fresh process
            // may find one still queued) expect no answer.
            if !RobotState::from_u8(obs.state).is_some_and(RobotState::expects_command) {
                continue;
            }
            let mut cmd = agent.step(obs);
            let obs_tick = obs.tick;
            drop(sample);
            if let (Some(store), Some(state)) = (
                store.as_mut(),
                agent.consensus().and_then(|c| c.persistent()),
            ) {
                store.save(&state)?;
            }
            match misbehave {
                Some(Misbehave::Nan) => cmd.v = f64::NAN,
                Some(Misbehave::Inf) => cmd.omega = f64::INFINITY,
                Some(Misbehave::Fast) => cmd.v = 1e6,
                Some(Misbehave::WrongTick) => cmd.tick += 1,
                Some(Misbehave::WrongVersion) => cmd.version = PROTOCOL_VERSION + 1,
                Some(Misbehave::Impersonate) => cmd.robot = (id + 1) % cfg.robots.count,
                Some(Misbehave::BadFrame) => cmd.outbox_len = u16::MAX,
                Some(Misbehave::OversizedFrame) => {
                    cmd.outbox_len = 1;
                    cmd.outbox[0].len = u16::MAX;
                }
                Some(Misbehave::GarbageFrame) => {
                    cmd.outbox_len = 1;
                    cmd.outbox[0].dst = swarmrt_protocol::BROADCAST;
                    cmd.outbox[0].len = 3;
                    // The goto tag and a beacon cut short: neither a message nor opaque.
                    cmd.outbox[0].payload[..3].copy_from_slice(&[0x00, 0x01, 0x02]);
                }
                Some(Misbehave::FrameToNobody) => {
                    let dst = cfg.robots.count + 7;
                    let _ = cmd.push_frame(
                        dst,
                        &crate::RadioMsg::Goto(crate::behaviours::goto::Beacon {
                            x: 0.0,
                            y: 0.0,
                            theta: 0.0,
                        }),
                    );
                    cmd.outbox[..cmd.outbox_len as usize]
                        .iter_mut()
                        .for_each(|f| f.dst = dst);
                }
                Some(Misbehave::GarbageNotes) => {
                    cmd.report_len = 4;
                    cmd.report[..4].copy_from_slice(&[0xff, 0xff, 0xff, 0xff]);
                }
                Some(Misbehave::Panic) if obs_tick == 20 => {
                    panic!("test hook: robot {id} panics at tick 20")
                }
                Some(Misbehave::Double) => {
                    ports.publisher.send_copy(cmd)?;
                }
                Some(Misbehave::Slow) => std::thread::sleep(Duration::from_millis(250)),
                Some(Misbehave::Panic) | None => {}
            }
            ports.send(cmd)?;
        }
        match ports.listener.timed_wait(|_| {}, IDLE_CHECK) {
            Ok(_) => {}
            // A signal interrupted the wait: SIGTERM/SIGINT (checked below) or the SIGCONT
            // ending a freeze, after which Linux fails the wait with EINTR.
            Err(ListenerWaitError::InterruptSignal) => {}
            Err(e) => return Err(e.into()),
        }
        if ipc::termination_requested(&node) {
            return Ok(Exit::Terminated);
        }
    }
}
