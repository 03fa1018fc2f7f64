//! The Zenoh side shared by both ends: key expressions, session configs and the layout hash
//! of the handshake.
//!
//! Zenoh is used directly (not iceoryx2's prototype Zenoh tunnel, see issue 16): reliable,
//! blocking on congestion and express, explicit endpoints, no scouting. The world's session
//! listens; each host's session is a client of it, so a host receives only what it
//! subscribed to: its own observation slots.

use swarmrt_protocol::PROTOCOL_VERSION;
use swarmrt_protocol::messages::{Command, MAX_INBOX, MAX_LIDAR_RAYS, MAX_OUTBOX, Observation};
use zenoh::Wait;

/// Error type of the link.
pub type LinkError = Box<dyn std::error::Error + Send + Sync>;

/// How long a Zenoh transport lives without hearing its peer: a cut link is noticed (and
/// the liveliness tokens behind it vanish) after this. Zenoh's default is 10 s.
pub const LEASE_MS: u64 = 3_000;

/// World -> host `name`.
pub fn down_key(run_id: &str, host: &str) -> String {
    format!("swarmrt/{run_id}/host/{host}/down")
}

/// Host -> world, from every host.
pub fn up_key(run_id: &str, host: &str) -> String {
    format!("swarmrt/{run_id}/host/{host}/up")
}

/// The liveliness token of host `name` (present while its session is).
pub fn host_token(run_id: &str, host: &str) -> String {
    format!("swarmrt/{run_id}/alive/{host}")
}

/// The liveliness token of the world.
pub fn world_token(run_id: &str) -> String {
    format!("swarmrt/{run_id}/alive-world")
}

/// The largest message a link carries for a host of `robots` robots: a tick's slots down, or
/// up to `2 * robots + 8` commands up (what [`crate::wire::Up::decode`] accepts), with room
/// for framing. Zenoh drops a larger message instead of reassembling up to its default 1 GiB.
pub fn max_message_size(robots: usize) -> usize {
    let per = std::mem::size_of::<Observation>().max(std::mem::size_of::<Command>()) + 16;
    64 * 1024 + (2 * robots + 8) * per
}

fn common(mode: &str, max_message: usize, max_sessions: usize) -> String {
    format!(
        r#"{{
            mode: "{mode}",
            scouting: {{ multicast: {{ enabled: false }}, gossip: {{ enabled: true }} }},
            transport: {{
                unicast: {{ max_sessions: {max_sessions} }},
                link: {{ tx: {{ lease: {LEASE_MS} }}, rx: {{ max_message_size: {max_message} }} }},
            }},
        }}"#
    )
}

/// The world's session: listens on `listen`, connects nowhere; at most one session per host
/// and one more (a host restarting while its old session times out), messages of at most
/// [`max_message_size`] for its largest host (`robots`).
pub fn world_session(
    listen: &str,
    hosts: usize,
    robots: usize,
) -> Result<zenoh::Session, LinkError> {
    let mut c = zenoh::Config::from_json5(&common("peer", max_message_size(robots), hosts + 1))?;
    c.insert_json5("listen/endpoints", &serde_json::to_string(&[listen])?)?;
    zenoh::open(c).wait()
}

/// A host's session: a client of the world at `connect`, trying for up to 10 s, for a host
/// of `robots` robots.
pub fn host_session(connect: &str, robots: usize) -> Result<zenoh::Session, LinkError> {
    let mut c = zenoh::Config::from_json5(&common("client", max_message_size(robots), 1))?;
    c.insert_json5("connect/endpoints", &serde_json::to_string(&[connect])?)?;
    c.insert_json5("connect/timeout_ms", "10000")?;
    c.insert_json5("connect/exit_on_failure", "true")?;
    zenoh::open(c).wait()
}

/// What both ends must agree on before robots start: the message layout of the build and the
/// resolved config text (a host given another config would replay another run).
pub fn layout(config_toml: &str) -> u32 {
    let mut h = crc32fast::Hasher::new();
    let shape = format!(
        "swarmrt v{PROTOCOL_VERSION} obs {} cmd {} rays {MAX_LIDAR_RAYS} inbox {MAX_INBOX} outbox {MAX_OUTBOX}\n",
        std::mem::size_of::<Observation>(),
        std::mem::size_of::<Command>(),
    );
    h.update(shape.as_bytes());
    h.update(config_toml.as_bytes());
    h.finalize()
}
