//! One logging setup for the three binaries: `tracing` to stderr, filtered by `RUST_LOG`
//! (default `warn`), so the world's stdout stays free for its reports to the orchestrator.

/// Installs the subscriber; call once at the start of `main`.
pub fn init() {
    tracing_subscriber::fmt()
        .with_env_filter(
            tracing_subscriber::EnvFilter::try_from_default_env()
                .unwrap_or_else(|_| tracing_subscriber::EnvFilter::new("warn")),
        )
        .with_writer(std::io::stderr)
        .init();
}
