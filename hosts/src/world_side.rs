//! The world's end of the link: one publisher per host for its slots, one subscriber per host
//! for its commands, and the hosts' liveliness. Incoming messages are decoded on Zenoh's
//! threads and queued; the world's shell relays them into its main loop (`swarmrt_ipc::wake_relay`).

use std::ops::Range;
use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};

use crossbeam_channel::{Receiver, Sender};
use serde::Serialize;
use zenoh::Wait;
use zenoh::qos::CongestionControl;
use zenoh::sample::SampleKind;

use crate::hosts_file::HostsFile;
use crate::link::{self, LinkError};
use crate::wire::{Down, Up};

/// Something a host said (or that it vanished).
#[derive(Debug)]
pub enum Heard {
    /// A message from host `host` (its index in the hosts file), `bytes` long.
    Up {
        /// The host.
        host: usize,
        /// The message.
        msg: Up,
        /// Its size on the wire.
        bytes: usize,
    },
    /// A message from `host` that did not decode; dropped and counted.
    Malformed {
        /// The host.
        host: usize,
    },
    /// The host's session is gone (its process died or its link was cut).
    Lost {
        /// The host.
        host: usize,
    },
}

/// Traffic with one host (`metrics.json` -> `shell.link`).
#[derive(Debug, Default, Clone, Serialize)]
pub struct HostTraffic {
    /// The host.
    pub host: String,
    /// Its robot ids.
    pub robots: Range<u32>,
    /// Bytes sent to it (observation slots, handshake, shutdown).
    pub bytes_down: u64,
    /// Bytes received from it (command batches, joins).
    pub bytes_up: u64,
    /// Messages sent to it.
    pub messages_down: u64,
    /// Messages received from it.
    pub messages_up: u64,
    /// Messages from it that did not decode.
    pub malformed: u64,
    /// Messages from it dropped because the world's queue was full (a flood): never queued,
    /// so memory stays bounded.
    pub dropped: u64,
    /// Joins refused after it had joined (wrong build, config or name); the run goes on.
    pub bad_joins: u64,
}

/// How many messages from the hosts may wait for the world's loop: a tick brings at most one
/// batch per host plus one message per robot answering past the deadline, so this is many
/// ticks' worth; past it a message is dropped and counted.
pub fn queue_capacity(hosts: usize, robots: usize) -> usize {
    1024 + 8 * (hosts + robots)
}

struct Remote {
    robots: Range<u32>,
    down: zenoh::pubsub::Publisher<'static>,
}

/// The world's Zenoh session and its per-host ports.
pub struct WorldLink {
    hosts: Vec<Remote>,
    traffic: Vec<HostTraffic>,
    /// Per host: messages dropped on a full queue (counted on Zenoh's threads).
    dropped: Vec<Arc<AtomicU64>>,
    _subscribers: Vec<zenoh::pubsub::Subscriber<()>>,
    _liveliness: zenoh::pubsub::Subscriber<()>,
    _token: zenoh::liveliness::LivelinessToken,
    session: zenoh::Session,
}

impl WorldLink {
    /// Listens on the file's endpoint and declares every host's ports. Messages from hosts
    /// arrive on the returned receiver.
    pub fn open(file: &HostsFile, run_id: &str) -> Result<(WorldLink, Receiver<Heard>), LinkError> {
        let largest = file.hosts.iter().map(|h| h.robots.len()).max().unwrap_or(0);
        let robots: usize = file.hosts.iter().map(|h| h.robots.len()).sum();
        let names: Vec<&str> = file.hosts.iter().map(|h| h.name.as_str()).collect();
        let (ca, (cert, key)) = (
            crate::certs::ca_cert(&file.certs),
            crate::certs::world_pair(&file.certs),
        );
        let tls = if file.is_secure() {
            link::Tls::Mutual {
                ca: &ca,
                cert: &cert,
                key: &key,
            }
        } else {
            link::Tls::Insecure
        };
        let session = link::world_session(&file.listen, run_id, &names, largest, tls)
            .map_err(|e| format!("cannot listen on {}: {e}", file.listen))?;
        let (tx, rx) = crossbeam_channel::bounded(queue_capacity(file.hosts.len(), robots));
        let mut hosts = Vec::new();
        let mut subscribers = Vec::new();
        let mut dropped = Vec::new();
        for (i, h) in file.hosts.iter().enumerate() {
            let down = session
                .declare_publisher(link::down_key(run_id, &h.name))
                .congestion_control(CongestionControl::Block)
                .express(true)
                .wait()?;
            let tx: Sender<Heard> = tx.clone();
            let max = 2 * h.robots.len() + 8;
            let drops = Arc::new(AtomicU64::new(0));
            dropped.push(drops.clone());
            let sub = session
                .declare_subscriber(link::up_key(run_id, &h.name))
                .callback(move |sample| {
                    let bytes = sample.payload().to_bytes();
                    let heard = match Up::decode(&bytes, max) {
                        Ok(msg) => Heard::Up {
                            host: i,
                            msg,
                            bytes: bytes.len(),
                        },
                        Err(_) => Heard::Malformed { host: i },
                    };
                    if tx.try_send(heard).is_err() {
                        drops.fetch_add(1, Ordering::Relaxed);
                    }
                })
                .wait()?;
            subscribers.push(sub);
            hosts.push(Remote {
                robots: h.robots.clone(),
                down,
            });
        }
        let names: Vec<String> = file
            .hosts
            .iter()
            .map(|h| link::host_token(run_id, &h.name))
            .collect();
        let ltx = tx.clone();
        let liveliness = session
            .liveliness()
            .declare_subscriber(format!("swarmrt/{run_id}/alive/*"))
            .callback(move |sample| {
                if sample.kind() == SampleKind::Delete
                    && let Some(host) = names.iter().position(|n| n == sample.key_expr().as_str())
                {
                    let _ = ltx.send(Heard::Lost { host });
                }
            })
            .wait()?;
        let token = session
            .liveliness()
            .declare_token(link::world_token(run_id))
            .wait()?;
        let traffic = file
            .hosts
            .iter()
            .map(|h| HostTraffic {
                host: h.name.clone(),
                robots: h.robots.clone(),
                ..HostTraffic::default()
            })
            .collect();
        Ok((
            WorldLink {
                hosts,
                traffic,
                dropped,
                _subscribers: subscribers,
                _liveliness: liveliness,
                _token: token,
                session,
            },
            rx,
        ))
    }

    /// Number of hosts.
    pub fn len(&self) -> usize {
        self.hosts.len()
    }

    /// True without hosts.
    pub fn is_empty(&self) -> bool {
        self.hosts.is_empty()
    }

    /// The robot ids of host `host`.
    pub fn robots(&self, host: usize) -> Range<u32> {
        self.hosts[host].robots.clone()
    }

    /// Sends `msg` to host `host` (blocking while its link is congested: lock-step needs every
    /// slot delivered).
    pub fn send(&mut self, host: usize, msg: &Down) -> Result<(), LinkError> {
        self.send_bytes(host, msg.encode())
    }

    /// Sends an encoded [`Down`] (e.g. from [`crate::wire::encode_tick`]) to host `host`.
    pub fn send_bytes(&mut self, host: usize, bytes: Vec<u8>) -> Result<(), LinkError> {
        self.traffic[host].bytes_down += bytes.len() as u64;
        self.traffic[host].messages_down += 1;
        self.hosts[host].down.put(bytes).wait()?;
        Ok(())
    }

    /// Counts a message received from `host`.
    pub fn count_up(&mut self, host: usize, bytes: usize, malformed: bool) {
        let t = &mut self.traffic[host];
        if malformed {
            t.malformed += 1;
        } else {
            t.bytes_up += bytes as u64;
            t.messages_up += 1;
        }
    }

    /// Counts a `Join` refused after the host had joined.
    pub fn count_bad_join(&mut self, host: usize) {
        self.traffic[host].bad_joins += 1;
    }

    /// Traffic so far, per host.
    pub fn traffic(&mut self) -> &[HostTraffic] {
        for (t, d) in self.traffic.iter_mut().zip(&self.dropped) {
            t.dropped = d.load(Ordering::Relaxed);
        }
        &self.traffic
    }

    /// Closes the session (the hosts see the world's token vanish).
    pub fn close(self) {
        let WorldLink { session, .. } = self;
        let _ = session.close().wait();
    }
}
