//! This host's Zenoh session with the world: mutual TLS when the endpoint is `quic/`, the
//! world's messages down (decoded, or counted malformed), the world's liveliness, and the
//! publisher and token of this host's messages up.

use std::path::PathBuf;

use crossbeam_channel::Sender;
use swarmrt_hosts::link;
use swarmrt_hosts::wire::{Down, Up};
use swarmrt_ipc::IpcError;
use zenoh::Wait;
use zenoh::qos::CongestionControl;
use zenoh::sample::SampleKind;

use super::{Args, HostStats, Msg};

/// The certificate files of this host, as `swarm certs` wrote them.
#[derive(Default)]
struct CertFiles {
    ca: PathBuf,
    cert: PathBuf,
    key: PathBuf,
}

impl CertFiles {
    fn of(args: &Args) -> CertFiles {
        match &args.certs {
            Some(dir) => {
                let (cert, key) = swarmrt_hosts::certs::host_pair(dir, &args.host);
                CertFiles {
                    ca: swarmrt_hosts::certs::ca_cert(dir),
                    cert,
                    key,
                }
            }
            None => CertFiles::default(),
        }
    }

    /// Mutual TLS for a `quic/` endpoint, refused with the reason when a file is missing or
    /// the certificate names another host; none for a `tcp/` one.
    fn tls(&self, args: &Args) -> Result<link::Tls<'_>, IpcError> {
        if !args.connect.starts_with("quic/") {
            return Ok(link::Tls::Insecure);
        }
        if args.certs.is_none() {
            return Err("a quic/ endpoint needs --certs (the directory swarm certs wrote)".into());
        }
        for p in [&self.ca, &self.cert, &self.key] {
            if !p.is_file() {
                return Err(format!(
                    "{} is missing on this host (swarm certs writes it; copy it here)",
                    p.display()
                )
                .into());
            }
        }
        let named = swarmrt_hosts::certs::common_name(&self.cert)?;
        if named != args.host {
            return Err(format!(
                "{} names host {named:?}, not {:?}: the world would refuse everything it says; use this host's own certificate",
                self.cert.display(),
                args.host
            )
            .into());
        }
        Ok(link::Tls::Mutual {
            ca: &self.ca,
            cert: &self.cert,
            key: &self.key,
        })
    }
}

/// The session and what this host declared on it; closed by [`HostLink::close`].
pub(super) struct HostLink {
    session: zenoh::Session,
    up: zenoh::pubsub::Publisher<'static>,
    _down: zenoh::pubsub::Subscriber<()>,
    _world_alive: zenoh::pubsub::Subscriber<()>,
    _token: zenoh::liveliness::LivelinessToken,
}

impl HostLink {
    /// Connects to the world for `count` robots; what the world says and its loss arrive on
    /// `tx` as [`Msg`]s.
    pub(super) fn open(args: &Args, count: usize, tx: &Sender<Msg>) -> Result<HostLink, IpcError> {
        let certs = CertFiles::of(args);
        let session = link::host_session(&args.connect, count, certs.tls(args)?).map_err(|e| {
            format!(
                "cannot reach the world at {}: {e} (with quic/: is {} signed by the run's CA, and does the world's certificate name this address?)",
                args.connect,
                certs.cert.display()
            )
        })?;
        let down = tx.clone();
        let _down = session
            .declare_subscriber(link::down_key(&args.run_id, &args.host))
            .callback(move |sample| {
                let bytes = sample.payload().to_bytes();
                let _ = down.send(match Down::decode(&bytes, count) {
                    Ok(d) => Msg::Down(d, bytes.len()),
                    Err(_) => Msg::Malformed,
                });
            })
            .wait()?;
        let lost = tx.clone();
        let _world_alive = session
            .liveliness()
            .declare_subscriber(link::world_token(&args.run_id))
            .callback(move |sample| {
                if sample.kind() == SampleKind::Delete {
                    let _ = lost.send(Msg::WorldLost);
                }
            })
            .wait()?;
        let up = session
            .declare_publisher(link::up_key(&args.run_id, &args.host))
            .congestion_control(CongestionControl::Block)
            .express(true)
            .wait()?;
        let _token = session
            .liveliness()
            .declare_token(link::host_token(&args.run_id, &args.host))
            .wait()?;
        Ok(HostLink {
            session,
            up,
            _down,
            _world_alive,
            _token,
        })
    }

    /// The session, for the test hook that floods the world from it.
    #[cfg(feature = "misbehave")]
    pub(super) fn session(&self) -> &zenoh::Session {
        &self.session
    }

    /// Sends a message up to the world, counting its bytes.
    pub(super) fn send(&self, msg: &Up, stats: &mut HostStats) -> Result<(), IpcError> {
        let bytes = msg.encode();
        stats.bytes_up += bytes.len() as u64;
        self.up.put(bytes).wait()?;
        Ok(())
    }

    /// Closes the session (its declarations go with it).
    pub(super) fn close(self) {
        let _ = self.session.close().wait();
    }
}
