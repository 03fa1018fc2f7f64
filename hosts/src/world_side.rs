//! The world's end of the link: one publisher per host for its slots, one subscriber per host
//! for its commands, and the hosts' liveliness. Incoming messages are decoded on Zenoh's
//! threads and queued; the world's shell relays them into its main loop (`swarmrt_ipc::wake_relay`).
//!
//! The queue is shared, but each host has a share of it ([`host_quota`]): a message holds
//! a place in its host's share until the world is done with it (its [`Heard`] is dropped).
//! A host past its share has its own messages dropped and counted against it, so one host's
//! flood never costs another host a message. Its answers to the world's resend requests have
//! a few places of their own ([`RESENT_RESERVE`]), so a flood of batches does not drown them.

use std::ops::Range;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicU64, AtomicUsize, Ordering};
use std::time::{Duration, Instant};

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
        /// Its place in the host's share of the queue, given back when this is dropped.
        slot: Slot,
    },
    /// A message from `host` that did not decode; dropped and counted.
    Malformed {
        /// The host.
        host: usize,
        /// Its place in the host's share of the queue.
        slot: Slot,
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
    /// How many of its messages may wait for the world at once ([`host_quota`]).
    pub quota: usize,
    /// Its messages dropped because its share of the world's queue was full (it sent faster
    /// than the world reads): never queued, so memory stays bounded. Only this host's own
    /// messages are ever counted here.
    pub dropped: u64,
    /// Times the world asked it to send again what the world had not received
    /// ([`crate::wire::Down::Resend`]), after messages of it were dropped.
    pub resends: u64,
    /// Robots whose answer or hello reached the world only in a resend.
    pub recovered: u64,
    /// Joins refused after it had joined (wrong build, config or name); the run goes on.
    pub bad_joins: u64,
}

/// How many messages of one host of `robots` robots may wait for the world's loop. A tick
/// brings at most one batch, one message per robot answering past the deadline and a resend,
/// and the world reads them all before the next tick, so this is a few ticks' worth; past it
/// that host's messages are dropped and counted against it.
pub fn host_quota(robots: usize) -> usize {
    64 + 2 * robots
}

/// Places of each host's share kept for its [`Up::Resent`] answers: the world asks at most
/// once per [`RESEND_EVERY`] and reads everything before asking again.
pub const RESENT_RESERVE: usize = 4;

/// The world's queue: every host's share and resend places, and a place for its `Lost`.
pub fn queue_capacity(file: &HostsFile) -> usize {
    file.hosts
        .iter()
        .map(|h| host_quota(h.robots.len()) + RESENT_RESERVE + 1)
        .sum()
}

/// One host's share of the world's queue, as Zenoh's threads and the world's loop see it.
#[derive(Debug)]
struct Share {
    host: String,
    quota: usize,
    /// Its messages queued or being handled by the world.
    waiting: AtomicUsize,
    /// The same, of its `Resent` answers (at most [`RESENT_RESERVE`]).
    resent_waiting: AtomicUsize,
    dropped: AtomicU64,
    /// Its `Lost` has been queued (once is enough).
    lost: AtomicBool,
}

impl Share {
    /// A place for one more message (a `Resent` answer when `resent`), unless the host's
    /// share is full: then the message is counted as dropped (the first drop is logged, once).
    fn take(self: &Arc<Share>, resent: bool) -> Option<Slot> {
        let quota = self.quota;
        let (count, limit) = if resent {
            (&self.resent_waiting, RESENT_RESERVE)
        } else {
            (&self.waiting, quota)
        };
        let free = count.fetch_update(Ordering::AcqRel, Ordering::Acquire, |w| {
            (w < limit).then_some(w + 1)
        });
        if free.is_ok() {
            return Some(Slot {
                share: self.clone(),
                resent,
            });
        }
        if self.dropped.fetch_add(1, Ordering::Relaxed) == 0 {
            tracing::warn!(
                "host {} sends faster than the world reads: its messages past {quota} waiting are dropped and counted (metrics.json shell.link[].dropped), and the world asks it to resend what it lost; other hosts are not affected",
                self.host
            );
        }
        None
    }
}

/// A queued message's place in its host's share of the world's queue; dropping it (with
/// the [`Heard`] that holds it) gives the place back.
#[derive(Debug)]
pub struct Slot {
    share: Arc<Share>,
    resent: bool,
}

impl Drop for Slot {
    fn drop(&mut self) {
        let count = if self.resent {
            &self.share.resent_waiting
        } else {
            &self.share.waiting
        };
        count.fetch_sub(1, Ordering::AcqRel);
    }
}

/// How often, at most, the world asks one host to resend ([`Resends`]).
pub const RESEND_EVERY: Duration = Duration::from_millis(50);

/// When the world asks a host to send again what it has not received (a pure rule; the
/// caller passes the time). Only a host whose own messages were dropped is asked, only while
/// the world waits for something of it, at most once per [`RESEND_EVERY`] and again as long
/// as its drops go on: a lost batch costs a resend, not its robots' lives.
#[derive(Debug, Clone)]
pub struct Resends {
    hosts: Vec<Asked>,
}

#[derive(Debug, Clone, Default)]
struct Asked {
    /// Drops accounted for: before the world waited, or covered by an ask.
    seen: u64,
    /// The last ask.
    at: Option<Instant>,
    /// Drops came while the last ask was too recent: ask once it is not.
    owed: bool,
}

impl Resends {
    /// For `hosts` hosts, none asked yet.
    pub fn new(hosts: usize) -> Resends {
        Resends {
            hosts: vec![Asked::default(); hosts],
        }
    }

    /// Host `host` has had `dropped` messages dropped so far and the world waits (or not)
    /// for some of its robots: true when the world should ask it to resend now.
    pub fn due(&mut self, host: usize, dropped: u64, waiting: bool, now: Instant) -> bool {
        let a = &mut self.hosts[host];
        if !waiting || dropped <= a.seen {
            // Drops while the world waited for nothing of it cost nothing.
            if !waiting {
                a.seen = dropped;
            }
            a.owed = false;
            return false;
        }
        if a.at.is_some_and(|t| now < t + RESEND_EVERY) {
            a.owed = true;
            return false;
        }
        *a = Asked {
            seen: dropped,
            at: Some(now),
            owed: false,
        };
        true
    }

    /// When the earliest ask held back by [`RESEND_EVERY`] comes due: the world must look
    /// again then, even if nothing wakes it.
    pub fn next(&self) -> Option<Instant> {
        self.hosts
            .iter()
            .filter(|a| a.owed)
            .filter_map(|a| a.at.map(|t| t + RESEND_EVERY))
            .min()
    }
}

struct Remote {
    robots: Range<u32>,
    down: zenoh::pubsub::Publisher<'static>,
}

/// The world's Zenoh session and its per-host ports.
pub struct WorldLink {
    hosts: Vec<Remote>,
    traffic: Vec<HostTraffic>,
    /// Per host: its share of the queue and its drops (counted on Zenoh's threads).
    shares: Vec<Arc<Share>>,
    _subscribers: Vec<zenoh::pubsub::Subscriber<()>>,
    _liveliness: zenoh::pubsub::Subscriber<()>,
    _token: zenoh::liveliness::LivelinessToken,
    session: zenoh::Session,
}

/// Host `i`'s ports at the world: its down publisher and its up subscriber, which takes a
/// message only while the host's share of the queue has room and decodes it on Zenoh's thread.
fn declare_host(
    session: &zenoh::Session,
    run_id: &str,
    i: usize,
    h: &crate::hosts_file::Host,
    tx: Sender<Heard>,
) -> Result<(Remote, zenoh::pubsub::Subscriber<()>, Arc<Share>), LinkError> {
    let down = session
        .declare_publisher(link::down_key(run_id, &h.name))
        .congestion_control(CongestionControl::Block)
        .express(true)
        .wait()?;
    let max = 2 * h.robots.len() + 8;
    let share = Arc::new(Share {
        host: h.name.clone(),
        quota: host_quota(h.robots.len()),
        waiting: AtomicUsize::new(0),
        resent_waiting: AtomicUsize::new(0),
        dropped: AtomicU64::new(0),
        lost: AtomicBool::new(false),
    });
    let mine = share.clone();
    let sub = session
        .declare_subscriber(link::up_key(run_id, &h.name))
        .callback(move |sample| {
            // A full share drops the message before it is even decoded; its kind is its
            // first byte.
            let first = sample.payload().slices().next().and_then(|b| b.first());
            let Some(slot) = mine.take(first.is_some_and(|&k| Up::is_resent(k))) else {
                return;
            };
            let bytes = sample.payload().to_bytes();
            let heard = match Up::decode(&bytes, max) {
                Ok(msg) => Heard::Up {
                    host: i,
                    msg,
                    bytes: bytes.len(),
                    slot,
                },
                Err(_) => Heard::Malformed { host: i, slot },
            };
            // Cannot be full (see above); disconnected means the world is gone.
            let _ = tx.try_send(heard);
        })
        .wait()?;
    let remote = Remote {
        robots: h.robots.clone(),
        down,
    };
    Ok((remote, sub, share))
}

/// Tells the world once when a host's liveliness token goes (the host lost), in a place of
/// its own in the queue: a host's flood cannot crowd out its loss.
fn watch_liveliness(
    session: &zenoh::Session,
    file: &HostsFile,
    run_id: &str,
    tx: Sender<Heard>,
    shares: Vec<Arc<Share>>,
) -> Result<zenoh::pubsub::Subscriber<()>, LinkError> {
    let names: Vec<String> = file
        .hosts
        .iter()
        .map(|h| link::host_token(run_id, &h.name))
        .collect();
    session
        .liveliness()
        .declare_subscriber(format!("swarmrt/{run_id}/alive/*"))
        .callback(move |sample| {
            if sample.kind() == SampleKind::Delete
                && let Some(host) = names.iter().position(|n| n == sample.key_expr().as_str())
                && !shares[host].lost.swap(true, Ordering::AcqRel)
            {
                let _ = tx.try_send(Heard::Lost { host });
            }
        })
        .wait()
}

impl WorldLink {
    /// Listens on the file's endpoint and declares every host's ports. Messages from hosts
    /// arrive on the returned receiver.
    pub fn open(file: &HostsFile, run_id: &str) -> Result<(WorldLink, Receiver<Heard>), LinkError> {
        let largest = file.hosts.iter().map(|h| h.robots.len()).max().unwrap_or(0);
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
        // Never full: every message in it holds a place in its host's share.
        let (tx, rx) = crossbeam_channel::bounded(queue_capacity(file));
        let mut hosts = Vec::new();
        let mut subscribers = Vec::new();
        let mut shares = Vec::new();
        for (i, h) in file.hosts.iter().enumerate() {
            let (remote, sub, share) = declare_host(&session, run_id, i, h, tx.clone())?;
            hosts.push(remote);
            subscribers.push(sub);
            shares.push(share);
        }
        let liveliness = watch_liveliness(&session, file, run_id, tx, shares.clone())?;
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
                quota: host_quota(h.robots.len()),
                ..HostTraffic::default()
            })
            .collect();
        Ok((
            WorldLink {
                hosts,
                traffic,
                shares,
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

    /// Counts a resend asked of `host`.
    pub fn count_resend(&mut self, host: usize) {
        self.traffic[host].resends += 1;
    }

    /// Counts robots of `host` whose message a resend delivered.
    pub fn count_recovered(&mut self, host: usize, robots: u64) {
        self.traffic[host].recovered += robots;
    }

    /// Messages of `host` dropped so far (its share was full).
    pub fn dropped(&self, host: usize) -> u64 {
        self.shares[host].dropped.load(Ordering::Relaxed)
    }

    /// Traffic so far, per host.
    pub fn traffic(&mut self) -> &[HostTraffic] {
        for (t, s) in self.traffic.iter_mut().zip(&self.shares) {
            t.dropped = s.dropped.load(Ordering::Relaxed);
        }
        &self.traffic
    }

    /// Closes the session (the hosts see the world's token vanish).
    pub fn close(self) {
        let WorldLink { session, .. } = self;
        let _ = session.close().wait();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_host_is_asked_only_after_its_own_drops_while_the_world_waits_for_it() {
        let t0 = Instant::now();
        let mut r = Resends::new(2);
        // Drops while the world waited for nothing of host 0 are not asked about.
        assert!(!r.due(0, 5, false, t0));
        assert!(!r.due(0, 5, true, t0));
        // A drop while it waits: asked at once; host 1, without drops, never.
        assert!(r.due(0, 6, true, t0));
        assert!(!r.due(1, 0, true, t0));
        assert_eq!(r.next(), None);
        // More drops soon after: held back, and the world is told when to look again.
        let soon = t0 + RESEND_EVERY / 2;
        assert!(!r.due(0, 9, true, soon));
        assert_eq!(r.next(), Some(t0 + RESEND_EVERY));
        assert!(r.due(0, 9, true, t0 + RESEND_EVERY));
        assert_eq!(r.next(), None);
        // Nothing new dropped: no ask, however long the wait.
        assert!(!r.due(0, 9, true, t0 + 10 * RESEND_EVERY));
        // Held back, then the world stopped waiting: nothing is owed any more.
        let t1 = t0 + 20 * RESEND_EVERY;
        assert!(r.due(0, 10, true, t1));
        assert!(!r.due(0, 11, true, t1));
        assert!(!r.due(0, 12, false, t1));
        assert_eq!(r.next(), None);
        assert!(!r.due(0, 12, true, t1 + RESEND_EVERY));
    }
}
