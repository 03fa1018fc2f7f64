//! The hidden `swarm-bench child --spec <json>` subcommand: one process of a benchmark.
//!
//! A child writes JSON lines on stdout ([`ChildMsg`]): `ready` once its ports exist (and the
//! parent may start its peer), `progress` mid-measurement, `result` at the end. Errors go to
//! stderr and a non-zero exit. Every wait in a child has a watchdog ([`super::PEER_TIMEOUT`]),
//! so a child whose peer vanished ends by itself; the parent-death signal ends it if the
//! parent dies.

use std::io::Write;

use serde::{Deserialize, Serialize};

use swarmrt_orchestrator::error::{SwarmError, SwarmResult};

/// Which transport a ping/pong pair uses.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Transport {
    /// iceoryx2 pub/sub, the receiver spins on `receive()`.
    Iox2Poll,
    /// iceoryx2 pub/sub + event service, the receiver sleeps in `Listener::timed_wait` (what
    /// the runtime's shells do).
    Iox2Listener,
    /// iceoryx2 pub/sub + event service, the receiver sleeps in a `WaitSet`.
    Iox2Waitset,
    /// Unix domain stream socket.
    Uds,
    /// TCP over loopback with TCP_NODELAY.
    Tcp,
    /// Crossbeam channel between two threads of one process (the lower bound).
    Crossbeam,
}

impl Transport {
    /// Every transport, in table order.
    pub const ALL: [Transport; 6] = [
        Transport::Iox2Poll,
        Transport::Iox2Listener,
        Transport::Iox2Waitset,
        Transport::Uds,
        Transport::Tcp,
        Transport::Crossbeam,
    ];

    /// The name used in tables and JSON.
    pub fn name(self) -> &'static str {
        match self {
            Transport::Iox2Poll => "iox2-poll",
            Transport::Iox2Listener => "iox2-listener",
            Transport::Iox2Waitset => "iox2-waitset",
            Transport::Uds => "unix-socket",
            Transport::Tcp => "tcp-loopback",
            Transport::Crossbeam => "crossbeam-inproc",
        }
    }
}

/// How the loss demonstration configures and drives its pub/sub pair.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum LossMode {
    /// iceoryx2 defaults (subscriber buffer 2, safe overflow on), free-running publisher.
    Defaults,
    /// The runtime's observation service (`swarmrt_ipc`), free-running publisher.
    RuntimeFree,
    /// The runtime's services driven in lock-step, as the world and robots drive them.
    RuntimeLockStep,
    /// Safe overflow off and a publisher that retries until delivered, free-running.
    NoOverflow,
}

impl LossMode {
    /// Every mode, in table order.
    pub const ALL: [LossMode; 4] = [
        LossMode::Defaults,
        LossMode::RuntimeFree,
        LossMode::RuntimeLockStep,
        LossMode::NoOverflow,
    ];

    /// The id used in tables and JSON.
    pub fn id(self) -> &'static str {
        match self {
            LossMode::Defaults => "iceoryx2-defaults",
            LossMode::RuntimeFree => "runtime-services-free-running",
            LossMode::RuntimeLockStep => "runtime-lock-step",
            LossMode::NoOverflow => "no-overflow-retry",
        }
    }

    /// What the mode configures, for the table.
    pub fn settings(self) -> &'static str {
        match self {
            LossMode::Defaults => "buffer 2, safe overflow on; publisher paced, never waits",
            LossMode::RuntimeFree => {
                "swarmrt_ipc observation service (buffer 1, safe overflow on); publisher paced, never waits"
            }
            LossMode::RuntimeLockStep => {
                "swarmrt_ipc services; one sample in flight, next after the reply (the runtime)"
            }
            LossMode::NoOverflow => {
                "buffer 2, safe overflow off, publisher RetryUntilDelivered: paced, but blocks in send while the queue is full"
            }
        }
    }
}

/// What a benchmark child process does.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "role", rename_all = "kebab-case")]
pub enum ChildSpec {
    /// Echo side of a round-trip pair; reports `ready` (with a socket address, if any).
    Pong {
        /// Run id naming the iceoryx2 resources (and the socket's directory).
        run_id: String,
        /// The transport.
        transport: Transport,
        /// Message size in bytes.
        payload: usize,
    },
    /// Measuring side of a pair: round trips, then one-way throughput; reports `result`.
    Ping {
        /// Run id.
        run_id: String,
        /// The transport.
        transport: Transport,
        /// Message size in bytes.
        payload: usize,
        /// Seconds of measurement (half round trips, half throughput).
        secs: f64,
        /// The pong's socket address.
        addr: Option<String>,
    },
    /// The publisher of the fan-out measurement (creates the services).
    FanoutPub {
        /// Run id.
        run_id: String,
        /// Subscriber processes to wait for.
        subscribers: usize,
        /// Seconds of measurement.
        secs: f64,
    },
    /// One subscriber of the fan-out measurement.
    FanoutSub {
        /// Run id.
        run_id: String,
        /// Its index.
        index: u32,
    },
    /// The slow subscriber of the loss demonstration (started first).
    LossSub {
        /// Run id.
        run_id: String,
        /// Settings and driving.
        mode: LossMode,
        /// Simulated work per sample, microseconds.
        work_us: u64,
    },
    /// The fast publisher of the loss demonstration.
    LossPub {
        /// Run id.
        run_id: String,
        /// Settings and driving.
        mode: LossMode,
        /// Samples to send.
        count: u64,
        /// Microseconds between sends (free-running modes).
        interval_us: u64,
    },
    /// World side of the message-path comparison (runtime services or raw iceoryx2).
    PathWorld {
        /// Run id.
        run_id: String,
        /// True: `swarmrt_ipc` services and types; false: raw `[u8]` services.
        runtime: bool,
        /// Seconds of measurement.
        secs: f64,
    },
    /// Robot side of the message-path comparison.
    PathRobot {
        /// Run id.
        run_id: String,
        /// As for `PathWorld`.
        runtime: bool,
    },
    /// The floor's world: the runtime's services, no world core.
    FloorWorld {
        /// Run id.
        run_id: String,
        /// Robot processes to wait for.
        robots: usize,
        /// Lock-step ticks to run.
        ticks: u64,
    },
    /// The floor's robot: wakes, answers, nothing else.
    FloorAgent {
        /// Run id.
        run_id: String,
        /// Its id.
        robot: u32,
    },
    /// A peer floor's world (`swarm bench swarm --peers`): the floor's lock-step over
    /// another transport; reports `ready` with its address.
    PeerWorld {
        /// Run id (names the socket's directory and the Zenoh keys).
        run_id: String,
        /// The transport (Unix sockets or Zenoh).
        peer: crate::peers::Peer,
        /// Robot processes to wait for.
        robots: usize,
        /// Lock-step ticks to run.
        ticks: u64,
    },
    /// A peer floor's robot.
    PeerAgent {
        /// Run id.
        run_id: String,
        /// The transport.
        peer: crate::peers::Peer,
        /// Its id.
        robot: u32,
        /// Robots in the run (the world's start-up limit grows with it).
        robots: usize,
        /// The world's address (socket path or Zenoh endpoint).
        addr: String,
        /// Kill itself on receiving this tick (the watchdog's test).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        die_at: Option<u64>,
    },
}

/// A line a child writes on stdout.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "msg", rename_all = "kebab-case")]
pub enum ChildMsg {
    /// Ports exist; the peer may start. `addr` is a socket address when there is one.
    Ready {
        /// Socket address (TCP `host:port` or a Unix socket path).
        addr: Option<String>,
    },
    /// Mid-measurement (the parent samples memory now).
    Progress,
    /// The measurement's numbers.
    Result {
        /// Role-specific JSON.
        value: serde_json::Value,
    },
    /// The measurement failed (the child exits with an error next).
    Failed {
        /// What went wrong.
        error: String,
    },
}

/// Writes one message line on stdout.
pub fn say(msg: &ChildMsg) -> anyhow::Result<()> {
    let mut out = std::io::stdout().lock();
    let mut line = serde_json::to_string(msg)?;
    line.push('\n');
    out.write_all(line.as_bytes())?;
    out.flush()?;
    Ok(())
}

fn run_of(run_id: &str) -> SwarmResult<swarmrt_protocol::services::RunServices> {
    if !swarmrt_protocol::services::valid_run_id(run_id) {
        return Err(SwarmError::User(format!("invalid run id {run_id:?}")));
    }
    Ok(swarmrt_protocol::services::RunServices::new(run_id))
}

/// Runs the child described by `spec`, a [`ChildSpec`] as JSON (its `--spec`).
pub fn main(spec: &str) -> SwarmResult<()> {
    let spec: ChildSpec =
        serde_json::from_str(spec).map_err(|e| SwarmError::User(format!("bad --spec: {e}")))?;
    let r = match &spec {
        ChildSpec::Pong {
            run_id,
            transport,
            payload,
        } => super::transports::pong(&run_of(run_id)?, *transport, *payload),
        ChildSpec::Ping {
            run_id,
            transport,
            payload,
            secs,
            addr,
        } => super::transports::ping(
            &run_of(run_id)?,
            *transport,
            *payload,
            *secs,
            addr.as_deref(),
        ),
        ChildSpec::FanoutPub {
            run_id,
            subscribers,
            secs,
        } => super::fanout::publisher(&run_of(run_id)?, *subscribers, *secs),
        ChildSpec::FanoutSub { run_id, index } => {
            super::fanout::subscriber(&run_of(run_id)?, *index)
        }
        ChildSpec::LossSub {
            run_id,
            mode,
            work_us,
        } => super::loss::subscriber(&run_of(run_id)?, *mode, *work_us),
        ChildSpec::LossPub {
            run_id,
            mode,
            count,
            interval_us,
        } => super::loss::publisher(&run_of(run_id)?, *mode, *count, *interval_us),
        ChildSpec::PathWorld {
            run_id,
            runtime,
            secs,
        } => super::transports::path_world(&run_of(run_id)?, *runtime, *secs),
        ChildSpec::PathRobot { run_id, runtime } => {
            super::transports::path_robot(&run_of(run_id)?, *runtime)
        }
        ChildSpec::FloorWorld {
            run_id,
            robots,
            ticks,
        } => super::floor::world(&run_of(run_id)?, *robots, *ticks),
        ChildSpec::FloorAgent { run_id, robot } => super::floor::agent(&run_of(run_id)?, *robot),
        ChildSpec::PeerWorld {
            run_id,
            peer,
            robots,
            ticks,
        } => {
            run_of(run_id)?;
            crate::peers::world(run_id, *peer, *robots, *ticks)
        }
        ChildSpec::PeerAgent {
            run_id,
            peer,
            robot,
            robots,
            addr,
            die_at,
        } => {
            run_of(run_id)?;
            crate::peers::agent(run_id, *peer, *robot, *robots, addr, *die_at)
        }
    };
    r.map_err(SwarmError::Internal)
}
