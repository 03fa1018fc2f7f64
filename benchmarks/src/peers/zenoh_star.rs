//! The Zenoh peer floor: every process is a Zenoh peer, in a star. The world listens on
//! `tcp/127.0.0.1:<port>`; each robot connects to it and nowhere else (no multicast
//! scouting, gossip that tells nobody, no listening of its own), so 1,000 robots make 1,000
//! sessions, not a mesh. Keys: the world puts each robot's slot on `bench/<run>/obs/<id>` (one `put` per
//! robot, the like-for-like of "hand each robot its slot": a robot receives only its own
//! message, as it reads only its own slot of the iceoryx2 sample), a robot puts its answer on
//! `bench/<run>/cmd/<id>`, the world subscribes to `bench/<run>/cmd/*`. Reliable, congestion
//! control `Block`, `express` (no batching delay) on both sides, as the runtime's own Zenoh
//! link between hosts does.
//!
//! Zenoh's runtime threads: a robot runs every Zenoh runtime on one Tokio worker
//! ([`ROBOT_RUNTIME`], through the `ZENOH_RUNTIME` variable, unless it is set already), so a
//! robot process is its main thread plus one or two Zenoh threads. The world keeps Zenoh's
//! default runtimes (one process, it serves every session).

use std::time::{Duration, Instant};

use anyhow::{Context, bail};
use swarmrt_protocol::CommandKind;
use zenoh::Wait;
use zenoh::handlers::{FifoChannel, FifoChannelHandler};
use zenoh::pubsub::{Publisher, Subscriber};
use zenoh::qos::CongestionControl;
use zenoh::sample::Sample;

use super::{CMD_BYTES, WorldLink, answer, command, drive, startup_limit};
use crate::PEER_TIMEOUT;
use crate::child::{ChildMsg, say};

/// `ZENOH_RUNTIME` of a robot: every Zenoh runtime handed over to one Tokio worker thread.
pub const ROBOT_RUNTIME: &str = "(app: (worker_threads: 1, max_blocking_threads: 2), \
     acc: (handover: app), tx: (handover: app), rx: (handover: app), net: (handover: app))";

fn zerr(what: &str) -> impl FnOnce(zenoh::Error) -> anyhow::Error + '_ {
    move |e| anyhow::anyhow!("zenoh {what}: {e}")
}

fn obs_key(run_id: &str, robot: u32) -> String {
    format!("bench/{run_id}/obs/{robot}")
}

fn cmd_key(run_id: &str, robot: u32) -> String {
    format!("bench/{run_id}/cmd/{robot}")
}

/// Gossip on (Zenoh's peer routing wants it to de-duplicate, and warns without it) but
/// single-hop, telling nobody (`target`) and connecting to nobody it hears of
/// (`autoconnect`): the star stays a star and 1,000 robots exchange no gossip.
const GOSSIP: &str = "{ enabled: true, multihop: false, target: { router: [], peer: [] }, \
     autoconnect: { router: [], peer: [] } }";

/// The world's session config: a peer listening on `endpoint`, connecting nowhere, room
/// for `n` sessions all connecting at once.
pub fn world_config(endpoint: &str, n: usize) -> anyhow::Result<zenoh::Config> {
    let text = format!(
        r#"{{
            mode: "peer",
            listen: {{ endpoints: ["{endpoint}"] }},
            connect: {{ endpoints: [] }},
            scouting: {{ multicast: {{ enabled: false }}, gossip: {GOSSIP} }},
            transport: {{ unicast: {{
                max_sessions: {sessions}, accept_pending: {sessions},
                accept_timeout: 60000, open_timeout: 60000,
            }} }},
        }}"#,
        sessions = n + 16
    );
    zenoh::Config::from_json5(&text).map_err(zerr("world config"))
}

/// A robot's session config: a peer connecting to the world at `endpoint` only, listening
/// nowhere, trying for `limit`.
pub fn robot_config(endpoint: &str, limit: Duration) -> anyhow::Result<zenoh::Config> {
    let text = format!(
        r#"{{
            mode: "peer",
            listen: {{ endpoints: [] }},
            connect: {{ endpoints: ["{endpoint}"], timeout_ms: {ms}, exit_on_failure: true }},
            scouting: {{ multicast: {{ enabled: false }}, gossip: {GOSSIP} }},
            transport: {{ unicast: {{ max_sessions: 4, open_timeout: 60000 }} }},
        }}"#,
        ms = limit.as_millis()
    );
    zenoh::Config::from_json5(&text).map_err(zerr("robot config"))
}

/// A free TCP port on 127.0.0.1 (the kernel's pick; closed again for Zenoh to bind).
fn free_port() -> anyhow::Result<u16> {
    let l = std::net::TcpListener::bind("127.0.0.1:0")?;
    Ok(l.local_addr()?.port())
}

/// Waits until `publisher` has a matching subscriber (start-up only: a `put` before that
/// goes nowhere), at most until `deadline`.
fn wait_matching(publisher: &Publisher<'_>, deadline: Instant, who: &str) -> anyhow::Result<()> {
    let listener = publisher
        .matching_listener()
        .wait()
        .map_err(zerr("matching listener"))?;
    if publisher
        .matching_status()
        .wait()
        .map_err(zerr("matching status"))?
        .matching()
    {
        return Ok(());
    }
    loop {
        match listener.recv_deadline(deadline) {
            Ok(Some(s)) if s.matching() => return Ok(()),
            Ok(Some(_)) => {}
            Ok(None) => bail!("{who}: no subscriber appeared in time"),
            Err(e) => bail!("{who}: matching listener: {e}"),
        }
    }
}

struct ZenohWorld<'a> {
    publishers: Vec<Publisher<'a>>,
    commands: Subscriber<FifoChannelHandler<Sample>>,
    /// Until the first put: the deadline for every robot's subscriber to be known here.
    match_by: Option<Instant>,
}

impl WorldLink for ZenohWorld<'_> {
    fn send(&mut self, robot: u32, msg: &[u8]) -> anyhow::Result<()> {
        if let Some(deadline) = self.match_by.take() {
            for (i, p) in self.publishers.iter().enumerate() {
                wait_matching(p, deadline, &format!("the world's publisher to robot {i}"))?;
            }
        }
        let p = self
            .publishers
            .get(robot as usize)
            .with_context(|| format!("no publisher for robot {robot}"))?;
        // The slot's bytes, copied into the message's own buffer, as a Zenoh user does.
        p.put(msg.to_vec()).wait().map_err(zerr("put"))
    }

    fn receive(&mut self, deadline: Instant, on: &mut dyn FnMut(&[u8])) -> anyhow::Result<()> {
        match self.commands.recv_deadline(deadline) {
            Ok(Some(s)) => on(&s.payload().to_bytes()),
            Ok(None) => return Ok(()),
            Err(e) => bail!("zenoh subscriber: {e}"),
        }
        while let Ok(Some(s)) = self.commands.try_recv() {
            on(&s.payload().to_bytes());
        }
        Ok(())
    }
}

/// The Zenoh world: open the listening session, declare the command subscriber and one
/// publisher per robot, say ready with the endpoint, drive the lock-step.
pub fn world(run_id: &str, n: usize, ticks: u64) -> anyhow::Result<()> {
    let endpoint = format!("tcp/127.0.0.1:{}", free_port()?);
    let session = zenoh::open(world_config(&endpoint, n)?)
        .wait()
        .map_err(zerr("open"))?;
    let commands = session
        .declare_subscriber(format!("bench/{run_id}/cmd/*"))
        .with(FifoChannel::new(2 * n + 16))
        .wait()
        .map_err(zerr("subscriber"))?;
    let mut publishers = Vec::with_capacity(n);
    for i in 0..n as u32 {
        publishers.push(
            session
                .declare_publisher(obs_key(run_id, i))
                .congestion_control(CongestionControl::Block)
                .express(true)
                .wait()
                .map_err(zerr("publisher"))?,
        );
    }
    say(&ChildMsg::Ready {
        addr: Some(endpoint),
    })?;
    // A robot says hello once it sees the world's subscriber; the world puts to it once it
    // sees the robot's (checked before the first put). Both are start-up only.
    let mut link = ZenohWorld {
        publishers,
        commands,
        match_by: Some(Instant::now() + startup_limit(n)),
    };
    let r = drive(&mut link, "Zenoh", n, ticks);
    drop(link);
    let _ = session.close().wait();
    r
}

/// A Zenoh robot: open a session to the world, subscribe to its own key, hello once the
/// world's subscriber is known, then answer each slot until shutdown.
pub fn agent(
    run_id: &str,
    robot: u32,
    robots: usize,
    endpoint: &str,
    die_at: Option<u64>,
) -> anyhow::Result<()> {
    if std::env::var_os("ZENOH_RUNTIME").is_none() {
        // SAFETY: set before Zenoh (or anything else) starts a thread in this process.
        unsafe {
            std::env::set_var("ZENOH_RUNTIME", ROBOT_RUNTIME);
        }
    }
    let limit = startup_limit(robots);
    let started = Instant::now();
    let session = zenoh::open(robot_config(endpoint, limit)?)
        .wait()
        .map_err(zerr("open"))?;
    let slots = session
        .declare_subscriber(obs_key(run_id, robot))
        .with(FifoChannel::new(16))
        .wait()
        .map_err(zerr("subscriber"))?;
    let publisher = session
        .declare_publisher(cmd_key(run_id, robot))
        .congestion_control(CongestionControl::Block)
        .express(true)
        .wait()
        .map_err(zerr("publisher"))?;
    wait_matching(
        &publisher,
        started + limit,
        &format!("robot {robot}'s publisher"),
    )?;
    let mut out = vec![0u8; CMD_BYTES];
    command(&mut out, robot, 0, CommandKind::Hello);
    publisher.put(out.clone()).wait().map_err(zerr("hello"))?;
    let mut timeout = limit;
    let r = loop {
        let sample = match slots.recv_timeout(timeout) {
            Ok(Some(s)) => s,
            Ok(None) => {
                break Err(anyhow::anyhow!(
                    "robot {robot}: nothing from the world in time"
                ));
            }
            Err(e) => break Err(anyhow::anyhow!("robot {robot}: subscriber: {e}")),
        };
        timeout = PEER_TIMEOUT;
        match answer(&sample.payload().to_bytes(), robot, die_at, &mut out) {
            Ok(None) => break Ok(()),
            Ok(Some(())) => {
                if let Err(e) = publisher.put(out.clone()).wait() {
                    break Err(anyhow::anyhow!("robot {robot}: put: {e}"));
                }
            }
            Err(e) => break Err(e),
        }
    };
    drop(publisher);
    drop(slots);
    let _ = session.close().wait();
    r
}
