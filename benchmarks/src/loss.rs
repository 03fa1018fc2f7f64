//! Loss accounting: a fast publisher, a slower subscriber, sequence numbers on every sample;
//! the publisher counts what it sent, the subscriber what it received.
//!
//! The subscriber is started first and creates the services. iceoryx2 connects a
//! subscriber to a publisher created after it only when the subscriber next calls
//! `receive()`; until then a full queue skips the subscriber even with `RetryUntilDelivered`,
//! and the samples of a publisher that exits before the subscriber connected are gone. So the
//! publisher first notifies without data, the subscriber calls `receive()` (connecting) and
//! answers on a side event, and only then does the publisher send. Its last sample is an end
//! marker, which safe overflow never drops (overflow drops the oldest queued sample); the
//! publisher stays until the subscriber says it has it.

use std::time::{Duration, Instant};

use anyhow::bail;
use iceoryx2::port::listener::Listener;
use iceoryx2::port::notifier::Notifier;
use iceoryx2::port::publisher::Publisher;
use iceoryx2::port::subscriber::Subscriber;
use iceoryx2::prelude::*;
use serde::{Deserialize, Serialize};
use swarmrt_ipc as proto_ipc;
use swarmrt_protocol::services::RunServices;
use swarmrt_protocol::{Command, CommandKind, Observation, ObservationHeader, PROTOCOL_VERSION};

use super::RobotPorts;
use super::child::{ChildMsg, LossMode, say};
use super::transports::{idle_wait, wait_for};
use super::{PEER_TIMEOUT, Svc, bench_node, iox, service_name, spin_for};

/// Side-event id: the subscriber has called `receive()` since the publisher appeared.
const CONNECTED: usize = 1;
/// Side-event id: the subscriber has the end marker.
const DONE: usize = 2;

/// The event service the subscriber answers on (handshake and end).
fn side_event(
    node: &Node<Svc>,
    run: &RunServices,
) -> anyhow::Result<iceoryx2::service::port_factory::event::PortFactory<Svc>> {
    iox(
        node.service_builder(&service_name(run, "loss/side")?)
            .event()
            .open_or_create(),
        "side event",
    )
}

/// Waits on the side event until `id` arrives.
fn await_side(listener: &Listener<Svc>, id: usize) -> anyhow::Result<()> {
    let start = Instant::now();
    loop {
        let mut seen = false;
        iox(
            listener.timed_wait(|e| seen |= e.id == EventId::new(id), PEER_TIMEOUT),
            "side wait",
        )?;
        if seen {
            return Ok(());
        }
        if start.elapsed() > PEER_TIMEOUT {
            bail!("the subscriber never sent side event {id}");
        }
    }
}

/// The sample of the plain modes.
#[derive(Debug, Clone, Copy, ZeroCopySend)]
#[type_name("swarmrt::bench::LossMsg")]
#[repr(C)]
pub struct LossMsg {
    /// Sequence number, 0..count.
    pub seq: u64,
    /// Non-zero on the end marker.
    pub end: u64,
}

/// What the subscriber saw.
#[derive(Debug, Clone, Default, Serialize, Deserialize)]
pub struct SubResult {
    /// Samples received (end marker excluded).
    pub received: u64,
    /// Sequence numbers skipped between consecutive received samples.
    pub gaps: u64,
    /// Highest sequence number received.
    pub highest: Option<u64>,
}

/// What the publisher did.
#[derive(Debug, Clone, Default, Serialize, Deserialize)]
pub struct PubResult {
    /// Samples sent (end marker excluded).
    pub sent: u64,
    /// Seconds the publisher took to send them.
    pub secs: f64,
}

fn plain_services(
    node: &Node<Svc>,
    run: &RunServices,
    mode: LossMode,
) -> anyhow::Result<(
    iceoryx2::service::port_factory::publish_subscribe::PortFactory<Svc, LossMsg, ()>,
    iceoryx2::service::port_factory::event::PortFactory<Svc>,
)> {
    let name = service_name(run, "loss")?;
    let mut b = node.service_builder(&name).publish_subscribe::<LossMsg>();
    if mode == LossMode::NoOverflow {
        b = b.enable_safe_overflow(false);
    }
    let svc = iox(b.open_or_create(), "loss service")?;
    let ev = iox(
        node.service_builder(&name).event().open_or_create(),
        "loss event",
    )?;
    Ok((svc, ev))
}

/// Tracks received sequence numbers.
struct Tally(SubResult);

impl Tally {
    fn see(&mut self, seq: u64) {
        let r = &mut self.0;
        let expected = r.highest.map(|h| h + 1).unwrap_or(0);
        r.gaps += seq.saturating_sub(expected);
        r.highest = Some(r.highest.map_or(seq, |h| h.max(seq)));
        r.received += 1;
    }
}

/// The slow subscriber: creates the services, says ready, spends `work_us` on each sample
/// (answering it in lock-step mode) until the end marker, reports.
pub fn subscriber(run: &RunServices, mode: LossMode, work_us: u64) -> anyhow::Result<()> {
    let node = bench_node(run, "bench-loss-sub")?;
    let side = iox(
        side_event(&node, run)?.notifier_builder().create(),
        "side notifier",
    )?;
    let work = Duration::from_micros(work_us);
    let mut tally = Tally(SubResult::default());
    // The first wake is the publisher's announcement (no data): receive() once to connect
    // to it, then tell it so.
    let mut announced = false;
    let connected = |announced: &mut bool| -> anyhow::Result<()> {
        *announced = true;
        iox(
            side.notify_with_custom_event_id(EventId::new(CONNECTED)),
            "side",
        )?;
        Ok(())
    };
    match mode {
        LossMode::Defaults | LossMode::NoOverflow => {
            let (svc, ev) = plain_services(&node, run, mode)?;
            let sub = iox(svc.subscriber_builder().create(), "subscriber")?;
            let listener = iox(ev.listener_builder().create(), "listener")?;
            say(&ChildMsg::Ready { addr: None })?;
            'run: loop {
                while let Some(s) = iox(sub.receive(), "receive")? {
                    let m = *s.payload();
                    drop(s);
                    if m.end != 0 {
                        break 'run;
                    }
                    tally.see(m.seq);
                    spin_for(work);
                }
                idle_wait(&listener)?;
                if !announced && iox(sub.receive(), "receive")?.is_none() {
                    connected(&mut announced)?;
                }
            }
        }
        LossMode::RuntimeFree | LossMode::RuntimeLockStep => {
            let s = proto_ipc::create_services(&node, run, 0..1, 0, 0)
                .map_err(|e| anyhow::anyhow!("{e}"))?;
            let listener = s
                .observations_event
                .listener_builder()
                .create()
                .map_err(|e| anyhow::anyhow!("robot listener: {e}"))?;
            let RobotPorts {
                subscriber: sub,
                publisher,
                notifier,
                wait,
            } = RobotPorts::on(
                &s.observations,
                &s.commands[0],
                &s.commands_event,
                proto_ipc::TickWait::Listener(Box::new(listener)),
            )
            .map_err(|e| anyhow::anyhow!("robot ports: {e}"))?;
            let proto_ipc::TickWait::Listener(listener) = wait else {
                bail!("the loss subscriber has no listener");
            };
            say(&ChildMsg::Ready { addr: None })?;
            'run: loop {
                while let Some(sample) = iox(sub.receive(), "receive")? {
                    let h = *sample.user_header();
                    drop(sample);
                    if h.shutdown != 0 {
                        break 'run;
                    }
                    tally.see(h.tick);
                    spin_for(work);
                    if mode == LossMode::RuntimeLockStep {
                        iox(publisher.send_copy(Command::act(0, h.tick)), "send")?;
                        iox(notifier.notify(), "notify")?;
                    }
                }
                idle_wait(&listener)?;
                if !announced && iox(sub.receive(), "receive")?.is_none() {
                    connected(&mut announced)?;
                }
            }
        }
    }
    say(&ChildMsg::Result {
        value: serde_json::to_value(tally.0)?,
    })?;
    iox(side.notify_with_custom_event_id(EventId::new(DONE)), "side")?;
    Ok(())
}

/// The fast publisher: `count` samples `interval_us` apart (in lock-step mode: each after
/// the previous one's answer), then the end marker; reports.
pub fn publisher(
    run: &RunServices,
    mode: LossMode,
    count: u64,
    interval_us: u64,
) -> anyhow::Result<()> {
    let interval = Duration::from_micros(interval_us);
    let node = bench_node(run, "bench-loss-pub")?;
    let side = iox(
        side_event(&node, run)?.listener_builder().create(),
        "side listener",
    )?;
    let start;
    match mode {
        LossMode::Defaults | LossMode::NoOverflow => {
            let (svc, ev) = plain_services(&node, run, mode)?;
            let mut pb = svc.publisher_builder();
            if mode == LossMode::NoOverflow {
                pb = pb.backpressure_strategy(BackpressureStrategy::RetryUntilDelivered);
            }
            let publisher = iox(pb.create(), "publisher")?;
            let notifier = iox(ev.notifier_builder().create(), "notifier")?;
            iox(notifier.notify(), "announce")?;
            await_side(&side, CONNECTED)?;
            start = Instant::now();
            for seq in 0..count {
                iox(publisher.send_copy(LossMsg { seq, end: 0 }), "send")?;
                iox(notifier.notify(), "notify")?;
                spin_for(interval);
            }
            iox(publisher.send_copy(LossMsg { seq: count, end: 1 }), "send")?;
            iox(notifier.notify(), "notify")?;
        }
        LossMode::RuntimeFree | LossMode::RuntimeLockStep => {
            let s = proto_ipc::open_services(&node, run, 0).map_err(|e| anyhow::anyhow!("{e}"))?;
            // The world's ports as `WorldPorts::open` makes them, on services this side opened.
            let publisher = iox(
                s.observations
                    .publisher_builder()
                    .initial_max_slice_len(1)
                    .override_sample_preallocation(|_| proto_ipc::OBSERVATION_SAMPLES)
                    .create(),
                "publisher",
            )?;
            let notifier = iox(s.observations_event.notifier_builder().create(), "notifier")?;
            let commands = iox(s.commands.subscriber_builder().create(), "subscriber")?;
            let listener = iox(s.commands_event.listener_builder().create(), "listener")?;
            iox(notifier.notify(), "announce")?;
            await_side(&side, CONNECTED)?;
            start = Instant::now();
            for seq in 0..count {
                send_observation(&publisher, &notifier, seq, false)?;
                if mode == LossMode::RuntimeLockStep {
                    await_answer(&commands, &listener, seq)?;
                } else {
                    spin_for(interval);
                }
            }
            send_observation(&publisher, &notifier, count, true)?;
        }
    }
    let secs = start.elapsed().as_secs_f64();
    // Stay until the subscriber has the end marker: a publisher's queued samples vanish
    // with it if the subscriber has not connected yet.
    await_side(&side, DONE)?;
    let result = PubResult { sent: count, secs };
    say(&ChildMsg::Result {
        value: serde_json::to_value(result)?,
    })
}

fn send_observation(
    publisher: &Publisher<Svc, [Observation], ObservationHeader>,
    notifier: &Notifier<Svc>,
    tick: u64,
    shutdown: bool,
) -> anyhow::Result<()> {
    let obs = [Observation::empty(0, tick)];
    let sample = iox(publisher.loan_slice_uninit(1), "loan")?;
    let mut sample = sample.write_from_slice(&obs);
    *sample.user_header_mut() = ObservationHeader {
        version: PROTOCOL_VERSION,
        shutdown: shutdown as u32,
        tick,
    };
    iox(sample.send(), "send")?;
    iox(notifier.notify(), "notify")?;
    Ok(())
}

fn await_answer(
    commands: &Subscriber<Svc, Command, ()>,
    listener: &Listener<Svc>,
    tick: u64,
) -> anyhow::Result<()> {
    wait_for(listener, || {
        let mut got = false;
        while let Some(c) = iox(commands.receive(), "receive")? {
            let c = *c.payload();
            if CommandKind::from_u32(c.kind) != Some(CommandKind::Act) {
                continue;
            }
            if c.tick != tick {
                bail!("answer for tick {} while waiting for {tick}", c.tick);
            }
            got = true;
        }
        Ok(got)
    })
}
