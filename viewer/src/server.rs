//! The page's small HTTP server: the embedded assets, the run's metadata, its frames and radio
//! traffic as binary chunks, and its status as server-sent events while it is live.

use std::convert::Infallible;
use std::sync::{Arc, Mutex};
use std::time::Duration;

use axum::Router;
use axum::extract::{Query, State};
use axum::http::{StatusCode, header};
use axum::response::sse::{Event, KeepAlive, Sse};
use axum::response::{IntoResponse, Json, Response};
use axum::routing::get;
use serde::Deserialize;
use serde_json::json;
use tokio::sync::watch;

use crate::run::{Run, Status};

/// How often a live run's files are looked at for new ticks (the page follows at most this
/// far behind the world).
const LIVE_REFRESH: Duration = Duration::from_millis(100);
/// How often a finished run's files are looked at (a crashed run's leftovers do not change;
/// a run being restarted into the same directory does).
const IDLE_REFRESH: Duration = Duration::from_millis(1000);

/// Live streams open at once (a page holds one); one more is refused with 503, so streams
/// that never end cannot take every connection ([`crate::conns::MAX_CONNECTIONS`]).
pub const MAX_LIVE_STREAMS: usize = 16;

/// What every request handler shares.
pub struct Shared {
    run: Mutex<Run>,
    status: watch::Sender<Status>,
    live_streams: Arc<tokio::sync::Semaphore>,
}

impl Shared {
    /// The run, locked (a poisoned lock still holds a readable run).
    fn run(&self) -> std::sync::MutexGuard<'_, Run> {
        self.run.lock().unwrap_or_else(|p| p.into_inner())
    }
}

/// Wraps `run` for the handlers.
pub fn shared(run: Run) -> Arc<Shared> {
    let status = run.status();
    Arc::new(Shared {
        run: Mutex::new(run),
        status: watch::Sender::new(status),
        live_streams: Arc::new(tokio::sync::Semaphore::new(MAX_LIVE_STREAMS)),
    })
}

/// Reads the run's new records every [`LIVE_REFRESH`] (while live) and tells the live
/// streams when something changed.
pub async fn refresher(shared: Arc<Shared>) {
    let mut last_error: Option<String> = None;
    loop {
        let s = shared.clone();
        let refreshed = tokio::task::spawn_blocking(move || {
            let mut run = s.run();
            let error = run.refresh().err().map(|e| e.to_string());
            (run.status(), error)
        })
        .await;
        let Ok((status, error)) = refreshed else {
            return;
        };
        // Said once, not every refresh; the page's banner shows it while it lasts.
        if error.is_some() && error != last_error {
            tracing::warn!(
                "cannot read the run's records: {}",
                error.as_deref().unwrap_or("")
            );
        }
        last_error = error;
        let live = status.state == "live";
        shared.status.send_if_modified(|s| {
            if *s != status {
                *s = status;
                true
            } else {
                false
            }
        });
        tokio::time::sleep(if live { LIVE_REFRESH } else { IDLE_REFRESH }).await;
    }
}

/// Every route of the page.
pub fn router(shared: Arc<Shared>) -> Router {
    Router::new()
        .route(
            "/",
            get(|| async { asset("text/html", crate::assets::INDEX) }),
        )
        .route(
            "/viewer.js",
            get(|| async { asset("text/javascript", crate::assets::SCRIPT) }),
        )
        .route(
            "/viewer.css",
            get(|| async { asset("text/css", crate::assets::STYLE) }),
        )
        .route("/api/meta", get(meta))
        .route("/api/status", get(status))
        .route("/api/live", get(live))
        .route("/api/frames", get(frames))
        .route("/api/markers", get(markers))
        .route("/api/lanes", get(lanes))
        .route("/api/robot", get(robot))
        .route("/api/radio/strip", get(radio_strip))
        .route("/api/radio/links", get(radio_links))
        .with_state(shared)
}

fn asset(kind: &'static str, body: &'static str) -> Response {
    (
        [
            (header::CONTENT_TYPE, format!("{kind}; charset=utf-8")),
            (header::CACHE_CONTROL, "no-cache".to_string()),
        ],
        body,
    )
        .into_response()
}

fn binary(bytes: Vec<u8>) -> Response {
    (
        [
            (header::CONTENT_TYPE, "application/octet-stream"),
            (header::CACHE_CONTROL, "no-store"),
        ],
        bytes,
    )
        .into_response()
}

fn failed(e: std::io::Error) -> Response {
    (
        StatusCode::INTERNAL_SERVER_ERROR,
        format!("cannot read the run: {e}"),
    )
        .into_response()
}

async fn meta(State(s): State<Arc<Shared>>) -> Json<crate::run::Meta> {
    Json(s.run().meta.clone())
}

async fn status(State(s): State<Arc<Shared>>) -> Json<Status> {
    Json(s.status.borrow().clone())
}

/// The status now, then each time it changes; the stream ends with the server. At most
/// [`MAX_LIVE_STREAMS`] at once.
async fn live(State(s): State<Arc<Shared>>) -> Response {
    let Ok(slot) = s.live_streams.clone().try_acquire_owned() else {
        return (
            StatusCode::SERVICE_UNAVAILABLE,
            format!("swarm view: {MAX_LIVE_STREAMS} live views are open already"),
        )
            .into_response();
    };
    let rx = s.status.subscribe();
    let stream =
        futures_util::stream::unfold((rx, true, slot), |(mut rx, first, slot)| async move {
            if !first {
                rx.changed().await.ok()?;
            }
            let status = rx.borrow_and_update().clone();
            let event = Event::default()
                .json_data(&status)
                .unwrap_or_else(|_| Event::default().data("{}"));
            Some((Ok::<_, Infallible>(event), (rx, false, slot)))
        });
    Sse::new(stream)
        .keep_alive(KeepAlive::default())
        .into_response()
}

#[derive(Deserialize)]
struct Range {
    from: usize,
    to: usize,
}

/// Runs `f` on the run off the async workers (it reads files), so one large request never
/// stalls the live stream or the refresher.
async fn blocking(s: Arc<Shared>, f: impl FnOnce(&Run) -> Response + Send + 'static) -> Response {
    tokio::task::spawn_blocking(move || f(&s.run()))
        .await
        .unwrap_or_else(|e| {
            (StatusCode::INTERNAL_SERVER_ERROR, format!("viewer: {e}")).into_response()
        })
}

async fn frames(State(s): State<Arc<Shared>>, Query(q): Query<Range>) -> Response {
    blocking(s, move |run| {
        // At most two chunks per request: a client cannot make the server read a whole run.
        let to = q.to.min(q.from.saturating_add(2 * run.meta.chunk_frames));
        match run
            .trajectory
            .frames(q.from, to, |id, tick| run.events.role_at(id, tick))
        {
            Ok(bytes) => binary(bytes),
            Err(e) => failed(e),
        }
    })
    .await
}

#[derive(Deserialize)]
struct From {
    #[serde(default)]
    from: usize,
}

async fn markers(State(s): State<Arc<Shared>>, Query(q): Query<From>) -> Response {
    let run = s.run();
    let m = &run.events.markers;
    Json(&m[q.from.min(m.len())..]).into_response()
}

async fn lanes(State(s): State<Arc<Shared>>, Query(q): Query<From>) -> Response {
    let run = s.run();
    let l = &run.events.lanes;
    Json(&l[q.from.min(l.len())..]).into_response()
}

#[derive(Deserialize)]
struct RobotQuery {
    id: u32,
    frame: usize,
}

async fn robot(State(s): State<Arc<Shared>>, Query(q): Query<RobotQuery>) -> Response {
    blocking(s, move |run| robot_info(run, &q)).await
}

fn robot_info(run: &Run, q: &RobotQuery) -> Response {
    let row = match run.trajectory.row(q.frame, q.id) {
        Ok(Some(row)) => row,
        Ok(None) => {
            return (StatusCode::NOT_FOUND, "no such robot or frame").into_response();
        }
        Err(e) => return failed(e),
    };
    let role = run.events.role_at(q.id, row.tick);
    let role = run.meta.roles.get(role as usize).map(|r| r.name);
    let notes: Vec<_> = run
        .events
        .notes_before(q.id, row.tick, 6)
        .into_iter()
        .map(|(tick, note)| json!({"tick": tick, "note": note}))
        .collect();
    Json(json!({"row": row, "role": role, "notes": notes})).into_response()
}

async fn radio_strip(State(s): State<Arc<Shared>>, Query(q): Query<From>) -> Response {
    let run = s.run();
    if !run.radio.recorded() {
        return (StatusCode::NOT_FOUND, "this run has no radio.csv").into_response();
    }
    Json(run.radio.strip_from(q.from)).into_response()
}

#[derive(Deserialize)]
struct TickRange {
    from: u64,
    to: u64,
}

async fn radio_links(State(s): State<Arc<Shared>>, Query(q): Query<TickRange>) -> Response {
    blocking(s, move |run| {
        // At most two chunks of ticks per request.
        let to =
            q.to.min(q.from.saturating_add(2 * run.meta.chunk_frames as u64));
        match run.radio.links(q.from, to) {
            Ok(bytes) => binary(bytes),
            Err(e) => failed(e),
        }
    })
    .await
}
