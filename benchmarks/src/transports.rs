//! Round trip and one-way throughput over one transport, between two processes (a `ping` and
//! a `pong` child) or two threads (crossbeam); and the runtime's own message path against raw
//! iceoryx2.
//!
//! Every message has the payload size and starts with a 24-byte header (kind, sequence,
//! value). The sender writes all `payload` bytes of each message once (for iceoryx2: into the
//! loaned sample, as the world does with `write_from_slice`); the receiver reads the header in
//! place (iceoryx2) or reads the whole message out of the socket.
//!
//! The ping measures round trips (send, wait for the echo) for half its time, then sends
//! `DATA` messages back to back for the other half, in [`THROUGHPUT_WINDOWS`] windows that
//! each end with `END`, which the pong answers with how many `DATA` it counted: a window's
//! throughput is its messages over the time from its first send to that answer, so nothing
//! still queued is counted as delivered, and the reported throughput is the median window.

use std::io::{Read, Write};
use std::time::{Duration, Instant};

use anyhow::{Context, bail};
use iceoryx2::port::listener::Listener;
use iceoryx2::port::notifier::Notifier;
use iceoryx2::port::publisher::Publisher;
use iceoryx2::port::subscriber::Subscriber;
use iceoryx2::prelude::*;
use serde::{Deserialize, Serialize};
use swarmrt_ipc as proto_ipc;
use swarmrt_protocol::services::RunServices;
use swarmrt_protocol::{Command, Observation, ObservationHeader, PROTOCOL_VERSION};

use super::child::{ChildMsg, Transport, say};
use super::stats::{Summary, median, summarize};
use super::{PEER_TIMEOUT, Svc, bench_node, iox, service_name};
use super::{WorldPorts, robot_ports, world_ports};

/// Bytes of the message header (kind u32, pad, seq u64, value u64).
pub const HEADER: usize = 24;
/// Smallest payload (room for the header, and the smallest size the issue asks for).
pub const MIN_PAYLOAD: usize = 64;

const PING: u32 = 1;
const DATA: u32 = 2;
const END: u32 = 3;
const ACK: u32 = 4;
const STOP: u32 = 5;

/// Most round-trip samples kept (memory bound for very fast transports).
const MAX_RTT_SAMPLES: usize = 2_000_000;
/// Busy-poll: `sched_yield` after this many empty `receive()` calls.
const POLL_YIELD_EVERY: u32 = 256;
/// Subscriber queue of the iceoryx2 pairs (lossless: safe overflow off, sender retries).
const IOX2_BUFFER: usize = 16;
/// Windows of the throughput phase. The rate is their median (as the round trip is a
/// median), so a burst of load from another process that starves the receiver's wake-ups
/// for part of the phase does not become the row's number; the spread stays in the JSON.
pub const THROUGHPUT_WINDOWS: usize = 5;

/// A message header.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Header {
    /// PING, DATA, END, ACK or STOP.
    pub kind: u32,
    /// Sequence number.
    pub seq: u64,
    /// Kind-specific value (ACK: messages counted).
    pub value: u64,
}

fn encode(buf: &mut [u8], h: Header) {
    buf[0..4].copy_from_slice(&h.kind.to_le_bytes());
    buf[4..8].fill(0);
    buf[8..16].copy_from_slice(&h.seq.to_le_bytes());
    buf[16..24].copy_from_slice(&h.value.to_le_bytes());
}

fn decode(b: &[u8]) -> anyhow::Result<Header> {
    if b.len() < HEADER {
        bail!("message of {} bytes has no header", b.len());
    }
    let u32_at = |i: usize| u32::from_le_bytes(b[i..i + 4].try_into().expect("4 bytes"));
    let u64_at = |i: usize| u64::from_le_bytes(b[i..i + 8].try_into().expect("8 bytes"));
    Ok(Header {
        kind: u32_at(0),
        seq: u64_at(8),
        value: u64_at(16),
    })
}

/// One side of a connection: sends whole messages, receives headers.
pub trait Endpoint {
    /// Sends `msg` (all of it).
    fn send(&mut self, msg: &[u8]) -> anyhow::Result<()>;
    /// Blocks (or spins) until the next message; an error after [`PEER_TIMEOUT`].
    fn recv(&mut self) -> anyhow::Result<Header>;
}

/// What the ping measured.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct PingResult {
    /// Round-trip latency in nanoseconds.
    pub rtt_ns: Summary,
    /// Messages sent in the throughput phase.
    pub sent: u64,
    /// Messages the pong counted.
    pub received: u64,
    /// Seconds of the throughput windows (each from its first DATA to the pong's count).
    pub secs: f64,
    /// Median over the windows of received / seconds.
    pub msgs_per_s: f64,
    /// `msgs_per_s` * payload.
    pub bytes_per_s: f64,
    /// Each window's messages per second, in order (their spread shows a disturbed phase).
    #[serde(default)]
    pub window_msgs_per_s: Vec<f64>,
    /// CPU seconds the sending thread used in the throughput phase (0 when not measured).
    #[serde(default)]
    pub cpu_secs: f64,
    /// Times the sending thread was preempted in the throughput phase (0 when not measured): about
    /// one per message means sender and receiver shared a core and woke each other.
    #[serde(default)]
    pub involuntary_switches: i64,
}

/// The calling thread's CPU seconds (user + system) and involuntary context switches.
fn cpu_usage() -> (f64, i64) {
    // SAFETY: an all-zero rusage is valid; getrusage only writes the struct we pass.
    let mut ru: libc::rusage = unsafe { std::mem::zeroed() };
    // SAFETY: as above.
    if unsafe { libc::getrusage(libc::RUSAGE_THREAD, &mut ru) } != 0 {
        return (0.0, 0);
    }
    let secs = |tv: libc::timeval| tv.tv_sec as f64 + tv.tv_usec as f64 * 1e-6;
    (secs(ru.ru_utime) + secs(ru.ru_stime), ru.ru_nivcsw)
}

/// The measuring side, over any endpoint.
pub fn run_ping(ep: &mut dyn Endpoint, payload: usize, secs: f64) -> anyhow::Result<PingResult> {
    let mut buf = vec![0xA5u8; payload];
    let half = Duration::from_secs_f64((secs / 2.0).max(0.01));
    let mut seq = 0u64;
    let round_trip = |ep: &mut dyn Endpoint, buf: &mut [u8], seq: u64| -> anyhow::Result<()> {
        encode(
            buf,
            Header {
                kind: PING,
                seq,
                value: 0,
            },
        );
        ep.send(buf)?;
        let h = ep.recv()?;
        if h.kind != PING || h.seq != seq {
            bail!("echo out of order: sent {seq}, got {h:?}");
        }
        Ok(())
    };
    // Warm-up: page faults, connection set-up, caches; not recorded.
    let warm = Instant::now();
    let warm_budget = half / 10;
    let mut warm_n = 0;
    while warm_n < 20 || (warm.elapsed() < warm_budget && warm_n < 10_000) {
        round_trip(ep, &mut buf, seq)?;
        seq += 1;
        warm_n += 1;
    }
    let mut rtts: Vec<u64> = Vec::with_capacity(1 << 16);
    let start = Instant::now();
    while (start.elapsed() < half || rtts.len() < 10) && rtts.len() < MAX_RTT_SAMPLES {
        let t0 = Instant::now();
        round_trip(ep, &mut buf, seq)?;
        rtts.push(t0.elapsed().as_nanos() as u64);
        seq += 1;
    }

    let window = half / THROUGHPUT_WINDOWS as u32;
    let (mut sent, mut received, mut secs_total) = (0u64, 0u64, 0.0f64);
    let mut rates = Vec::with_capacity(THROUGHPUT_WINDOWS);
    let usage_before = cpu_usage();
    for _ in 0..THROUGHPUT_WINDOWS {
        let start = Instant::now();
        let mut n = 0u64;
        while start.elapsed() < window || n < 10 {
            encode(
                &mut buf,
                Header {
                    kind: DATA,
                    seq,
                    value: 0,
                },
            );
            ep.send(&buf)?;
            n += 1;
            seq += 1;
        }
        encode(
            &mut buf,
            Header {
                kind: END,
                seq,
                value: 0,
            },
        );
        ep.send(&buf)?;
        let h = ep.recv()?;
        let elapsed = start.elapsed().as_secs_f64();
        if h.kind != ACK || h.seq != seq {
            bail!("expected the pong's count for END {seq}, got {h:?}");
        }
        if h.value != n {
            bail!(
                "sent {n} messages in a window but the pong counted {}",
                h.value
            );
        }
        seq += 1;
        sent += n;
        received += h.value;
        secs_total += elapsed;
        rates.push(h.value as f64 / elapsed);
    }
    let usage_after = cpu_usage();
    encode(
        &mut buf,
        Header {
            kind: STOP,
            seq,
            value: 0,
        },
    );
    ep.send(&buf)?;
    let msgs_per_s = median(&rates);
    Ok(PingResult {
        rtt_ns: summarize(&mut rtts),
        sent,
        received,
        secs: secs_total,
        msgs_per_s,
        bytes_per_s: msgs_per_s * payload as f64,
        window_msgs_per_s: rates,
        cpu_secs: usage_after.0 - usage_before.0,
        involuntary_switches: usage_after.1 - usage_before.1,
    })
}

/// The echo side, over any endpoint, until STOP.
pub fn run_pong(ep: &mut dyn Endpoint, payload: usize) -> anyhow::Result<()> {
    let mut buf = vec![0x5Au8; payload];
    let mut counted = 0u64;
    loop {
        let h = ep.recv()?;
        match h.kind {
            PING => {
                encode(&mut buf, h);
                ep.send(&buf)?;
            }
            DATA => counted += 1,
            END => {
                encode(
                    &mut buf,
                    Header {
                        kind: ACK,
                        seq: h.seq,
                        value: counted,
                    },
                );
                ep.send(&buf)?;
                counted = 0;
            }
            STOP => return Ok(()),
            k => bail!("unknown message kind {k}"),
        }
    }
}

// ---------------------------------------------------------------------------------------
// iceoryx2

/// How an iceoryx2 endpoint waits for the next sample.
enum Wake<'a> {
    /// Spin on `receive()`.
    Poll,
    /// Sleep in something that returns when the peer notified (or after the timeout).
    Wait(&'a mut dyn FnMut(Duration) -> anyhow::Result<()>),
}

struct Iox2Endpoint<'a> {
    publisher: &'a Publisher<Svc, [u8], ()>,
    subscriber: &'a Subscriber<Svc, [u8], ()>,
    notifier: Option<&'a Notifier<Svc>>,
    wake: Wake<'a>,
}

impl Endpoint for Iox2Endpoint<'_> {
    fn send(&mut self, msg: &[u8]) -> anyhow::Result<()> {
        let sample = iox(self.publisher.loan_slice_uninit(msg.len()), "loan")?;
        iox(sample.write_from_slice(msg).send(), "send")?;
        if let Some(n) = self.notifier {
            iox(n.notify(), "notify")?;
        }
        Ok(())
    }

    fn recv(&mut self) -> anyhow::Result<Header> {
        let start = Instant::now();
        let mut spins = 0u32;
        loop {
            if let Some(s) = iox(self.subscriber.receive(), "receive")? {
                return decode(s.payload());
            }
            match &mut self.wake {
                Wake::Poll => {
                    spins = spins.wrapping_add(1);
                    if spins.is_multiple_of(POLL_YIELD_EVERY) {
                        // Never sleeps, but lets a descheduled peer run on an
                        // oversubscribed machine instead of spinning out a whole time slice.
                        std::thread::yield_now();
                        if start.elapsed() > PEER_TIMEOUT {
                            bail!("no message within {PEER_TIMEOUT:?}");
                        }
                    }
                    std::hint::spin_loop();
                }
                Wake::Wait(wait) => {
                    let waited = start.elapsed();
                    if waited > PEER_TIMEOUT {
                        bail!("no message within {PEER_TIMEOUT:?}");
                    }
                    wait(PEER_TIMEOUT - waited)?;
                }
            }
        }
    }
}

/// The ports of one side of an iceoryx2 pair.
struct Iox2Side {
    _node: Node<Svc>,
    publisher: Publisher<Svc, [u8], ()>,
    subscriber: Subscriber<Svc, [u8], ()>,
    notifier: Notifier<Svc>,
    listener: Listener<Svc>,
}

fn iox2_side(run: &RunServices, payload: usize, is_pong: bool) -> anyhow::Result<Iox2Side> {
    let node = bench_node(run, if is_pong { "bench-pong" } else { "bench-ping" })?;
    let pubsub = |what: &str| -> anyhow::Result<_> {
        iox(
            node.service_builder(&service_name(run, what)?)
                .publish_subscribe::<[u8]>()
                .max_publishers(1)
                .max_subscribers(1)
                .max_nodes(3)
                .subscriber_max_buffer_size(IOX2_BUFFER)
                .subscriber_max_borrowed_samples(2)
                .history_size(0)
                .enable_safe_overflow(false)
                .open_or_create(),
            "pub/sub service",
        )
    };
    let event = |what: &str| -> anyhow::Result<_> {
        iox(
            node.service_builder(&service_name(run, what)?)
                .event()
                .max_notifiers(1)
                .max_listeners(1)
                .max_nodes(3)
                .open_or_create(),
            "event service",
        )
    };
    let (out, inc) = if is_pong {
        ("pair/rep", "pair/req")
    } else {
        ("pair/req", "pair/rep")
    };
    let out_svc = pubsub(out)?;
    let in_svc = pubsub(inc)?;
    let out_ev = event(out)?;
    let in_ev = event(inc)?;
    let publisher = iox(
        out_svc
            .publisher_builder()
            .initial_max_slice_len(payload)
            .backpressure_strategy(BackpressureStrategy::RetryUntilDelivered)
            .create(),
        "publisher",
    )?;
    let subscriber = iox(in_svc.subscriber_builder().create(), "subscriber")?;
    let notifier = iox(out_ev.notifier_builder().create(), "notifier")?;
    let listener = iox(in_ev.listener_builder().create(), "listener")?;
    Ok(Iox2Side {
        _node: node,
        publisher,
        subscriber,
        notifier,
        listener,
    })
}

/// Runs `f` with an endpoint over `side` that waits as `transport` says.
fn with_iox2_endpoint<T>(
    side: &Iox2Side,
    transport: Transport,
    f: impl FnOnce(&mut dyn Endpoint) -> anyhow::Result<T>,
) -> anyhow::Result<T> {
    match transport {
        Transport::Iox2Poll => f(&mut Iox2Endpoint {
            publisher: &side.publisher,
            subscriber: &side.subscriber,
            notifier: None,
            wake: Wake::Poll,
        }),
        Transport::Iox2Listener => {
            let listener = &side.listener;
            let mut wait = |t: Duration| -> anyhow::Result<()> {
                iox(listener.timed_wait(|_| {}, t), "listener wait")?;
                Ok(())
            };
            f(&mut Iox2Endpoint {
                publisher: &side.publisher,
                subscriber: &side.subscriber,
                notifier: Some(&side.notifier),
                wake: Wake::Wait(&mut wait),
            })
        }
        Transport::Iox2Waitset => {
            let waitset = iox(
                WaitSetBuilder::new()
                    .signal_handling_mode(SignalHandlingMode::Disabled)
                    .create::<Svc>(),
                "waitset",
            )?;
            let listener = &side.listener;
            let subscriber = &side.subscriber;
            let _guard = iox(waitset.attach_notification(listener), "attach")?;
            let mut wait = |t: Duration| -> anyhow::Result<()> {
                // The WaitSet sleeps on the listener's socket only, but iceoryx2's notifier
                // writes to that socket only while the listener's shared state is not
                // "notified" (later notifies just set a bit). A drain that races a notify
                // (state reset, the notify's datagram written, then eaten by the same drain)
                // leaves the state "notified" with an empty socket: from then on no notify
                // reaches the socket and the WaitSet sleeps until its timeout (the 20 s hang).
                // So arm before sleeping: drain until a drain finds nothing (which resets the
                // state, and a drain that raced a notify counts that notify's event), then
                // re-check the queue, as every sample that was notified before is in it.
                loop {
                    let drained = iox(listener.try_wait(|_| {}), "listener drain")?;
                    if iox(subscriber.has_samples(), "has_samples")? {
                        return Ok(());
                    }
                    if drained == 0 {
                        break;
                    }
                }
                iox(
                    waitset.wait_and_process_once_with_timeout(
                        |_| {
                            // Drain the notifications, or the WaitSet wakes at once again.
                            let _ = listener.try_wait(|_| {});
                            CallbackProgression::Continue
                        },
                        t,
                    ),
                    "waitset wait",
                )?;
                Ok(())
            };
            f(&mut Iox2Endpoint {
                publisher: &side.publisher,
                subscriber: &side.subscriber,
                notifier: Some(&side.notifier),
                wake: Wake::Wait(&mut wait),
            })
        }
        _ => bail!("{} is not an iceoryx2 transport", transport.name()),
    }
}

// ---------------------------------------------------------------------------------------
// sockets and channels

struct StreamEndpoint<S: Read + Write> {
    stream: S,
    buf: Vec<u8>,
}

impl<S: Read + Write> Endpoint for StreamEndpoint<S> {
    fn send(&mut self, msg: &[u8]) -> anyhow::Result<()> {
        self.stream.write_all(msg).context("socket write")
    }

    fn recv(&mut self) -> anyhow::Result<Header> {
        self.stream
            .read_exact(&mut self.buf)
            .context("socket read (peer gone or silent)")?;
        decode(&self.buf)
    }
}

/// One side of the in-process crossbeam pair.
pub struct ChannelEndpoint {
    tx: crossbeam_channel::Sender<Vec<u8>>,
    rx: crossbeam_channel::Receiver<Vec<u8>>,
}

impl Endpoint for ChannelEndpoint {
    fn send(&mut self, msg: &[u8]) -> anyhow::Result<()> {
        self.tx
            .send(msg.to_vec())
            .map_err(|_| anyhow::anyhow!("channel closed"))
    }

    fn recv(&mut self) -> anyhow::Result<Header> {
        let m = self
            .rx
            .recv_timeout(PEER_TIMEOUT)
            .map_err(|e| anyhow::anyhow!("channel: {e}"))?;
        decode(&m)
    }
}

/// Ping and pong on two threads of this process over bounded crossbeam channels.
pub fn crossbeam_pair(payload: usize, secs: f64) -> anyhow::Result<PingResult> {
    let (to_pong, pong_rx) = crossbeam_channel::bounded(IOX2_BUFFER);
    let (to_ping, ping_rx) = crossbeam_channel::bounded(IOX2_BUFFER);
    let pong = std::thread::spawn(move || {
        run_pong(
            &mut ChannelEndpoint {
                tx: to_ping,
                rx: pong_rx,
            },
            payload,
        )
    });
    let r = run_ping(
        &mut ChannelEndpoint {
            tx: to_pong,
            rx: ping_rx,
        },
        payload,
        secs,
    );
    let p = pong
        .join()
        .map_err(|_| anyhow::anyhow!("pong thread panicked"))?;
    let r = r?;
    p?;
    Ok(r)
}

fn socket_path(run: &RunServices) -> std::path::PathBuf {
    run.ipc_root().join("bench.sock")
}

// ---------------------------------------------------------------------------------------
// child entry points

/// `pong` child: set up, say ready (with the socket address), echo until STOP.
pub fn pong(run: &RunServices, transport: Transport, payload: usize) -> anyhow::Result<()> {
    check_payload(payload)?;
    match transport {
        Transport::Uds => {
            let path = socket_path(run);
            let listener = std::os::unix::net::UnixListener::bind(&path)
                .with_context(|| format!("bind {}", path.display()))?;
            say(&ChildMsg::Ready {
                addr: Some(path.display().to_string()),
            })?;
            let (stream, _) = listener.accept()?;
            stream.set_read_timeout(Some(PEER_TIMEOUT))?;
            run_pong(
                &mut StreamEndpoint {
                    stream,
                    buf: vec![0; payload],
                },
                payload,
            )
        }
        Transport::Tcp => {
            let listener = std::net::TcpListener::bind("127.0.0.1:0")?;
            say(&ChildMsg::Ready {
                addr: Some(listener.local_addr()?.to_string()),
            })?;
            let (stream, _) = listener.accept()?;
            stream.set_nodelay(true)?;
            stream.set_read_timeout(Some(PEER_TIMEOUT))?;
            run_pong(
                &mut StreamEndpoint {
                    stream,
                    buf: vec![0; payload],
                },
                payload,
            )
        }
        Transport::Crossbeam => bail!("crossbeam runs in-process"),
        _ => {
            let side = iox2_side(run, payload, true)?;
            say(&ChildMsg::Ready { addr: None })?;
            with_iox2_endpoint(&side, transport, |ep| run_pong(ep, payload))
        }
    }
}

/// `ping` child: connect, measure, report.
pub fn ping(
    run: &RunServices,
    transport: Transport,
    payload: usize,
    secs: f64,
    addr: Option<&str>,
) -> anyhow::Result<()> {
    check_payload(payload)?;
    let result = match transport {
        Transport::Uds => {
            let addr = addr.context("no socket path")?;
            let stream = std::os::unix::net::UnixStream::connect(addr)?;
            stream.set_read_timeout(Some(PEER_TIMEOUT))?;
            run_ping(
                &mut StreamEndpoint {
                    stream,
                    buf: vec![0; payload],
                },
                payload,
                secs,
            )?
        }
        Transport::Tcp => {
            let addr = addr.context("no TCP address")?;
            let stream = std::net::TcpStream::connect(addr)?;
            stream.set_nodelay(true)?;
            stream.set_read_timeout(Some(PEER_TIMEOUT))?;
            run_ping(
                &mut StreamEndpoint {
                    stream,
                    buf: vec![0; payload],
                },
                payload,
                secs,
            )?
        }
        Transport::Crossbeam => bail!("crossbeam runs in-process"),
        _ => {
            let side = iox2_side(run, payload, false)?;
            with_iox2_endpoint(&side, transport, |ep| run_ping(ep, payload, secs))?
        }
    };
    say(&ChildMsg::Result {
        value: serde_json::to_value(result)?,
    })
}

fn check_payload(payload: usize) -> anyhow::Result<()> {
    if payload < MIN_PAYLOAD {
        bail!("payload {payload} is below {MIN_PAYLOAD} bytes");
    }
    Ok(())
}

// ---------------------------------------------------------------------------------------
// The runtime's message path against raw iceoryx2 with the same payload sizes.

/// Request bytes of the path comparison: one robot's observation slot.
pub const PATH_REQUEST: usize = std::mem::size_of::<Observation>();
/// Reply bytes: one command.
pub const PATH_REPLY: usize = std::mem::size_of::<Command>();

/// World side: publish one observation (runtime) or `PATH_REQUEST` bytes (raw), notify, sleep
/// until the reply's notification, drain; repeat for `secs`. Reports round trips.
pub fn path_world(run: &RunServices, runtime: bool, secs: f64) -> anyhow::Result<()> {
    let node = bench_node(run, "bench-path-world")?;
    let deadline = Duration::from_secs_f64(secs.max(0.01));
    let mut rtts = Vec::new();
    if runtime {
        let s = proto_ipc::create_services(&node, run, 0..1, 0, 0)
            .map_err(|e| anyhow::anyhow!("{e}"))?;
        let ports = world_ports(&s, 1)?;
        let WorldPorts {
            publisher,
            commands: subscriber,
            listener,
            ..
        } = &ports;
        say(&ChildMsg::Ready { addr: None })?;
        // Hello first, as in the runtime.
        wait_for(listener, || {
            let mut got = false;
            while iox(subscriber.receive(), "receive")?.is_some() {
                got = true;
            }
            Ok(got)
        })?;
        let obs = [Observation::empty(0, 0)];
        let start = Instant::now();
        let mut tick = 0u64;
        while start.elapsed() < deadline || rtts.len() < 10 {
            let t0 = Instant::now();
            let sample = iox(publisher.loan_slice_uninit(1), "loan")?;
            let mut sample = sample.write_from_slice(&obs);
            *sample.user_header_mut() = ObservationHeader {
                version: PROTOCOL_VERSION,
                shutdown: 0,
                tick,
            };
            iox(sample.send(), "send")?;
            iox(ports.wake_robots(), "wake")?;
            wait_for(listener, || {
                let mut got = false;
                while let Some(c) = iox(subscriber.receive(), "receive")? {
                    got |= c.payload().tick == tick;
                }
                Ok(got)
            })?;
            rtts.push(t0.elapsed().as_nanos() as u64);
            tick += 1;
        }
        let sample = iox(publisher.loan_slice_uninit(0), "loan")?;
        let mut sample = sample.write_from_slice(&[]);
        *sample.user_header_mut() = ObservationHeader {
            version: PROTOCOL_VERSION,
            shutdown: 1,
            tick,
        };
        iox(sample.send(), "send")?;
        iox(ports.wake_robots(), "wake")?;
    } else {
        let (publisher, subscriber, notifier, listener) = raw_path_ports(&node, run, true)?;
        say(&ChildMsg::Ready { addr: None })?;
        wait_for(&listener, || {
            let mut got = false;
            while iox(subscriber.receive(), "receive")?.is_some() {
                got = true;
            }
            Ok(got)
        })?;
        let mut req = vec![0u8; PATH_REQUEST];
        let start = Instant::now();
        let mut tick = 0u64;
        while start.elapsed() < deadline || rtts.len() < 10 {
            let t0 = Instant::now();
            encode(
                &mut req,
                Header {
                    kind: PING,
                    seq: tick,
                    value: 0,
                },
            );
            let sample = iox(publisher.loan_slice_uninit(PATH_REQUEST), "loan")?;
            iox(sample.write_from_slice(&req).send(), "send")?;
            iox(notifier.notify(), "notify")?;
            wait_for(&listener, || {
                let mut got = false;
                while let Some(c) = iox(subscriber.receive(), "receive")? {
                    got |= decode(c.payload())?.seq == tick;
                }
                Ok(got)
            })?;
            rtts.push(t0.elapsed().as_nanos() as u64);
            tick += 1;
        }
        encode(
            &mut req,
            Header {
                kind: STOP,
                seq: tick,
                value: 0,
            },
        );
        let sample = iox(publisher.loan_slice_uninit(PATH_REQUEST), "loan")?;
        iox(sample.write_from_slice(&req).send(), "send")?;
        iox(notifier.notify(), "notify")?;
    }
    say(&ChildMsg::Result {
        value: serde_json::json!({ "samples_ns": rtts }),
    })
}

/// Robot side of the path comparison.
pub fn path_robot(run: &RunServices, runtime: bool) -> anyhow::Result<()> {
    let node = bench_node(run, "bench-path-robot")?;
    if runtime {
        let ports = robot_ports(&node, run, 0)?;
        iox(ports.hello(0), "send")?;
        loop {
            let seen = ports.wait.seen();
            while let Some(sample) = iox(ports.subscriber.receive(), "receive")? {
                let header = *sample.user_header();
                if header.shutdown != 0 {
                    return Ok(());
                }
                // Read the own slot, as a robot does.
                let robot = sample.payload().first().map(|o| o.robot).unwrap_or(0);
                drop(sample);
                iox(ports.send(Command::act(robot, header.tick)), "send")?;
            }
            tick_wait(&ports.wait, seen)?;
        }
    } else {
        let (publisher, subscriber, notifier, listener) = raw_path_ports(&node, run, false)?;
        let mut reply = vec![0u8; PATH_REPLY];
        let hello = Header {
            kind: PING,
            seq: u64::MAX,
            value: 0,
        };
        encode(&mut reply, hello);
        let sample = iox(publisher.loan_slice_uninit(PATH_REPLY), "loan")?;
        iox(sample.write_from_slice(&reply).send(), "send")?;
        iox(notifier.notify(), "notify")?;
        loop {
            while let Some(sample) = iox(subscriber.receive(), "receive")? {
                let h = decode(sample.payload())?;
                drop(sample);
                if h.kind == STOP {
                    return Ok(());
                }
                encode(&mut reply, h);
                let out = iox(publisher.loan_slice_uninit(PATH_REPLY), "loan")?;
                iox(out.write_from_slice(&reply).send(), "send")?;
                iox(notifier.notify(), "notify")?;
            }
            idle_wait(&listener)?;
        }
    }
}

type RawPorts = (
    Publisher<Svc, [u8], ()>,
    Subscriber<Svc, [u8], ()>,
    Notifier<Svc>,
    Listener<Svc>,
);

/// Raw iceoryx2 for the path comparison: iceoryx2's default service settings, `[u8]`
/// payloads of the runtime's sizes (the world sends `PATH_REQUEST`, the robot `PATH_REPLY`).
fn raw_path_ports(node: &Node<Svc>, run: &RunServices, world: bool) -> anyhow::Result<RawPorts> {
    let (out, inc, out_len) = if world {
        ("raw/obs", "raw/cmd", PATH_REQUEST)
    } else {
        ("raw/cmd", "raw/obs", PATH_REPLY)
    };
    let svc = |what: &str| -> anyhow::Result<_> {
        iox(
            node.service_builder(&service_name(run, what)?)
                .publish_subscribe::<[u8]>()
                .open_or_create(),
            "pub/sub service",
        )
    };
    let ev = |what: &str| -> anyhow::Result<_> {
        iox(
            node.service_builder(&service_name(run, what)?)
                .event()
                .open_or_create(),
            "event service",
        )
    };
    let publisher = iox(
        svc(out)?
            .publisher_builder()
            .initial_max_slice_len(out_len)
            .create(),
        "publisher",
    )?;
    let subscriber = iox(svc(inc)?.subscriber_builder().create(), "subscriber")?;
    let notifier = iox(ev(out)?.notifier_builder().create(), "notifier")?;
    let listener = iox(ev(inc)?.listener_builder().create(), "listener")?;
    Ok((publisher, subscriber, notifier, listener))
}

/// Sleeps on `listener` until `ready()` says the awaited sample was taken; an error after
/// [`PEER_TIMEOUT`] without it.
pub fn wait_for(
    listener: &Listener<Svc>,
    mut ready: impl FnMut() -> anyhow::Result<bool>,
) -> anyhow::Result<()> {
    let start = Instant::now();
    loop {
        if ready()? {
            return Ok(());
        }
        let waited = start.elapsed();
        if waited > PEER_TIMEOUT {
            bail!("peer silent for {PEER_TIMEOUT:?}");
        }
        iox(listener.timed_wait(|_| {}, PEER_TIMEOUT - waited), "wait")?;
    }
}

/// Sleeps on a robot's [`proto_ipc::TickWait`] (read `seen` before draining) until the world
/// wakes it; an error when [`PEER_TIMEOUT`] passes with nothing.
pub fn tick_wait(wait: &proto_ipc::TickWait, seen: u32) -> anyhow::Result<()> {
    match wait.wait(seen, PEER_TIMEOUT) {
        Ok(proto_ipc::bell::Woke::TimedOut) => {
            bail!("nothing from the peer for {PEER_TIMEOUT:?}")
        }
        Ok(_) => Ok(()),
        Err(e) => bail!("wait: {e}"),
    }
}

/// Sleeps on `listener` until a notification; an error when [`PEER_TIMEOUT`] passes without
/// one (the peer is gone: end instead of hanging). A wake with no events is not a timeout:
/// iceoryx2 returns at once with none when a notification's datagram was consumed by the
/// previous drain, so only the clock says the peer is silent.
pub fn idle_wait(listener: &Listener<Svc>) -> anyhow::Result<()> {
    let start = Instant::now();
    let n = iox(listener.timed_wait(|_| {}, PEER_TIMEOUT), "wait")?;
    if n == 0 && start.elapsed() >= PEER_TIMEOUT {
        bail!("nothing from the peer for {PEER_TIMEOUT:?}");
    }
    Ok(())
}
