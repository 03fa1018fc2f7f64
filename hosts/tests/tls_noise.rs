//! Refused TLS handshakes do not fill the user's terminal: strangers without a certificate
//! and with one of another CA try the world's port again and again, and the log the world
//! sets up (`swarmrt_hosts::noise`) holds one line about them, not one per attempt, while
//! every refusal is counted. Its own test binary: the subscriber is process-wide.

use std::io::Write;
use std::path::Path;
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use swarmrt_hosts::link::{self, Tls};
use swarmrt_hosts::world_side::WorldLink;
use swarmrt_hosts::{HostsFile, certs, noise};
use tracing_subscriber::prelude::*;
use zenoh::Wait;

mod support;
use support::free_port;

/// What the process logged.
#[derive(Clone, Default)]
struct Log(Arc<Mutex<Vec<u8>>>);

impl Write for Log {
    fn write(&mut self, b: &[u8]) -> std::io::Result<usize> {
        self.0.lock().unwrap().extend_from_slice(b);
        Ok(b.len())
    }
    fn flush(&mut self) -> std::io::Result<()> {
        Ok(())
    }
}

impl<'a> tracing_subscriber::fmt::MakeWriter<'a> for Log {
    type Writer = Log;
    fn make_writer(&'a self) -> Log {
        self.clone()
    }
}

impl Log {
    fn lines(&self) -> Vec<String> {
        String::from_utf8_lossy(&self.0.lock().unwrap())
            .lines()
            .map(str::to_string)
            .collect()
    }
}

fn hosts(dir: &Path, port: u16) -> HostsFile {
    let text = format!(
        "[world]\nlisten = \"quic/127.0.0.1:{port}\"\n\
         [[host]]\nname = \"a\"\nlauncher = [\"sh\"]\nrobots = 2\n"
    );
    let path = dir.join("hosts.toml");
    std::fs::write(&path, &text).unwrap();
    HostsFile::parse(path.to_str().unwrap(), &text, 4).unwrap()
}

#[test]
fn refused_handshakes_are_counted_and_logged_in_one_line_a_minute() {
    let log = Log::default();
    // The world's logging (`noise::init_logging`), writing into `log`.
    tracing_subscriber::registry()
        .with(
            tracing_subscriber::fmt::layer()
                .with_writer(log.clone())
                .with_ansi(false)
                .with_filter(tracing_subscriber::EnvFilter::new("warn")),
        )
        .with(noise::layer(log.clone()))
        .init();
    let tmp = tempfile::tempdir().unwrap();
    let port = free_port();
    let file = hosts(tmp.path(), port);
    certs::generate(&file, &file.certs).unwrap();
    let (world, _heard) = WorldLink::open(&file, "7150").unwrap();
    let endpoint = format!("quic/127.0.0.1:{port}");

    // Strangers, each trying for a second: one that trusts the run's CA but has no
    // certificate, one with a certificate of another CA naming host a.
    let other = tempfile::tempdir().unwrap();
    let other_file = hosts(other.path(), port);
    certs::generate(&other_file, &other_file.certs).unwrap();
    for round in 0..2 {
        let mut c = zenoh::Config::default();
        c.insert_json5("mode", "\"client\"").unwrap();
        c.insert_json5("connect/endpoints", &format!("[\"{endpoint}\"]"))
            .unwrap();
        c.insert_json5("connect/timeout_ms", "1000").unwrap();
        c.insert_json5("connect/exit_on_failure", "true").unwrap();
        c.insert_json5(
            "transport/link/tls/root_ca_certificate",
            &format!("{:?}", certs::ca_cert(&file.certs).display().to_string()),
        )
        .unwrap();
        assert!(
            zenoh::open(c).wait().is_err(),
            "round {round}: no certificate got in"
        );
        let ca = certs::ca_cert(&other_file.certs);
        let (cert, key) = certs::host_pair(&other_file.certs, "a");
        let tls = Tls::Mutual {
            ca: &ca,
            cert: &cert,
            key: &key,
        };
        assert!(
            // 3 s, not a host's 10: the refused handshake is retried until the timeout.
            link::host_session_within(&endpoint, 2, tls, Duration::from_secs(3)).is_err(),
            "round {round}: another CA's certificate got in"
        );
    }
    // Every refusal is counted (the strangers' own retries included).
    let since = Instant::now();
    while noise::refused().refused < 4 {
        assert!(
            since.elapsed() < Duration::from_secs(30),
            "refusals not counted: {:?}",
            noise::refused()
        );
        std::thread::sleep(Duration::from_millis(20));
    }
    let counted = noise::refused();
    let lines = log.lines();
    let about: Vec<&String> = lines
        .iter()
        .filter(|l| l.contains("handshake") || l.contains("QUIC acceptor"))
        .collect();
    assert_eq!(
        about.len(),
        1,
        "{} refusals logged as {} lines: {lines:#?}",
        counted.refused,
        about.len()
    );
    assert!(
        about[0].contains("refused a TLS handshake on the hosts' port")
            && about[0].contains("peer sent no certificates")
            && about[0].contains("shell.tls"),
        "{}",
        about[0]
    );
    assert_eq!(counted.lines, 1, "{counted:?}");
    // Nothing else of the world's is hidden: its own warnings still reach the log.
    tracing::warn!("a warning of the world's own");
    assert!(
        log.lines()
            .iter()
            .any(|l| l.contains("a warning of the world's own"))
    );
    world.close();
}
