//! The floor: the runtime's lock-step loop with nothing in it. The same services
//! (`swarmrt_ipc::create_services`: one observation slice publisher + one event to wake all
//! robots, one shared command service + event back), the same message types and sizes, the
//! same processes; but the world publishes a prepared slice instead of computing one, and a
//! robot answers `Command::act` at once instead of thinking. What the runtime costs beyond
//! this is the world and robot cores and the shells' bookkeeping.
//!
//! The floor wakes its robots as the runtime did before the bell (issue 34): each floor robot
//! sleeps in its own listener of the observation event, so a tick costs one notification
//! (a datagram and a wake-up call) per robot. The runtime now rings the run's bell once.

use std::time::{Duration, Instant};

use anyhow::bail;
use serde::{Deserialize, Serialize};
use swarmrt_ipc as proto_ipc;
use swarmrt_protocol::services::RunServices;
use swarmrt_protocol::{Command, CommandKind, Observation, ObservationHeader, PROTOCOL_VERSION};

use super::child::{ChildMsg, say};
use super::fanout::own_fds;
use super::stats::{Summary, summarize};
use super::transports::idle_wait;
use super::{PEER_TIMEOUT, bench_node, iox};
use super::{WorldPorts, listening_robot_ports, world_ports};

/// The tick after which memory is read: every observation sample has been written once.
pub const SAMPLE_TICK: u64 = proto_ipc::OBSERVATION_SAMPLES as u64 + 1;

/// What the floor world measured.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct FloorResult {
    /// Robot processes.
    pub robots: usize,
    /// Ticks run.
    pub ticks: u64,
    /// Milliseconds from services created to the last hello (spawning the robots included).
    pub startup_ms: f64,
    /// Seconds of ticking (the sum of the tick durations, as the runtime's `timing.seconds`).
    pub secs: f64,
    /// Whole tick (publish + wait for every answer), ns.
    pub tick_ns: Summary,
    /// Mean ns spent loaning, writing, sending and notifying.
    pub publish_ns_mean: f64,
    /// Mean ns from the notify until the last answer was drained.
    pub wait_ns_mean: f64,
    /// Open descriptors of the world process mid-run.
    pub world_fds: usize,
}

/// What a floor world measures while it ticks, the iceoryx2 floor and the peer floors alike:
/// each tick's publish and wait, and one pause between two ticks for the parent's memory and
/// CPU reading (at [`SAMPLE_TICK`], or the last tick of a shorter run).
pub struct FloorClock {
    ticks: u64,
    tick_ns: Vec<u64>,
    publish_sum: u128,
    wait_sum: u128,
    world_fds: Option<usize>,
}

impl FloorClock {
    /// A clock for a run of `ticks` ticks.
    pub fn new(ticks: u64) -> FloorClock {
        FloorClock {
            ticks,
            tick_ns: Vec::with_capacity(ticks as usize),
            publish_sum: 0,
            wait_sum: 0,
            world_fds: None,
        }
    }

    /// Tick `tick` started at `t0`, had handed every robot its slot at `t1` and had every
    /// answer at `t2`. Pauses for the reading once, outside the timing.
    pub fn tick(&mut self, tick: u64, t0: Instant, t1: Instant, t2: Instant) -> anyhow::Result<()> {
        self.tick_ns.push((t2 - t0).as_nanos() as u64);
        self.publish_sum += (t1 - t0).as_nanos();
        self.wait_sum += (t2 - t1).as_nanos();
        if self.world_fds.is_none() && (tick + 1 >= SAMPLE_TICK || tick + 1 == self.ticks) {
            self.world_fds = Some(own_fds());
            say(&ChildMsg::Progress)?;
            let mut line = String::new();
            std::io::stdin().read_line(&mut line)?;
        }
        Ok(())
    }

    /// The world's result, for `robots` robots that were all ready after `startup_ms`.
    pub fn result(mut self, robots: usize, startup_ms: f64) -> FloorResult {
        let count = self.ticks.max(1) as f64;
        FloorResult {
            robots,
            ticks: self.ticks,
            startup_ms,
            secs: self.tick_ns.iter().sum::<u64>() as f64 / 1e9,
            tick_ns: summarize(&mut self.tick_ns),
            publish_ns_mean: self.publish_sum as f64 / count,
            wait_ns_mean: self.wait_sum as f64 / count,
            world_fds: self.world_fds.unwrap_or_else(own_fds),
        }
    }
}

/// The floor world child.
pub fn world(run: &RunServices, n: usize, ticks: u64) -> anyhow::Result<()> {
    if let Err(e) = proto_ipc::raise_fd_limit() {
        tracing::warn!("cannot raise the open-file limit: {e}");
    }
    let node = bench_node(run, &run.world_node_name())?;
    let s = proto_ipc::create_services(&node, run, 0..n as u32, 0, 0)
        .map_err(|e| anyhow::anyhow!("{e}"))?;
    let WorldPorts {
        publisher,
        notifier,
        commands,
        listener,
        ..
    } = world_ports(&s, n)?;
    say(&ChildMsg::Ready { addr: None })?;

    let ready_at = Instant::now();
    let limit = PEER_TIMEOUT + Duration::from_millis(100) * n as u32;
    let mut hello = vec![false; n];
    let mut missing = n;
    while missing > 0 {
        while let Some(c) = iox(commands.receive(), "receive")? {
            let c = *c.payload();
            if CommandKind::from_u32(c.kind) == Some(CommandKind::Hello)
                && let Some(h) = hello.get_mut(c.robot as usize)
                && !*h
            {
                *h = true;
                missing -= 1;
            }
        }
        if missing == 0 {
            break;
        }
        if ready_at.elapsed() > limit {
            bail!("{missing} of {n} floor robots never said hello");
        }
        iox(
            listener.timed_wait(|_| {}, Duration::from_millis(500)),
            "wait",
        )?;
    }
    let startup_ms = ready_at.elapsed().as_secs_f64() * 1e3;

    let obs: Vec<Observation> = (0..n as u32).map(|i| Observation::empty(i, 0)).collect();
    let mut answered = vec![u64::MAX; n];
    let mut clock = FloorClock::new(ticks);
    for tick in 0..ticks {
        let t0 = Instant::now();
        let sample = iox(publisher.loan_slice_uninit(n), "loan")?;
        let mut sample = sample.write_from_slice(&obs);
        *sample.user_header_mut() = ObservationHeader {
            version: PROTOCOL_VERSION,
            shutdown: 0,
            tick,
        };
        iox(sample.send(), "send")?;
        iox(notifier.notify(), "notify")?;
        let t1 = Instant::now();
        let mut pending = n;
        loop {
            while let Some(c) = iox(commands.receive(), "receive")? {
                let c = *c.payload();
                if c.tick == tick
                    && CommandKind::from_u32(c.kind) == Some(CommandKind::Act)
                    && let Some(a) = answered.get_mut(c.robot as usize)
                    && *a != tick
                {
                    *a = tick;
                    pending -= 1;
                }
            }
            if pending == 0 {
                break;
            }
            let waited = t1.elapsed();
            if waited > PEER_TIMEOUT {
                bail!("{pending} floor robots did not answer tick {tick}");
            }
            iox(listener.timed_wait(|_| {}, PEER_TIMEOUT - waited), "wait")?;
        }
        // As the runtime is read at its world's report of this tick: the parent reads
        // memory now, while this world waits (between ticks, outside the timing).
        clock.tick(tick, t0, t1, Instant::now())?;
    }
    let sample = iox(publisher.loan_slice_uninit(0), "loan")?;
    let mut sample = sample.write_from_slice(&[]);
    *sample.user_header_mut() = ObservationHeader {
        version: PROTOCOL_VERSION,
        shutdown: 1,
        tick: ticks,
    };
    iox(sample.send(), "send")?;
    iox(notifier.notify(), "notify")?;
    say(&ChildMsg::Result {
        value: serde_json::to_value(clock.result(n, startup_ms))?,
    })
}

/// The floor robot child: hello, then answer every tick at once until shutdown.
pub fn agent(run: &RunServices, id: u32) -> anyhow::Result<()> {
    let node = bench_node(run, &run.robot_node_name(id))?;
    let ports = listening_robot_ports(&node, run, id)?;
    let proto_ipc::TickWait::Listener(listener) = &ports.wait else {
        bail!("the floor robot has no listener");
    };
    iox(ports.hello(id), "hello")?;
    loop {
        while let Some(sample) = iox(ports.subscriber.receive(), "receive")? {
            let header = *sample.user_header();
            if header.shutdown != 0 {
                return Ok(());
            }
            // Read the own slot, as a robot does.
            let Some(robot) = sample.payload().get(id as usize).map(|o| o.robot) else {
                bail!("observation sample has no slot for robot {id}");
            };
            drop(sample);
            iox(ports.send(Command::act(robot, header.tick)), "send")?;
        }
        idle_wait(listener)?;
    }
}
