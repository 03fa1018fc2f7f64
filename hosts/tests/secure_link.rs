//! The link's promises, tested on localhost with the certificates `swarm certs` makes and the
//! world's real session config (`link::world_session` with `link::world_acl`):
//! - a host with its own certificate joins, and both directions and liveliness work;
//! - no certificate, another CA's certificate or plain TCP cannot even connect;
//! - a host with a valid certificate of another name cannot speak for a host it is not:
//!   its samples on that host's up key never reach the world, and it hears nothing of
//!   that host's down key.

use std::path::Path;
use std::time::Duration;

use swarmrt_hosts::link::{self, Tls};
use swarmrt_hosts::wire::{Down, Up};
use swarmrt_hosts::world_side::{Heard, WorldLink};
use swarmrt_hosts::{HostsFile, certs};
use zenoh::Wait;

mod support;
use support::free_port;

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

fn host(dir: &Path, name: &str, port: u16) -> Result<zenoh::Session, link::LinkError> {
    host_within(dir, name, port, link::HOST_CONNECT_TIMEOUT)
}

/// [`host`] for a certificate the world must refuse: it gives up after 3 s, not a host's 10
/// (a refused handshake is retried until the timeout; a valid one completes in milliseconds).
fn refused_host(dir: &Path, name: &str, port: u16) -> Result<zenoh::Session, link::LinkError> {
    host_within(dir, name, port, Duration::from_secs(3))
}

/// Host `name`'s session with its certificate from `dir`, trying for `within`.
fn host_within(
    dir: &Path,
    name: &str,
    port: u16,
    within: Duration,
) -> Result<zenoh::Session, link::LinkError> {
    let ca = certs::ca_cert(dir);
    let (cert, key) = certs::host_pair(dir, name);
    let tls = Tls::Mutual {
        ca: &ca,
        cert: &cert,
        key: &key,
    };
    link::host_session_within(&format!("quic/127.0.0.1:{port}"), 2, tls, within)
}

fn wait_up(heard: &crossbeam_channel::Receiver<Heard>, within: Duration) -> Vec<(usize, Up)> {
    let mut got = Vec::new();
    while let Ok(h) = heard.recv_timeout(within) {
        if let Heard::Up { host, msg, .. } = h {
            got.push((host, msg));
        }
    }
    got
}

#[test]
fn only_the_runs_hosts_connect_and_each_speaks_only_as_itself() {
    let tmp = tempfile::tempdir().unwrap();
    let port = free_port();
    let file = hosts(tmp.path(), port);
    let written = certs::generate(&file, &file.certs).unwrap();
    assert_eq!(
        written.len(),
        2 + 2 + 4,
        "CA, world and two hosts, certificate and key each"
    );
    assert!(certs::check(&file).is_empty(), "{:?}", certs::check(&file));
    let run_id = "5ec";
    let (mut world, heard) = WorldLink::open(&file, run_id).unwrap();

    // Host a, with its own certificate: joins, sends up, hears its down key.
    let a = host(&file.certs, "a", port).expect("host a connects with its certificate");
    let a_up = a
        .declare_publisher(link::up_key(run_id, "a"))
        .wait()
        .unwrap();
    let a_down = a
        .declare_subscriber(link::down_key(run_id, "a"))
        .wait()
        .unwrap();
    std::thread::sleep(Duration::from_millis(500));
    a_up.put(Up::Bye.encode()).wait().unwrap();
    let got = wait_up(&heard, Duration::from_secs(2));
    assert_eq!(
        got,
        vec![(0, Up::Bye)],
        "a's sample reaches the world as a's"
    );
    world.send(0, &Down::Welcome).unwrap();
    let s = a_down.recv_timeout(Duration::from_secs(2)).unwrap();
    assert!(s.is_some(), "the world's sample reaches a");

    // Host b, valid certificate of another name, tries to be a: up and down.
    let b = host(&file.certs, "b", port).expect("host b connects with its certificate");
    let b_as_a = b
        .declare_publisher(link::up_key(run_id, "a"))
        .wait()
        .unwrap();
    let b_spy = b.declare_subscriber("swarmrt/**").wait().unwrap();
    std::thread::sleep(Duration::from_millis(500));
    for _ in 0..5 {
        b_as_a.put(Up::Bye.encode()).wait().unwrap();
    }
    world.send(0, &Down::Welcome).unwrap();
    // a's own traffic meanwhile, which b must not hear (b's session does see its own puts).
    let from_a = Up::Commands(Vec::new()).encode();
    a_up.put(from_a.clone()).wait().unwrap();
    let got = wait_up(&heard, Duration::from_secs(2));
    assert_eq!(
        got,
        vec![(0, Up::Commands(Vec::new()))],
        "only a's sample arrives, none of b's on a's up key"
    );
    let spied: Vec<(String, Vec<u8>)> = b_spy
        .drain()
        .map(|s| {
            (
                s.key_expr().as_str().to_string(),
                s.payload().to_bytes().to_vec(),
            )
        })
        .collect();
    assert!(
        spied
            .iter()
            .all(|(k, p)| !k.ends_with("/host/a/down") && *p != from_a),
        "b heard a's traffic: {spied:?}"
    );
    assert!(
        a_down
            .recv_timeout(Duration::from_secs(2))
            .unwrap()
            .is_some()
    );

    // Strangers: one that trusts the run's CA but has no certificate of its own, then one
    // with a certificate of another CA.
    let mut c = zenoh::Config::default();
    c.insert_json5("mode", "\"client\"").unwrap();
    c.insert_json5("connect/endpoints", &format!("[\"quic/127.0.0.1:{port}\"]"))
        .unwrap();
    c.insert_json5("connect/timeout_ms", "3000").unwrap();
    c.insert_json5("connect/exit_on_failure", "true").unwrap();
    c.insert_json5(
        "transport/link/tls/root_ca_certificate",
        &format!("{:?}", certs::ca_cert(&file.certs).display().to_string()),
    )
    .unwrap();
    assert!(
        zenoh::open(c).wait().is_err(),
        "a client without a certificate must not connect"
    );
    let other = tempfile::tempdir().unwrap();
    let other_file = hosts(other.path(), port);
    certs::generate(&other_file, &other_file.certs).unwrap();
    assert!(
        refused_host(&other_file.certs, "a", port).is_err(),
        "a certificate of another CA, even naming a, must not connect"
    );
    // What another CA signed is reported by swarm check.
    std::fs::copy(
        certs::host_pair(&other_file.certs, "a").0,
        certs::host_pair(&file.certs, "a").0,
    )
    .unwrap();
    let problems = certs::check(&file);
    assert!(
        problems
            .iter()
            .any(|p| p.contains("host-a.pem") && p.contains("not signed by the run's CA"))
            && problems
                .iter()
                .any(|p| p.contains("host-a.key") && p.contains("is not the key")),
        "{problems:?}"
    );

    let _ = a.close().wait();
    let _ = b.close().wait();
    world.close();
}

#[test]
fn swarm_certs_never_overwrites_and_writes_keys_private() {
    use std::os::unix::fs::PermissionsExt;
    let tmp = tempfile::tempdir().unwrap();
    let file = hosts(tmp.path(), 7447);
    certs::generate(&file, &file.certs).unwrap();
    let key = certs::host_pair(&file.certs, "a").1;
    let mode = std::fs::metadata(&key).unwrap().permissions().mode() & 0o777;
    assert_eq!(mode, 0o600, "{}", key.display());
    let before = std::fs::read(&key).unwrap();
    let err = certs::generate(&file, &file.certs).unwrap_err().to_string();
    assert!(err.contains("ca.pem") && err.contains("exists"), "{err}");
    assert_eq!(std::fs::read(&key).unwrap(), before);
    // A certificate naming the wrong host, or an address hosts do not connect to.
    std::fs::copy(
        certs::host_pair(&file.certs, "b").0,
        certs::host_pair(&file.certs, "a").0,
    )
    .unwrap();
    let problems = certs::check(&file);
    assert!(
        problems
            .iter()
            .any(|p| p.contains("host-a.pem") && p.contains("names \"b\", expected \"a\"")),
        "{problems:?}"
    );
    let moved = HostsFile::parse(
        tmp.path().join("hosts.toml").to_str().unwrap(),
        &std::fs::read_to_string(tmp.path().join("hosts.toml"))
            .unwrap()
            .replace("127.0.0.1", "10.9.9.9"),
        4,
    )
    .unwrap();
    assert!(
        certs::check(&moved)
            .iter()
            .any(|p| p.contains("world.pem") && p.contains("10.9.9.9")),
    );
}

/// The names in the certificates directory, sorted.
fn listing(dir: &Path) -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    names
}

/// Issue 48: a link planted at `ca.key` was refused with a bare "File exists" after `ca.pem`
/// had been written. Every target is checked first: a link or a taken name anywhere in the
/// set refuses the whole set in one line naming it, and nothing new is left behind.
#[test]
fn a_planted_link_or_a_taken_name_makes_swarm_certs_write_nothing() {
    let tmp = tempfile::tempdir().unwrap();
    let file = hosts(tmp.path(), 7447);
    std::fs::create_dir(&file.certs).unwrap();
    let victim = tmp.path().join("victim");
    std::fs::write(&victim, "the victim's own file\n").unwrap();
    let planted = file.certs.join("ca.key");
    std::os::unix::fs::symlink(&victim, &planted).unwrap();
    let err = certs::generate(&file, &file.certs).unwrap_err().to_string();
    assert!(
        err.contains(&planted.display().to_string())
            && err.contains("is a symbolic link")
            && !err.contains('\n'),
        "{err}"
    );
    assert_eq!(
        listing(&file.certs),
        vec!["ca.key"],
        "something was written"
    );
    assert_eq!(
        std::fs::read_to_string(&victim).unwrap(),
        "the victim's own file\n"
    );
    assert!(
        std::fs::symlink_metadata(&planted)
            .unwrap()
            .file_type()
            .is_symlink()
    );

    // The last name of the set taken by a file: still nothing written, the file unchanged.
    std::fs::remove_file(&planted).unwrap();
    let taken = certs::host_pair(&file.certs, "b").1;
    std::fs::write(&taken, "mine\n").unwrap();
    let err = certs::generate(&file, &file.certs).unwrap_err().to_string();
    assert!(
        err.contains(&taken.display().to_string()) && err.contains("exists"),
        "{err}"
    );
    assert_eq!(listing(&file.certs), vec!["host-b.key"]);
    assert_eq!(std::fs::read_to_string(&taken).unwrap(), "mine\n");

    // Free names: the whole set, and no directory of the work left beside it.
    std::fs::remove_file(&taken).unwrap();
    let written = certs::generate(&file, &file.certs).unwrap();
    assert_eq!(written.len(), 8);
    assert_eq!(listing(&file.certs).len(), 8, "{:?}", listing(&file.certs));
}
