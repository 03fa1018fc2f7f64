//! Fan-out: one publisher process, K subscriber processes, the runtime's topology (one
//! pub/sub service + one event to wake all; one shared ack service + event back).
//!
//! Per sample the publisher stamps CLOCK_MONOTONIC, sends, notifies; each subscriber stamps
//! the moment it holds the sample and acks with that stamp. "Last receive" is the latest
//! subscriber stamp minus the send stamp (one way, the clock is shared by all processes of
//! the machine); "all acked" is when the publisher has drained the K-th ack (a round trip).

use std::time::{Duration, Instant};

use anyhow::bail;
use iceoryx2::prelude::*;
use serde::{Deserialize, Serialize};
use swarmrt_protocol::services::RunServices;

use super::child::{ChildMsg, say};
use super::stats::{Summary, summarize};
use super::transports::idle_wait;
use super::{PEER_TIMEOUT, bench_node, iox, monotonic_ns, service_name};

/// The published sample: 64 bytes.
#[derive(Debug, Clone, Copy, ZeroCopySend)]
#[type_name("swarmrt::bench::FanoutSample")]
#[repr(C)]
pub struct FanoutSample {
    /// Sequence number.
    pub seq: u64,
    /// CLOCK_MONOTONIC at send, ns.
    pub sent_ns: u64,
    /// Non-zero: subscribers exit.
    pub shutdown: u64,
    /// Padding to 64 bytes.
    pub pad: [u64; 5],
}

/// A subscriber's acknowledgement (seq `u64::MAX` is its hello).
#[derive(Debug, Clone, Copy, ZeroCopySend)]
#[type_name("swarmrt::bench::FanoutAck")]
#[repr(C)]
pub struct FanoutAck {
    /// Subscriber index.
    pub index: u32,
    /// Padding.
    pub pad: u32,
    /// The acknowledged sequence number.
    pub seq: u64,
    /// CLOCK_MONOTONIC when the subscriber held the sample, ns.
    pub recv_ns: u64,
}

const HELLO: u64 = u64::MAX;
/// Fewest samples per fan-out size, however short `--secs` is.
const MIN_SAMPLES: usize = 20;
/// Most samples per fan-out size.
const MAX_SAMPLES: usize = 20_000;

/// What the publisher measured.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct FanoutResult {
    /// Subscriber processes.
    pub subscribers: usize,
    /// Milliseconds from the publisher's ready to the last subscriber's hello (includes
    /// spawning the subscriber processes).
    pub startup_ms: f64,
    /// Latest subscriber receive minus send, ns.
    pub last_receive_ns: Summary,
    /// Send until the K-th ack was drained, ns.
    pub all_acked_ns: Summary,
    /// Open file descriptors of the publisher process during the measurement.
    pub publisher_fds: usize,
}

fn data_name(run: &RunServices) -> anyhow::Result<ServiceName> {
    service_name(run, "fanout/data")
}

fn ack_name(run: &RunServices) -> anyhow::Result<ServiceName> {
    service_name(run, "fanout/ack")
}

/// Open descriptors of this process.
pub fn own_fds() -> usize {
    std::fs::read_dir("/proc/self/fd")
        .map(|d| d.count())
        .unwrap_or(0)
}

/// The publisher child: creates the services sized for `k` subscribers, waits for their
/// hellos, measures for `secs`, tells them to exit, reports.
pub fn publisher(run: &RunServices, k: usize, secs: f64) -> anyhow::Result<()> {
    if let Err(e) = swarmrt_ipc::raise_fd_limit() {
        tracing::warn!("cannot raise the open-file limit: {e}");
    }
    let node = bench_node(run, "bench-fanout-pub")?;
    let n = k + 2;
    let data = iox(
        node.service_builder(&data_name(run)?)
            .publish_subscribe::<FanoutSample>()
            .max_publishers(1)
            .max_subscribers(n)
            .max_nodes(n)
            .subscriber_max_buffer_size(2)
            .subscriber_max_borrowed_samples(1)
            .history_size(0)
            .create(),
        "data service",
    )?;
    let data_ev = iox(
        node.service_builder(&data_name(run)?)
            .event()
            .max_notifiers(2)
            .max_listeners(n)
            .max_nodes(n)
            .create(),
        "data event",
    )?;
    let ack = iox(
        node.service_builder(&ack_name(run)?)
            .publish_subscribe::<FanoutAck>()
            .max_publishers(n)
            .max_subscribers(1)
            .max_nodes(n)
            .subscriber_max_buffer_size(2)
            .subscriber_max_borrowed_samples(1)
            .history_size(0)
            .create(),
        "ack service",
    )?;
    let ack_ev = iox(
        node.service_builder(&ack_name(run)?)
            .event()
            .max_notifiers(n)
            .max_listeners(2)
            .max_nodes(n)
            .create(),
        "ack event",
    )?;
    let publisher = iox(data.publisher_builder().create(), "publisher")?;
    let notifier = iox(data_ev.notifier_builder().create(), "notifier")?;
    let acks = iox(ack.subscriber_builder().create(), "ack subscriber")?;
    let listener = iox(ack_ev.listener_builder().create(), "ack listener")?;
    say(&ChildMsg::Ready { addr: None })?;

    // Every subscriber says hello once its ports exist.
    let ready_at = Instant::now();
    let startup_limit = PEER_TIMEOUT + Duration::from_millis(100) * k as u32;
    let mut hellos = vec![false; k];
    let mut missing = k;
    while missing > 0 {
        while let Some(a) = iox(acks.receive(), "receive")? {
            let a = *a.payload();
            if a.seq == HELLO
                && let Some(h) = hellos.get_mut(a.index as usize)
                && !*h
            {
                *h = true;
                missing -= 1;
            }
        }
        if missing == 0 {
            break;
        }
        if ready_at.elapsed() > startup_limit {
            bail!("{missing} of {k} subscribers never said hello");
        }
        iox(
            listener.timed_wait(|_| {}, Duration::from_millis(500)),
            "wait",
        )?;
    }
    let startup_ms = ready_at.elapsed().as_secs_f64() * 1e3;
    say(&ChildMsg::Progress)?;
    let publisher_fds = own_fds();

    let budget = Duration::from_secs_f64(secs.max(0.01));
    let mut last_receive = Vec::new();
    let mut all_acked = Vec::new();
    let mut got = vec![u64::MAX; k];
    let start = Instant::now();
    let mut seq = 0u64;
    while (start.elapsed() < budget || last_receive.len() < MIN_SAMPLES)
        && last_receive.len() < MAX_SAMPLES
    {
        let sent_ns = monotonic_ns();
        iox(
            publisher.send_copy(FanoutSample {
                seq,
                sent_ns,
                shutdown: 0,
                pad: [0; 5],
            }),
            "send",
        )?;
        iox(notifier.notify(), "notify")?;
        let mut pending = k;
        let mut latest = sent_ns;
        let waited_from = Instant::now();
        loop {
            while let Some(a) = iox(acks.receive(), "receive")? {
                let a = *a.payload();
                if a.seq == seq
                    && let Some(g) = got.get_mut(a.index as usize)
                    && *g != seq
                {
                    *g = seq;
                    pending -= 1;
                    latest = latest.max(a.recv_ns);
                }
            }
            if pending == 0 {
                break;
            }
            let waited = waited_from.elapsed();
            if waited > PEER_TIMEOUT {
                bail!("{pending} of {k} subscribers did not ack sample {seq}");
            }
            iox(listener.timed_wait(|_| {}, PEER_TIMEOUT - waited), "wait")?;
        }
        all_acked.push(monotonic_ns().saturating_sub(sent_ns));
        last_receive.push(latest.saturating_sub(sent_ns));
        seq += 1;
    }
    iox(
        publisher.send_copy(FanoutSample {
            seq,
            sent_ns: 0,
            shutdown: 1,
            pad: [0; 5],
        }),
        "send",
    )?;
    iox(notifier.notify(), "notify")?;
    let result = FanoutResult {
        subscribers: k,
        startup_ms,
        last_receive_ns: summarize(&mut last_receive),
        all_acked_ns: summarize(&mut all_acked),
        publisher_fds,
    };
    say(&ChildMsg::Result {
        value: serde_json::to_value(result)?,
    })
}

/// A subscriber child: hello, then ack every sample with its receive stamp until shutdown.
pub fn subscriber(run: &RunServices, index: u32) -> anyhow::Result<()> {
    let node = bench_node(run, &format!("bench-fanout-sub-{index}"))?;
    let data = iox(
        node.service_builder(&data_name(run)?)
            .publish_subscribe::<FanoutSample>()
            .open(),
        "data service",
    )?;
    let data_ev = iox(
        node.service_builder(&data_name(run)?).event().open(),
        "data event",
    )?;
    let ack = iox(
        node.service_builder(&ack_name(run)?)
            .publish_subscribe::<FanoutAck>()
            .open(),
        "ack service",
    )?;
    let ack_ev = iox(
        node.service_builder(&ack_name(run)?).event().open(),
        "ack event",
    )?;
    let subscriber = iox(data.subscriber_builder().create(), "subscriber")?;
    let listener = iox(data_ev.listener_builder().create(), "listener")?;
    let publisher = iox(ack.publisher_builder().create(), "ack publisher")?;
    let notifier = iox(ack_ev.notifier_builder().create(), "ack notifier")?;
    let ack_of = |seq: u64, recv_ns: u64| FanoutAck {
        index,
        pad: 0,
        seq,
        recv_ns,
    };
    iox(publisher.send_copy(ack_of(HELLO, 0)), "hello")?;
    iox(notifier.notify(), "notify")?;
    loop {
        while let Some(s) = iox(subscriber.receive(), "receive")? {
            let recv_ns = monotonic_ns();
            let s = *s.payload();
            if s.shutdown != 0 {
                return Ok(());
            }
            iox(publisher.send_copy(ack_of(s.seq, recv_ns)), "ack")?;
            iox(notifier.notify(), "notify")?;
        }
        idle_wait(&listener)?;
    }
}
