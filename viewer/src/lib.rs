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
//!   embedded in the binary: building needs no JavaScript toolchain).
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

mod agent_overlay;
mod assets;
pub mod events;
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

    /// Serves the run in `dir` on a socket from [`Viewer::bind`].
    pub fn serve(dir: &Path, socket: std::net::TcpListener) -> Result<Viewer, ViewError> {
        let run = run::Run::open(dir)?;
        let bound = socket.local_addr().map_err(ViewError::Start)?;
        let host = match bound.ip() {
            IpAddr::V6(ip) => format!("[{ip}]"),
            ip => ip.to_string(),
        };
        let url = format!("http://{host}:{}/", bound.port());
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
                    let listener = match tokio::net::TcpListener::from_std(socket) {
                        Ok(l) => l,
                        Err(e) => {
                            tracing::error!("viewer: {e}");
                            return;
                        }
                    };
                    tokio::select! {
                        r = axum::serve(listener, app) => {
                            if let Err(e) = r {
                                tracing::error!("viewer: {e}");
                            }
                        }
                        _ = stopped => {}
                    }
                });
                // Live streams never end on their own: do not wait for them.
                runtime.shutdown_timeout(Duration::from_millis(200));
            })
            .map_err(ViewError::Start)?;
        Ok(Viewer {
            url,
            stop: Some(stop),
            thread: Some(thread),
        })
    }

    /// The page's address.
    pub fn url(&self) -> &str {
        &self.url
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

impl Drop for Viewer {
    fn drop(&mut self) {
        self.shutdown();
    }
}
