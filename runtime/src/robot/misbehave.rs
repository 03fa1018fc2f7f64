//! Test hooks: one robot corrupts its commands on purpose so the tests can check the world's
//! input checks (`tests/tests/e2e/bad_robots.rs`). Compiled only with the `misbehave` feature.

use std::time::Duration;

use swarmrt_ipc::{IpcError, RobotPorts};
use swarmrt_protocol::{Command, PROTOCOL_VERSION};
use swarmrt_scenario::Config;

/// Environment variable that makes one robot send malformed commands, for tests of the
/// world's input checks: `<robot>:<mode>` with mode `nan` (NaN speed), `inf` (infinite turn
/// rate), `fast` (a speed far past the limit), `wrong-tick`, `wrong-version`, `impersonate`
/// (claims another robot's id), `double` (answers every tick twice), `stale` (sends a copy
/// naming the previous tick before each answer), `bad-frame` (an outbox
/// length past the maximum), `oversized-frame` (a frame length past the payload size),
/// `garbage-frame` (a payload that is no message), `frame-to-nobody` (a unicast to an unknown
/// robot), `garbage-notes` (a report that does not decode), `panic` (panics at tick 20) or
/// `slow` (thinks 250 ms per tick, for `--realtime` runs).
pub const MISBEHAVE_ENV: &str = "SWARMRT_TEST_MISBEHAVE";

/// How a misbehaving robot corrupts its commands.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Misbehave {
    Nan,
    Inf,
    Fast,
    WrongTick,
    WrongVersion,
    Impersonate,
    Double,
    Stale,
    BadFrame,
    OversizedFrame,
    GarbageFrame,
    FrameToNobody,
    GarbageNotes,
    Panic,
    Slow,
}

impl Misbehave {
    /// The hook [`MISBEHAVE_ENV`] selects for robot `id`, if any.
    pub(super) fn from_env(id: u32) -> Option<Misbehave> {
        let spec = std::env::var(MISBEHAVE_ENV).ok()?;
        let (robot, mode) = spec.split_once(':')?;
        if robot.parse::<u32>().ok()? != id {
            return None;
        }
        let m = match mode {
            "nan" => Misbehave::Nan,
            "inf" => Misbehave::Inf,
            "fast" => Misbehave::Fast,
            "wrong-tick" => Misbehave::WrongTick,
            "wrong-version" => Misbehave::WrongVersion,
            "impersonate" => Misbehave::Impersonate,
            "double" => Misbehave::Double,
            "stale" => Misbehave::Stale,
            "bad-frame" => Misbehave::BadFrame,
            "oversized-frame" => Misbehave::OversizedFrame,
            "garbage-frame" => Misbehave::GarbageFrame,
            "frame-to-nobody" => Misbehave::FrameToNobody,
            "garbage-notes" => Misbehave::GarbageNotes,
            "panic" => Misbehave::Panic,
            "slow" => Misbehave::Slow,
            _ => return None,
        };
        tracing::warn!(?m, "test hook: this robot sends malformed commands");
        Some(m)
    }

    /// `cmd`, robot `id`'s answer, corrupted before it is sent (`double` sends an extra copy
    /// first, `slow` sleeps, `panic` panics at tick 20).
    pub(super) fn corrupted(
        self,
        mut cmd: Command,
        id: u32,
        cfg: &Config,
        ports: &RobotPorts,
    ) -> Result<Command, IpcError> {
        let tick = cmd.tick;
        match self {
            Misbehave::Nan => cmd.v = f64::NAN,
            Misbehave::Inf => cmd.omega = f64::INFINITY,
            Misbehave::Fast => cmd.v = 1e6,
            Misbehave::WrongTick => cmd.tick += 1,
            Misbehave::WrongVersion => cmd.version = PROTOCOL_VERSION + 1,
            Misbehave::Impersonate => cmd.robot = (id + 1) % cfg.robots.count,
            Misbehave::BadFrame => cmd.outbox_len = u16::MAX,
            Misbehave::OversizedFrame => {
                cmd.outbox_len = 1;
                cmd.outbox[0].len = u16::MAX;
            }
            Misbehave::GarbageFrame => {
                cmd.outbox_len = 1;
                cmd.outbox[0].dst = swarmrt_protocol::BROADCAST;
                cmd.outbox[0].len = 3;
                // The goto tag and a beacon cut short: neither a message nor opaque.
                cmd.outbox[0].payload[..3].copy_from_slice(&[0x00, 0x01, 0x02]);
            }
            Misbehave::FrameToNobody => {
                let dst = cfg.robots.count + 7;
                let _ = cmd.push_frame(
                    dst,
                    &swarmrt_agent::RadioMsg::Goto(swarmrt_agent::behaviours::goto::Beacon {
                        x: 0.0,
                        y: 0.0,
                        theta: 0.0,
                    }),
                );
                cmd.outbox[..cmd.outbox_len as usize]
                    .iter_mut()
                    .for_each(|f| f.dst = dst);
            }
            Misbehave::GarbageNotes => {
                cmd.report_len = 4;
                cmd.report[..4].copy_from_slice(&[0xff, 0xff, 0xff, 0xff]);
            }
            Misbehave::Panic if tick == 20 => {
                panic!("test hook: robot {id} panics at tick 20")
            }
            Misbehave::Double => {
                ports.publisher.send_copy(cmd)?;
            }
            Misbehave::Stale if tick > 0 => {
                ports.publisher.send_copy(Command {
                    tick: tick - 1,
                    ..cmd
                })?;
            }
            Misbehave::Stale => {}
            Misbehave::Slow => std::thread::sleep(Duration::from_millis(250)),
            Misbehave::Panic => {}
        }
        Ok(cmd)
    }
}
