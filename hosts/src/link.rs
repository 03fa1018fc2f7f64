//! The Zenoh side shared by both ends: key expressions, session configs and the layout hash
//! of the handshake.
//!
//! Zenoh is used directly (not iceoryx2's prototype Zenoh tunnel, see issue 16): reliable,
//! blocking on congestion and express, explicit endpoints, no scouting. The world's session
//! listens; each host's session is a client of it, so a host receives only what it
//! subscribed to: its own observation slots.

use std::path::Path;
use std::time::Duration;
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

/// How one end of the link proves who it is.
#[derive(Debug, Clone, Copy)]
pub enum Tls<'a> {
    /// Mutual TLS (`quic/` endpoints): both ends present a certificate of the run's CA.
    Mutual {
        /// The run's CA certificate: the only one this end trusts.
        ca: &'a Path,
        /// This end's certificate.
        cert: &'a Path,
        /// Its private key.
        key: &'a Path,
    },
    /// Plain TCP (`tcp/`, `--insecure-link`): nobody proves anything.
    Insecure,
}

fn json(s: &Path) -> Result<String, LinkError> {
    Ok(serde_json::to_string(&s.display().to_string())?)
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

/// `side` is "listen" (the world) or "connect" (a host). The world's certificate must name
/// the address a host connects to (zenoh checks it); the world matches hosts by the common
/// name of theirs ([`world_acl`]).
fn set_tls(c: &mut zenoh::Config, side: &str, tls: Tls) -> Result<(), LinkError> {
    if let Tls::Mutual { ca, cert, key } = tls {
        c.insert_json5("transport/link/tls/root_ca_certificate", &json(ca)?)?;
        c.insert_json5(
            &format!("transport/link/tls/{side}_certificate"),
            &json(cert)?,
        )?;
        c.insert_json5(
            &format!("transport/link/tls/{side}_private_key"),
            &json(key)?,
        )?;
        c.insert_json5("transport/link/tls/enable_mtls", "true")?;
        c.insert_json5("transport/link/tls/verify_name_on_connect", "true")?;
        c.insert_json5("transport/link/tls/close_link_on_expiration", "true")?;
    }
    Ok(())
}

/// The world's access control, default deny: host `h` (a TLS peer whose certificate's common
/// name is `h`) may publish only on its up key, subscribe only to its down key (and receive
/// the world's samples there), declare only its own liveliness token and watch the world's.
/// Nothing else passes, in either direction.
pub fn world_acl(run_id: &str, hosts: &[&str]) -> String {
    let mut rules = Vec::new();
    let mut subjects = Vec::new();
    let mut policies = Vec::new();
    for h in hosts {
        let (up, down) = (up_key(run_id, h), down_key(run_id, h));
        let (token, world) = (host_token(run_id, h), world_token(run_id));
        let mine = [
            ("in-put-up", "ingress", "put", up.as_str()),
            (
                "in-sub-down",
                "ingress",
                "declare_subscriber",
                down.as_str(),
            ),
            ("out-put-down", "egress", "put", down.as_str()),
            // The world's subscriber on the up key, announced to the host so it sends there.
            ("out-sub-up", "egress", "declare_subscriber", up.as_str()),
            ("in-token", "ingress", "liveliness_token", token.as_str()),
            (
                "in-watch-world",
                "ingress",
                "declare_liveliness_subscriber",
                world.as_str(),
            ),
            (
                "out-token-world",
                "egress",
                "liveliness_token",
                world.as_str(),
            ),
        ];
        let mut ids = Vec::new();
        for (id, flow, message, key) in mine {
            let id = format!("{h}-{id}");
            rules.push(format!(
                r#"{{ id: "{id}", flows: ["{flow}"], messages: ["{message}"], permission: "allow", key_exprs: ["{key}"] }}"#
            ));
            ids.push(format!("\"{id}\""));
        }
        subjects.push(format!(
            r#"{{ id: "host-{h}", cert_common_names: ["{h}"], link_protocols: ["quic"] }}"#
        ));
        policies.push(format!(
            r#"{{ id: "policy-{h}", rules: [{}], subjects: ["host-{h}"] }}"#,
            ids.join(", ")
        ));
    }
    format!(
        r#"{{ enabled: true, default_permission: "deny", rules: [{}], subjects: [{}], policies: [{}] }}"#,
        rules.join(", "),
        subjects.join(", "),
        policies.join(", ")
    )
}

/// The world's session: listens on `listen`, connects nowhere; at most one session per host
/// and one more (a host restarting while its old session times out), messages of at most
/// [`max_message_size`] for its largest host (`robots`). With TLS, `hosts` may do only what
/// [`world_acl`] allows.
pub fn world_session(
    listen: &str,
    run_id: &str,
    hosts: &[&str],
    robots: usize,
    tls: Tls,
) -> Result<zenoh::Session, LinkError> {
    let mut c =
        zenoh::Config::from_json5(&common("peer", max_message_size(robots), hosts.len() + 1))?;
    c.insert_json5("listen/endpoints", &serde_json::to_string(&[listen])?)?;
    set_tls(&mut c, "listen", tls)?;
    if matches!(tls, Tls::Mutual { .. }) {
        c.insert_json5("access_control", &world_acl(run_id, hosts))?;
    }
    zenoh::open(c).wait()
}

/// How long a host keeps trying to reach the world before it gives up.
pub const HOST_CONNECT_TIMEOUT: Duration = Duration::from_secs(10);

/// A host's session: a client of the world at `connect`, trying for up to
/// [`HOST_CONNECT_TIMEOUT`], for a host of `robots` robots.
pub fn host_session(connect: &str, robots: usize, tls: Tls) -> Result<zenoh::Session, LinkError> {
    host_session_within(connect, robots, tls, HOST_CONNECT_TIMEOUT)
}

/// [`host_session`], trying for `within`: the tests of refused certificates wait less than a
/// host would for a refusal they know is coming (a refused handshake is retried until then).
pub fn host_session_within(
    connect: &str,
    robots: usize,
    tls: Tls,
    within: Duration,
) -> Result<zenoh::Session, LinkError> {
    let mut c = zenoh::Config::from_json5(&common("client", max_message_size(robots), 1))?;
    set_tls(&mut c, "connect", tls)?;
    c.insert_json5("connect/endpoints", &serde_json::to_string(&[connect])?)?;
    c.insert_json5("connect/timeout_ms", &within.as_millis().to_string())?;
    c.insert_json5("connect/exit_on_failure", "true")?;
    zenoh::open(c).wait()
}

/// What both ends must agree on before robots start: the message layout of the build and the
/// resolved config text (a host given another config would replay another run).
pub fn layout(config_toml: &str) -> u32 {
    let mut h = crc32fast::Hasher::new();
    let shape = format!(
        "swarmrt v{PROTOCOL_VERSION} obs {} cmd {} rays {MAX_LIDAR_RAYS} inbox {MAX_INBOX} outbox {MAX_OUTBOX} wire {}\n",
        std::mem::size_of::<Observation>(),
        std::mem::size_of::<Command>(),
        crate::wire::WIRE_REVISION,
    );
    h.update(shape.as_bytes());
    h.update(config_toml.as_bytes());
    h.finalize()
}
