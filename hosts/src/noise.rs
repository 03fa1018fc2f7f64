//! Refused TLS handshakes on the world's port, counted and summarised instead of printed one
//! by one. Zenoh 1.10 logs every failed QUIC handshake as a warning of its own (with a hint
//! about open-file limits that does not apply), so anyone who reaches the port could fill the
//! user's terminal. [`QuietHandshakes`] is a `tracing` layer that swallows those warnings,
//! counts them ([`refused`], `metrics.json` -> `shell.tls`) and writes one line at most once
//! per [`SUMMARY_EVERY`]: the first refusal at once, later ones as a count.
//!
//! Zenoh does not say which address a refused handshake came from, so the limit is one line
//! per interval for all peers together, never one per peer.

use std::fmt::Write as _;
use std::io::Write as _;
use std::sync::Mutex;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::{Duration, Instant};

use serde::Serialize;
use tracing::{Event, Level, Metadata, Subscriber};
use tracing_subscriber::fmt::MakeWriter;
use tracing_subscriber::fmt::time::{FormatTime, SystemTime};
use tracing_subscriber::layer::{Context, Layer};
use tracing_subscriber::registry::LookupSpan;

/// At most one line about refused handshakes per this long.
pub const SUMMARY_EVERY: Duration = Duration::from_secs(60);

/// Handshakes refused in this process so far.
static REFUSED: AtomicU64 = AtomicU64::new(0);
/// Lines written about them.
static LINES: AtomicU64 = AtomicU64::new(0);

/// What `metrics.json` says about refused handshakes (`shell.tls`).
#[derive(Debug, Default, Clone, Copy, PartialEq, Eq, Serialize)]
pub struct Refusals {
    /// TLS handshakes on the world's port that failed (no certificate, one of another CA,
    /// garbage): strangers, or hosts with the wrong files.
    pub refused: u64,
    /// Lines logged about them (at most one per [`SUMMARY_EVERY`]).
    pub lines: u64,
}

/// Handshakes refused in this process so far, and the lines logged about them.
pub fn refused() -> Refusals {
    Refusals {
        refused: REFUSED.load(Ordering::Relaxed),
        lines: LINES.load(Ordering::Relaxed),
    }
}

/// When to write a line (pure: the caller passes the time).
#[derive(Debug, Default)]
pub struct Summary {
    /// When the last line was written.
    at: Option<Instant>,
    /// Refusals since then, not yet in a line.
    unsaid: u64,
}

impl Summary {
    /// One more refusal at `now`: `Some(n)` when a line is due now, saying `n` refusals
    /// (the first ever at once, then at most one line per [`SUMMARY_EVERY`]).
    pub fn refused(&mut self, now: Instant) -> Option<u64> {
        self.unsaid += 1;
        if self.at.is_some_and(|t| now < t + SUMMARY_EVERY) {
            return None;
        }
        self.at = Some(now);
        Some(std::mem::take(&mut self.unsaid))
    }
}

/// True for zenoh's warning about one failed QUIC accept (a failed TLS handshake).
fn is_refusal(meta: &Metadata<'_>) -> bool {
    meta.target().starts_with("zenoh_link_commons::quic")
        && (*meta.level() == Level::WARN || *meta.level() == Level::ERROR)
}

/// The event's message.
#[derive(Default)]
struct Message(String);

impl tracing::field::Visit for Message {
    fn record_debug(&mut self, field: &tracing::field::Field, value: &dyn std::fmt::Debug) {
        if field.name() == "message" {
            let _ = write!(self.0, "{value:?}");
        }
    }
}

/// Why rustls refused, out of zenoh's message: the `reason` quinn carries, else the text
/// before zenoh's source location.
fn reason(message: &str) -> String {
    let after = message
        .split_once("reason: b\"")
        .or_else(|| message.split_once("reason: \""));
    match after.and_then(|(_, r)| r.split_once('"')) {
        Some((r, _)) => r.to_string(),
        None => message
            .split(" at ")
            .next()
            .unwrap_or(message)
            .trim()
            .to_string(),
    }
}

/// The layer to add to a subscriber: [`QuietHandshakes`] writing to `writer`, seeing only
/// zenoh's QUIC accept warnings (so it costs nothing elsewhere and hides nothing else).
pub fn layer<S, W>(writer: W) -> impl Layer<S>
where
    S: Subscriber + for<'a> LookupSpan<'a>,
    W: for<'w> MakeWriter<'w> + Send + Sync + 'static,
{
    QuietHandshakes::new(writer).with_filter(tracing_subscriber::filter::filter_fn(|meta| {
        is_refusal(meta)
    }))
}

/// Swallows zenoh's per-handshake warnings, counts them, and writes a summary line to `W`
/// at most once per [`SUMMARY_EVERY`]. Use it through [`layer`], which filters what it sees.
pub struct QuietHandshakes<W> {
    writer: W,
    summary: Mutex<Summary>,
}

impl<W> QuietHandshakes<W> {
    /// Summary lines go to `writer` (stderr in the world).
    pub fn new(writer: W) -> QuietHandshakes<W> {
        QuietHandshakes {
            writer,
            summary: Mutex::new(Summary::default()),
        }
    }
}

impl<S, W> Layer<S> for QuietHandshakes<W>
where
    S: Subscriber,
    W: for<'w> MakeWriter<'w> + 'static,
{
    /// Disables a refusal's event for every layer (no line of zenoh's reaches the terminal)
    /// and counts it instead.
    fn event_enabled(&self, event: &Event<'_>, _: Context<'_, S>) -> bool {
        if !is_refusal(event.metadata()) {
            return true;
        }
        let mut m = Message::default();
        event.record(&mut m);
        if !m.0.contains("QUIC acceptor failed") && !m.0.contains("Cannot accept QUIC") {
            return true;
        }
        REFUSED.fetch_add(1, Ordering::Relaxed);
        let due = match self.summary.lock() {
            Ok(mut s) => s.refused(Instant::now()),
            Err(_) => None,
        };
        if let Some(n) = due {
            LINES.fetch_add(1, Ordering::Relaxed);
            let mut line = String::new();
            let _ = SystemTime
                .format_time(&mut tracing_subscriber::fmt::format::Writer::new(&mut line));
            let what = if n == 1 && LINES.load(Ordering::Relaxed) == 1 {
                "refused a TLS handshake on the hosts' port".to_string()
            } else {
                format!(
                    "refused {n} TLS handshakes on the hosts' port in the last {} s",
                    SUMMARY_EVERY.as_secs()
                )
            };
            let _ = writeln!(
                line,
                "  WARN swarmrt_hosts::noise: {what} (last: {}); a peer without a certificate of the run's CA, counted in metrics.json shell.tls and logged at most once a minute",
                reason(&m.0)
            );
            let _ = self.writer.make_writer().write_all(line.as_bytes());
        }
        false
    }
}

/// The world's logging: what `swarmrt_scenario::process::init_logging` sets up (`RUST_LOG`,
/// default `warn`, to stderr), plus [`QuietHandshakes`], which counts refused handshakes
/// whatever `RUST_LOG` says.
pub fn init_logging() {
    use tracing_subscriber::prelude::*;
    let filter = tracing_subscriber::EnvFilter::try_from_default_env()
        .unwrap_or_else(|_| tracing_subscriber::EnvFilter::new("warn"));
    tracing_subscriber::registry()
        .with(
            tracing_subscriber::fmt::layer()
                .with_writer(std::io::stderr)
                .with_filter(filter),
        )
        .with(layer(std::io::stderr))
        .init();
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_first_refusal_is_said_at_once_then_one_line_a_minute() {
        let t0 = Instant::now();
        let mut s = Summary::default();
        assert_eq!(s.refused(t0), Some(1));
        for k in 1..100 {
            assert_eq!(s.refused(t0 + Duration::from_millis(k * 100)), None);
        }
        assert_eq!(s.refused(t0 + SUMMARY_EVERY), Some(100));
        assert_eq!(s.refused(t0 + SUMMARY_EVERY + Duration::from_secs(1)), None);
    }

    #[test]
    fn the_reason_is_the_one_quinn_gives() {
        let m = r#"QUIC acceptor failed: TransportError(Error { code: Code::crypto(74), frame: None, reason: "peer sent no certificates" }) at /x/unicast.rs:686. Hint: increase the system open file limit."#;
        assert_eq!(reason(m), "peer sent no certificates");
        let m = r#"QUIC acceptor failed: ConnectionClosed(ConnectionClose { error_code: Code::crypto(33), frame_type: None, reason: b"invalid peer certificate: BadSignature" }) at /x:686."#;
        assert_eq!(reason(m), "invalid peer certificate: BadSignature");
        assert_eq!(
            reason("QUIC acceptor failed: TimedOut at /x:686."),
            "QUIC acceptor failed: TimedOut"
        );
    }
}
