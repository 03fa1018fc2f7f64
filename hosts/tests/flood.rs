//! A flood at the world's end of the link stays bounded: oversized messages never reach the
//! world (Zenoh drops them at `link::max_message_size`), and past the queue's capacity
//! messages are dropped and counted instead of queued. The link still works afterwards.

use std::time::{Duration, Instant};

use swarmrt_hosts::HostsFile;
use swarmrt_hosts::link;
use swarmrt_hosts::wire::Up;
use swarmrt_hosts::world_side::{Heard, WorldLink, queue_capacity};
use zenoh::Wait;

mod support;
use support::free_port;

#[test]
fn a_flood_is_dropped_and_counted_and_oversized_messages_never_arrive() {
    let port = free_port();
    let text = format!(
        "[world]\nlisten = \"tcp/127.0.0.1:{port}\"\n[[host]]\nname = \"a\"\nlauncher = [\"sh\"]\nrobots = 2\n"
    );
    let hosts = HostsFile::parse("hosts.toml", &text, 4).unwrap();
    let run_id = "f100d";
    let (mut world, heard) = WorldLink::open(&hosts, run_id).unwrap();
    let capacity = queue_capacity(1, 2);
    assert_eq!(heard.capacity(), Some(capacity));

    let host =
        link::host_session(&format!("tcp/127.0.0.1:{port}"), 2, link::Tls::Insecure).unwrap();
    let up = host
        .declare_publisher(link::up_key(run_id, "a"))
        .congestion_control(zenoh::qos::CongestionControl::Block)
        .wait()
        .unwrap();
    // Let the world's subscriber become known to the host.
    std::thread::sleep(Duration::from_millis(500));
    let bound = link::max_message_size(2);
    for _ in 0..5 {
        up.put(vec![0xAB; 2 * bound]).wait().unwrap();
    }
    let flood = 3 * capacity;
    for _ in 0..flood {
        up.put(Up::Bye.encode()).wait().unwrap();
    }
    // Wait until everything sent has been either queued or dropped.
    let since = Instant::now();
    while heard.len() + (world.traffic()[0].dropped as usize) < flood
        && since.elapsed() < Duration::from_secs(20)
    {
        std::thread::sleep(Duration::from_millis(50));
    }
    assert!(heard.len() <= capacity, "queue grew past its bound");
    let dropped = world.traffic()[0].dropped;
    assert!(dropped > 0, "a flood past the capacity must be dropped");
    assert_eq!(
        heard.len() + dropped as usize,
        flood,
        "every small message queued or counted"
    );
    let mut got = 0;
    while let Ok(h) = heard.try_recv() {
        match h {
            Heard::Up { bytes, .. } => {
                assert!(
                    bytes < bound,
                    "an oversized message of {bytes} bytes arrived"
                );
                got += 1;
            }
            Heard::Malformed { .. } => panic!("the oversized messages must never arrive"),
            Heard::Lost { .. } => panic!("the host was not lost"),
        }
    }
    assert_eq!(got, capacity);
    // The link still works after the flood.
    up.put(Up::Bye.encode()).wait().unwrap();
    let h = heard.recv_timeout(Duration::from_secs(5)).unwrap();
    assert!(matches!(h, Heard::Up { msg: Up::Bye, .. }));
    drop(up);
    let _ = host.close().wait();
    world.close();
}
