//! Accepting the page's connections within bounds, so another local user who opens many of
//! them, or sends half a request and waits, can neither exhaust the viewer's file
//! descriptors nor keep its owner out:
//!
//! - at most [`MAX_CONNECTIONS`] are open at once. A connection beyond them takes the place
//!   of the one that has waited longest for a request (idle, or its header still arriving),
//!   or, if every one is busy, of the oldest; a newcomer is never refused;
//! - a request's header must arrive within [`HEADER_TIMEOUT`] of the connection opening, or
//!   of the previous answer on it (hyper's header timer); otherwise the connection is closed;
//! - every request passes [`Access::check`] before it is routed.

use std::collections::BTreeMap;
use std::convert::Infallible;
use std::future::Future;
use std::pin::Pin;
use std::sync::{Arc, Mutex};
use std::task::{Context, Poll};
use std::time::{Duration, Instant};

use axum::Router;
use axum::body::{Body, Bytes};
use axum::http::{HeaderValue, Request, Response, header};
use axum::response::IntoResponse;
use hyper::body::{Body as HttpBody, Incoming};
use hyper_util::rt::{TokioIo, TokioTimer};
use hyper_util::service::TowerToHyperService;
use tokio::sync::{Notify, Semaphore};

use crate::access::{Access, Verdict};

/// Connections open at once. A page uses about seven (a browser opens at most six per
/// host, plus its live stream); the rest is room for a few tabs.
pub const MAX_CONNECTIONS: usize = 64;
/// How long a request's header may take to arrive.
pub const HEADER_TIMEOUT: Duration = Duration::from_secs(5);
/// How long to wait before accepting again after `accept` failed (out of descriptors).
const ACCEPT_BACKOFF: Duration = Duration::from_millis(100);

/// One open connection, as the accept loop sees it.
struct Conn {
    state: Mutex<ConnState>,
    /// Told to close.
    close: Notify,
}

struct ConnState {
    /// Requests being answered (a live stream is answered for as long as it is open).
    busy: u32,
    /// Since when it has waited for a request (when `busy` is 0), or since it opened.
    since: Instant,
}

impl Conn {
    fn state(&self) -> std::sync::MutexGuard<'_, ConnState> {
        self.state.lock().unwrap_or_else(|p| p.into_inner())
    }
}

/// The open connections, by the order they were accepted.
#[derive(Default)]
struct Registry {
    next: u64,
    open: BTreeMap<u64, Arc<Conn>>,
}

impl Registry {
    fn lock(this: &Mutex<Registry>) -> std::sync::MutexGuard<'_, Registry> {
        this.lock().unwrap_or_else(|p| p.into_inner())
    }

    /// Tells the connection that has waited longest for a request (or, if all are busy, the
    /// oldest) to close; false when none is open.
    fn evict(&mut self) -> bool {
        let idle = self
            .open
            .iter()
            .filter_map(|(id, c)| {
                let s = c.state();
                (s.busy == 0).then_some((s.since, *id))
            })
            .min()
            .map(|(_, id)| id);
        let Some(id) = idle.or_else(|| self.open.keys().next().copied()) else {
            return false;
        };
        if let Some(conn) = self.open.remove(&id) {
            conn.close.notify_one();
        }
        true
    }
}

/// Serves `router` on `listener` under the bounds above until `stop` fires.
pub async fn serve(
    listener: tokio::net::TcpListener,
    access: Arc<Access>,
    router: Router,
    stop: tokio::sync::oneshot::Receiver<()>,
) {
    let slots = Arc::new(Semaphore::new(MAX_CONNECTIONS));
    let registry = Arc::new(Mutex::new(Registry::default()));
    let accept = async {
        let mut warned = false;
        loop {
            let stream = match listener.accept().await {
                Ok((stream, _)) => stream,
                Err(e) => {
                    if !warned {
                        tracing::warn!("viewer: cannot accept a connection: {e}");
                        warned = true;
                    }
                    tokio::time::sleep(ACCEPT_BACKOFF).await;
                    continue;
                }
            };
            let permit = match slots.clone().try_acquire_owned() {
                Ok(p) => p,
                Err(_) => {
                    // Full: make room, and wait until the one told to close has closed, so
                    // the descriptors in use never pass the bound.
                    if !Registry::lock(&registry).evict() {
                        continue;
                    }
                    match slots.clone().acquire_owned().await {
                        Ok(p) => p,
                        Err(_) => return,
                    }
                }
            };
            let conn = Arc::new(Conn {
                state: Mutex::new(ConnState {
                    busy: 0,
                    since: Instant::now(),
                }),
                close: Notify::new(),
            });
            let id = {
                let mut r = Registry::lock(&registry);
                r.next += 1;
                let id = r.next;
                r.open.insert(id, conn.clone());
                id
            };
            let service = Guarded {
                access: access.clone(),
                inner: TowerToHyperService::new(router.clone()),
                conn: conn.clone(),
            };
            let registry = registry.clone();
            tokio::spawn(async move {
                let http = hyper::server::conn::http1::Builder::new()
                    .timer(TokioTimer::new())
                    .header_read_timeout(HEADER_TIMEOUT)
                    .serve_connection(TokioIo::new(stream), service);
                tokio::select! {
                    r = http => {
                        if let Err(e) = r {
                            tracing::debug!("viewer: connection closed: {e}");
                        }
                    }
                    _ = conn.close.notified() => {}
                }
                Registry::lock(&registry).open.remove(&id);
                drop(permit);
            });
        }
    };
    tokio::select! {
        _ = accept => {}
        _ = stop => {}
    }
}

/// The router behind the access check, marking its connection busy while it answers.
struct Guarded {
    access: Arc<Access>,
    inner: TowerToHyperService<Router>,
    conn: Arc<Conn>,
}

/// Marks a connection busy while alive; when the last answer on it is done (its body
/// dropped), the connection waits for a request again.
struct Busy(Arc<Conn>);

impl Busy {
    fn new(conn: Arc<Conn>) -> Busy {
        conn.state().busy += 1;
        Busy(conn)
    }
}

impl Drop for Busy {
    fn drop(&mut self) {
        let mut s = self.0.state();
        s.busy = s.busy.saturating_sub(1);
        if s.busy == 0 {
            s.since = Instant::now();
        }
    }
}

/// An answer's body that keeps its connection [`Busy`] until it is sent or dropped.
pub struct Tracked {
    inner: Body,
    _busy: Busy,
}

impl HttpBody for Tracked {
    type Data = Bytes;
    type Error = axum::Error;

    fn poll_frame(
        mut self: Pin<&mut Self>,
        cx: &mut Context<'_>,
    ) -> Poll<Option<Result<hyper::body::Frame<Bytes>, axum::Error>>> {
        Pin::new(&mut self.inner).poll_frame(cx)
    }

    fn is_end_stream(&self) -> bool {
        self.inner.is_end_stream()
    }

    fn size_hint(&self) -> hyper::body::SizeHint {
        self.inner.size_hint()
    }
}

type Answer = Pin<Box<dyn Future<Output = Result<Response<Tracked>, Infallible>> + Send>>;

impl hyper::service::Service<Request<Incoming>> for Guarded {
    type Response = Response<Tracked>;
    type Error = Infallible;
    type Future = Answer;

    fn call(&self, req: Request<Incoming>) -> Answer {
        let busy = Busy::new(self.conn.clone());
        let verdict = self.access.check(req.uri(), req.headers());
        let routed = match verdict {
            Verdict::Refuse(code, line) => {
                let answer = (code, line).into_response();
                return Box::pin(async move { Ok(track(answer, busy)) });
            }
            Verdict::Allow { set_cookie } => (self.inner.call(req), set_cookie),
        };
        Box::pin(async move {
            let (routed, set_cookie) = routed;
            let Ok(mut answer) = routed.await;
            if let Some(value) = set_cookie.and_then(|c| HeaderValue::from_str(&c).ok()) {
                answer.headers_mut().append(header::SET_COOKIE, value);
            }
            Ok(track(answer, busy))
        })
    }
}

fn track(answer: Response<Body>, busy: Busy) -> Response<Tracked> {
    answer.map(|inner| Tracked { inner, _busy: busy })
}
