//! A flood at the world's end of the link stays bounded and stays the flooder's: oversized
//! messages never reach the world (Zenoh drops them at `link::max_message_size`), and a host
//! that sends faster than the world reads has its own messages dropped and counted against
//! it, while another host's messages all arrive. Both hosts hold valid certificates of the
//! run's CA, over the real mutual-TLS session and access control.

use std::path::Path;
use std::time::{Duration, Instant};

use crossbeam_channel::Receiver;
use swarmrt_hosts::link::{self, Tls};
use swarmrt_hosts::wire::Up;
use swarmrt_hosts::world_side::{Heard, WorldLink};
use swarmrt_hosts::{HostsFile, certs};
use zenoh::Wait;

mod support;
use support::free_port;

/// How long any wait of these tests may take before it fails.
const LIMIT: Duration = Duration::from_secs(30);

fn hosts(dir: &Path, port: u16) -> HostsFile {
    let text = format!(
        "[world]\nlisten = \"quic/127.0.0.1:{port}\"\n\
         [[host]]\nname = \"a\"\nlauncher = [\"sh\"]\nrobots = 2\n\
         [[host]]\nname = \"b\"\nlauncher = [\"sh\"]\nrobots = 2\n"
    );
    let path = dir.join("hosts.toml");
    std::fs::write(&path, &text).unwrap();
    HostsFile::parse(path.to_str().unwrap(), &text, 4).unwrap()
}

/// Host `name`'s session with its own certificate, and a publisher on its up key.
fn host(
    file: &HostsFile,
    name: &str,
    port: u16,
) -> (zenoh::Session, zenoh::pubsub::Publisher<'static>) {
    let ca = certs::ca_cert(&file.certs);
    let (cert, key) = certs::host_pair(&file.certs, name);
    let tls = Tls::Mutual {
        ca: &ca,
        cert: &cert,
        key: &key,
    };
    let s = link::host_session(&format!("quic/127.0.0.1:{port}"), 2, tls).unwrap();
    let up = s
        .declare_publisher(link::up_key("f100d", name))
        .congestion_control(zenoh::qos::CongestionControl::Block)
        .wait()
        .unwrap();
    (s, up)
}

/// Sends a `Bye` every 50 ms until the world hears one from host `i`: then the world's
/// subscriber is known to that host. Returns once it is, with the queue empty again.
fn until_heard(up: &zenoh::pubsub::Publisher<'static>, heard: &Receiver<Heard>, i: usize) {
    let since = Instant::now();
    loop {
        up.put(Up::Bye.encode()).wait().unwrap();
        match heard.recv_timeout(Duration::from_millis(50)) {
            Ok(Heard::Up { host, .. }) if host == i => break,
            _ => assert!(since.elapsed() < LIMIT, "host {i} never reached the world"),
        }
    }
    // Byes still on their way.
    while heard.recv_timeout(Duration::from_millis(200)).is_ok() {}
}

/// Waits until `n` messages are queued or counted as dropped.
fn settled(world: &mut WorldLink, heard: &Receiver<Heard>, n: usize) {
    let since = Instant::now();
    loop {
        let dropped: u64 = world.traffic().iter().map(|t| t.dropped).sum();
        if heard.len() + dropped as usize >= n {
            return;
        }
        assert!(
            since.elapsed() < LIMIT,
            "the world never received the flood"
        );
        std::thread::sleep(Duration::from_millis(20));
    }
}

#[test]
fn a_flooding_host_loses_only_its_own_messages_and_is_counted_for_them() {
    let tmp = tempfile::tempdir().unwrap();
    let port = free_port();
    let file = hosts(tmp.path(), port);
    certs::generate(&file, &file.certs).unwrap();
    let (mut world, heard) = WorldLink::open(&file, "f100d").unwrap();
    let (a, a_up) = host(&file, "a", port);
    let (b, b_up) = host(&file, "b", port);
    until_heard(&a_up, &heard, 0);
    until_heard(&b_up, &heard, 1);
    let before = world.traffic().iter().map(|t| t.dropped).sum::<u64>();
    assert_eq!(before, 0);

    // Host a, with its valid certificate, floods valid empty batches on its own key while the
    // world is busy with a tick and reads nothing; oversized messages first.
    let bound = link::max_message_size(2);
    for _ in 0..5 {
        a_up.put(vec![0xAB; 2 * bound]).wait().unwrap();
    }
    let flood = 20_000;
    let empty = Up::Commands(Vec::new()).encode();
    for _ in 0..flood {
        a_up.put(empty.clone()).wait().unwrap();
    }
    settled(&mut world, &heard, flood);
    // Host b answers its tick meanwhile: one batch per robot, say.
    let answers = 10;
    for _ in 0..answers {
        b_up.put(empty.clone()).wait().unwrap();
    }
    settled(&mut world, &heard, flood + answers);

    let t = world.traffic().to_vec();
    assert!(t[0].dropped > 0, "a flood past a's share must be dropped");
    assert_eq!(t[1].dropped, 0, "b lost messages to a's flood: {t:?}");
    let mut got = [0usize; 2];
    while let Ok(h) = heard.try_recv() {
        match h {
            Heard::Up { host, bytes, .. } => {
                assert!(
                    bytes < bound,
                    "an oversized message of {bytes} bytes arrived"
                );
                got[host] += 1;
            }
            Heard::Malformed { .. } => panic!("the oversized messages must never arrive"),
            Heard::Lost { .. } => panic!("no host was lost"),
        }
    }
    assert_eq!(got[1], answers, "every one of b's messages arrives");
    assert_eq!(
        got[0] + t[0].dropped as usize,
        flood,
        "each of a's messages queued or counted against a"
    );
    assert!(
        got[0] < flood / 10,
        "a's queued messages stay bounded: {}",
        got[0]
    );
    // The link still works for both afterwards.
    for (i, up) in [&a_up, &b_up].into_iter().enumerate() {
        up.put(Up::Bye.encode()).wait().unwrap();
        let h = heard.recv_timeout(LIMIT).unwrap();
        assert!(
            matches!(h, Heard::Up { host, msg: Up::Bye, .. } if host == i),
            "{h:?}"
        );
    }
    drop((a_up, b_up));
    let _ = a.close().wait();
    let _ = b.close().wait();
    world.close();
}

/// What the world asked a flooding host to resend has places of its own: with the host's
/// share full of its own flood, its `Resent` answer still reaches the world, so a lost batch
/// costs that host a resend, not its robots.
#[test]
fn a_resend_reaches_the_world_through_a_share_full_of_flood() {
    let tmp = tempfile::tempdir().unwrap();
    let port = free_port();
    let file = hosts(tmp.path(), port);
    certs::generate(&file, &file.certs).unwrap();
    let (mut world, heard) = WorldLink::open(&file, "f100d").unwrap();
    let (a, a_up) = host(&file, "a", port);
    until_heard(&a_up, &heard, 0);
    let flood = 5_000;
    let empty = Up::Commands(Vec::new()).encode();
    for _ in 0..flood {
        a_up.put(empty.clone()).wait().unwrap();
    }
    settled(&mut world, &heard, flood);
    assert!(world.traffic()[0].dropped > 0, "a's share is full");
    let resent = Up::Resent {
        tick: 7,
        answers: vec![(2, swarmrt_protocol::Command::act(2, 7))],
        hellos: Vec::new(),
    };
    a_up.put(resent.encode()).wait().unwrap();
    // Behind a's queued flood, the resend arrives.
    let since = Instant::now();
    loop {
        match heard.recv_timeout(LIMIT) {
            Ok(Heard::Up { msg, .. }) if msg == resent => break,
            Ok(_) => assert!(since.elapsed() < LIMIT),
            Err(_) => panic!("the resend never arrived"),
        }
    }
    drop(a_up);
    let _ = a.close().wait();
    world.close();
}
