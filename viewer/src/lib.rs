//! `swarm view`: a run replayed, or followed while it goes, in the browser.
//!
//! The viewer reads only what a run records (`config.toml`, `trajectory.csv`,
//! `events.jsonl`, the opt-in `radio.csv`), so a live view and a replay are one code path and
//! the world's loop is untouched: attaching a viewer changes no record byte.
//!
//! - `run.rs`: a run directory, its metadata and whether it is live, finished or crashed;
//! - `trajectory.rs`, `events.rs`, `radio.rs`: each record read as it grows, the trajectory
//!   packed as binary frames;
//! - `overlay.rs` and `agent_overlay.rs`: what a behaviour's notes mean (roles, headlines,
//!   consensus lanes), answered by the behaviour's own folder;
//! - `server.rs`: the HTTP routes; `assets/` the page (plain HTML, CSS and JavaScript,
//!   embedded in the binary: building needs no JavaScript toolchain);
//! - `access.rs`: who may ask (the `Host` must name the viewer, no other origin, a token
//!   beyond loopback); `conns.rs`: connections accepted within bounds (how many, how long a
//!   header may take);
//! - `files.rs` and `tail.rs`: a run directory's files opened without following a FIFO, a
//!   device or a link, and read once each, holding at most a bounded piece of a line.
//!
//! ```no_run
//! let viewer = swarmrt_viewer::Viewer::start(
//!     std::path::Path::new("runs/goto_simple-s1-20261127-120000"),
//!     &swarmrt_viewer::Listen::default(),
//! )?;
//! println!("{}", viewer.url());
//! # Ok::<(), swarmrt_viewer::ViewError>(())
//! ```
#![warn(missing_docs)]

pub mod access;
mod agent_overlay;
mod assets;
pub mod conns;
pub mod events;
pub mod files;
pub mod overlay;
pub mod radio;
pub mod run;
pub mod server;
mod tail;
pub mod trajectory;

use std::net::{IpAddr, Ipv4Addr, SocketAddr};
use std::path::Path;
use std::time::Duration;

/// Why the viewer cannot show a run.
#[derive(Debug, thiserror::Error)]
pub enum ViewError {
    /// The directory is not a run directory, or its config does not load.
    #[error("{0}")]
    NotARun(String),
    /// The port is taken.
    #[error(
        "cannot listen on {0}: the address is in use (choose another --port, or 0 for a free one)"
    )]
    InUse(SocketAddr),
    /// The address cannot be listened on.
    #[error("cannot listen on {0}: {1}")]
    Listen(SocketAddr, std::io::Error),
    /// The server thread could not be started.
    #[error("cannot start the viewer: {0}")]
    Start(std::io::Error),
}

/// Where the page is served.
#[derive(Debug, Clone, Copy)]
pub struct Listen {
    /// Address; loopback unless the user names another.
    pub ip: IpAddr,
    /// Port; 0 picks a free one.
    pub port: u16,
}

impl Default for Listen {
    fn default() -> Self {
        Listen {
            ip: IpAddr::V4(Ipv4Addr::LOCALHOST),
            port: 0,
        }
    }
}

/// A running viewer: its server lives on its own thread until [`Viewer::stop`] or drop.
pub struct Viewer {
    url: String,
    token: Option<String>,
    stop: Option<tokio::sync::oneshot::Sender<()>>,
    thread: Option<std::thread::JoinHandle<()>>,
}

impl Viewer {
    /// Opens the run in `dir` and serves its page; returns once the port is listening.
    pub fn start(dir: &Path, listen: &Listen) -> Result<Viewer, ViewError> {
        Viewer::serve(dir, Viewer::bind(listen)?)
    }

    /// Takes the port first (so `swarm run --view` can refuse a port in use before it
    /// writes anything).
    pub fn bind(listen: &Listen) -> Result<std::net::TcpListener, ViewError> {
        let addr = SocketAddr::new(listen.ip, listen.port);
        let socket = std::net::TcpListener::bind(addr).map_err(|e| match e.kind() {
            std::io::ErrorKind::AddrInUse => ViewError::InUse(addr),
            _ => ViewError::Listen(addr, e),
        })?;
        socket
            .set_nonblocking(true)
            .map_err(|e| ViewError::Listen(addr, e))?;
        Ok(socket)
    }

    /// Serves the run in `dir` on a socket from [`Viewer::bind`]. Beyond loopback every
    /// request must carry a fresh random token, which [`Viewer::url`] includes.
    pub fn serve(dir: &Path, socket: std::net::TcpListener) -> Result<Viewer, ViewError> {
        let run = run::Run::open(dir)?;
        let bound = socket.local_addr().map_err(ViewError::Start)?;
        let token = if bound.ip().is_loopback() {
            None
        } else {
            Some(access::new_token().map_err(ViewError::Start)?)
        };
        let name = access::host_name();
        let access = std::sync::Arc::new(access::Access::new(bound, name.clone(), token.clone()));
        let mut url = format!("http://{}:{}/", shown_host(bound.ip(), name), bound.port());
        if let Some(t) = &token {
            url.push_str(&format!("?token={t}"));
        }
        let runtime = tokio::runtime::Builder::new_multi_thread()
            .worker_threads(2)
            .thread_name("viewer")
            .enable_all()
            .build()
            .map_err(ViewError::Start)?;
        let (stop, stopped) = tokio::sync::oneshot::channel::<()>();
        let thread = std::thread::Builder::new()
            .name("viewer".into())
            .spawn(move || {
                runtime.block_on(async move {
                    let shared = server::shared(run);
                    tokio::spawn(server::refresher(shared.clone()));
                    let app = server::router(shared);
                    match tokio::net::TcpListener::from_std(socket) {
                        Ok(listener) => conns::serve(listener, access, app, stopped).await,
                        Err(e) => tracing::error!("viewer: {e}"),
                    }
                });
                // Live streams never end on their own: do not wait for them.
                runtime.shutdown_timeout(Duration::from_millis(200));
            })
            .map_err(ViewError::Start)?;
        Ok(Viewer {
            url,
            token,
            stop: Some(stop),
            thread: Some(thread),
        })
    }

    /// The page's address (with its token, beyond loopback).
    pub fn url(&self) -> &str {
        &self.url
    }

    /// The token every request must carry, when the viewer listens beyond loopback.
    pub fn token(&self) -> Option<&str> {
        self.token.as_deref()
    }

    /// Stops the server and waits for its thread.
    pub fn stop(mut self) {
        self.shutdown();
    }

    fn shutdown(&mut self) {
        if let Some(stop) = self.stop.take() {
            let _ = stop.send(());
        }
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

/// The host to print in the page's URL: the address itself, or for an unspecified one
/// (0.0.0.0, ::) the address this host reaches the network from, else its name.
fn shown_host(ip: IpAddr, name: Option<String>) -> String {
    let literal = |ip: IpAddr| match ip {
        IpAddr::V6(v6) => format!("[{v6}]"),
        ip => ip.to_string(),
    };
    if !ip.is_unspecified() {
        return literal(ip);
    }
    // Connecting a UDP socket sends nothing: it only asks the routing table which local
    // address would reach a (documentation-range) address beyond this host.
    let routed = |bind: &str, to: &str| {
        let s = std::net::UdpSocket::bind(bind).ok()?;
        s.connect(to).ok()?;
        s.local_addr()
            .ok()
            .map(|a| a.ip())
            .filter(|ip| !ip.is_unspecified())
    };
    routed("0.0.0.0:0", "192.0.2.1:9")
        .or_else(|| {
            ip.is_ipv6()
                .then(|| routed("[::]:0", "[2001:db8::1]:9"))
                .flatten()
        })
        .map(literal)
        .or(name)
        .unwrap_or_else(|| "localhost".to_string())
}

impl Drop for Viewer {
    fn drop(&mut self) {
        self.shutdown();
    }
}
