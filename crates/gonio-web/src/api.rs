//! The routes: the read-only JSON API, the server-sent events and the pages.

use crate::live::Hub;
use crate::state::{AppState, blocking, error, parse_id};
use crate::{WebError, assets, pages};
use axum::Router;
use axum::body::{Body, Bytes};
use axum::extract::rejection::QueryRejection;
use axum::extract::{Path, Query, State};
use axum::http::{StatusCode, header};
use axum::response::sse::{Event as SseEvent, KeepAlive, Sse};
use axum::response::{Html, IntoResponse, Response};
use axum::routing::get;
use gonio_store::pool::Pool;
use gonio_store::{PartQuery, Store, StoreError};
use serde::Deserialize;
use serde_json::json;
use std::convert::Infallible;
use std::sync::Arc;
use tokio_stream::StreamExt;
use tokio_stream::wrappers::BroadcastStream;
use tokio_stream::wrappers::errors::BroadcastStreamRecvError;

/// Arrays of parts streamed at once; more requests wait their turn.
const MAX_STREAMS: usize = 8;

fn json_response<T: serde::Serialize>(v: &T) -> Response {
    match serde_json::to_string(v) {
        Ok(s) => ([(header::CONTENT_TYPE, "application/json")], s).into_response(),
        Err(e) => error(StatusCode::INTERNAL_SERVER_ERROR, e),
    }
}

/// The query parameters of `/api/parts` (those of `gonio parts`).
#[derive(Debug, Default, Deserialize)]
pub(crate) struct PartsParams {
    since: Option<String>,
    verdict: Option<String>,
    serial: Option<String>,
    batch: Option<i64>,
    limit: Option<usize>,
    /// Only parts with a greater id (paging: the last id already read).
    after: Option<i64>,
    /// Only parts with this id or a smaller one.
    through: Option<i64>,
    /// `summary`: table rows without turns and pushes.
    view: Option<String>,
}

impl PartsParams {
    fn query(&self) -> Result<PartQuery, Box<Response>> {
        let since = match self.since.as_deref().filter(|s| !s.is_empty()) {
            Some(t) => Some(
                gonio_store::time::parse_since(t)
                    .map_err(|e| Box::new(error(StatusCode::BAD_REQUEST, format!("since: {e}"))))?,
            ),
            None => None,
        };
        Ok(PartQuery {
            since,
            verdict: self.verdict.clone().filter(|s| !s.is_empty()),
            serial: self.serial.clone().filter(|s| !s.is_empty()),
            batch: self.batch,
            limit: self.limit,
            after: self.after,
            through: self.through,
            ..PartQuery::default()
        })
    }
}

/// The query string's parameters, or a JSON 400 naming what is wrong with them.
fn params(p: Result<Query<PartsParams>, QueryRejection>) -> Result<PartsParams, Box<Response>> {
    p.map(|Query(p)| p).map_err(|e| {
        Box::new(error(
            StatusCode::BAD_REQUEST,
            format!("query string: {}", e.body_text()),
        ))
    })
}

/// Parts a streamed array reads from the store at a time.
const PAGE_PARTS: usize = 64;

/// Streams a JSON array of the parts matching `q` (`fetch` reads one page: the matching parts
/// with ids in a range), a page at a time: memory holds a page per request, never the store.
/// The query is checked (and the ids listed) before the status is sent, so a bad filter is a
/// JSON 400; a store error later ends the body early (the array is then not closed).
async fn stream_array<T: serde::Serialize + 'static>(
    st: &AppState,
    q: PartQuery,
    fetch: fn(&mut dyn Store, &PartQuery) -> Result<Vec<T>, StoreError>,
) -> Response {
    let Ok(permit) = st.streams.clone().acquire_owned().await else {
        return error(StatusCode::SERVICE_UNAVAILABLE, "shutting down");
    };
    let ids = match blocking(&st.pool, {
        let q = q.clone();
        move |s| s.part_ids(&q)
    })
    .await
    {
        Ok(ids) => ids,
        Err(r) => return r,
    };
    let (tx, rx) = tokio::sync::mpsc::channel::<Result<Bytes, std::io::Error>>(2);
    let pool = st.pool.clone();
    tokio::task::spawn_blocking(move || {
        let _permit = permit;
        if tx.blocking_send(Ok(Bytes::from_static(b"["))).is_err() {
            return;
        }
        let mut first = true;
        for chunk in ids.chunks(PAGE_PARTS) {
            let (Some(&lo), Some(&hi)) = (chunk.first(), chunk.last()) else {
                continue;
            };
            let page_q = PartQuery {
                after: Some(lo - 1),
                through: Some(hi),
                limit: None,
                ..q.clone()
            };
            let page = match pool.with(|s| fetch(s, &page_q)) {
                Ok(p) => p,
                Err(e) => {
                    let _ = tx.blocking_send(Err(std::io::Error::other(e.to_string())));
                    return;
                }
            };
            let mut buf = Vec::new();
            for item in &page {
                if !first {
                    buf.push(b',');
                }
                first = false;
                if let Err(e) = serde_json::to_writer(&mut buf, item) {
                    let _ = tx.blocking_send(Err(std::io::Error::other(e.to_string())));
                    return;
                }
            }
            if tx.blocking_send(Ok(Bytes::from(buf))).is_err() {
                return; // the client went away
            }
        }
        let _ = tx.blocking_send(Ok(Bytes::from_static(b"]")));
    });
    (
        [(header::CONTENT_TYPE, "application/json")],
        Body::from_stream(tokio_stream::wrappers::ReceiverStream::new(rx)),
    )
        .into_response()
}

async fn api_parts(
    State(st): State<AppState>,
    p: Result<Query<PartsParams>, QueryRejection>,
) -> Response {
    let p = match params(p) {
        Ok(p) => p,
        Err(r) => return *r,
    };
    let q = match p.query() {
        Ok(q) => q,
        Err(r) => return *r,
    };
    match p.view.as_deref() {
        None | Some("") | Some("full") => stream_array(&st, q, |s, q| s.parts(q)).await,
        Some("summary") => stream_array(&st, q, |s, q| s.part_summaries(q)).await,
        Some(other) => error(
            StatusCode::BAD_REQUEST,
            format!("view = {other:?}: expected full or summary"),
        ),
    }
}

async fn api_part(State(st): State<AppState>, Path(id): Path<String>) -> Response {
    let id = match parse_id("part", &id) {
        Ok(i) => i,
        Err(r) => return *r,
    };
    match blocking(&st.pool, move |s| s.part(id)).await {
        Ok(Some(p)) => json_response(&p),
        Ok(None) => error(StatusCode::NOT_FOUND, format!("no part {id}")),
        Err(r) => r,
    }
}

/// Yu et al., 2024: the station's 25 real parts.
pub(crate) fn paper_figures() -> serde_json::Value {
    let y = &gonio_station::published::YU_2024;
    json!({
        "source": y.source,
        "parts": y.parts,
        "mean_time_s": y.mean_time_s,
        "mean_pushes": y.mean_pushes,
        "max_pushes": y.max_pushes,
        "mean_final_e_um": y.mean_final_e_um,
    })
}

async fn api_stats(
    State(st): State<AppState>,
    p: Result<Query<PartsParams>, QueryRejection>,
) -> Response {
    let p = match params(p) {
        Ok(p) => p,
        Err(r) => return *r,
    };
    let q = match p.query() {
        Ok(q) => q,
        Err(r) => return *r,
    };
    match blocking(&st.pool, move |s| s.stats(&q)).await {
        Ok(v) => json_response(&json!({"store": v, "paper": paper_figures()})),
        Err(r) => r,
    }
}

async fn api_calibrations(State(st): State<AppState>) -> Response {
    match blocking(&st.pool, |s| s.calibrations()).await {
        Ok(v) => json_response(&v),
        Err(r) => r,
    }
}

async fn api_calibration(State(st): State<AppState>, Path(id): Path<String>) -> Response {
    let id = match parse_id("calibration", &id) {
        Ok(i) => i,
        Err(r) => return *r,
    };
    match blocking(&st.pool, move |s| s.calibration(id)).await {
        Ok(Some(c)) => json_response(&c),
        Ok(None) => error(StatusCode::NOT_FOUND, format!("no calibration {id}")),
        Err(r) => r,
    }
}

async fn live_page(State(st): State<AppState>) -> Html<String> {
    Html(assets::live_page(st.hub.state().station))
}

async fn api_live(State(st): State<AppState>) -> Response {
    json_response(&st.hub.state())
}

async fn api_status(State(st): State<AppState>) -> Response {
    let live = st.hub.state();
    json_response(&json!({
        "station": live.station,
        "phase": live.phase,
        "serial": live.serial,
        "events": live.events,
        "frame_timing": st.hub.station_status(),
        "plc": st.hub.plc_status(),
    }))
}

async fn api_events(
    State(st): State<AppState>,
) -> Sse<impl tokio_stream::Stream<Item = Result<SseEvent, Infallible>>> {
    let stream = BroadcastStream::new(st.hub.subscribe()).map(|r| {
        Ok(match r {
            Ok(e) => SseEvent::default().event(e.name).data(e.data.as_str()),
            // Too slow to follow: the page reloads the state from /api/live.
            Err(BroadcastStreamRecvError::Lagged(n)) => {
                SseEvent::default().event("resync").data(n.to_string())
            }
        })
    });
    Sse::new(stream).keep_alive(KeepAlive::default())
}

async fn not_found() -> Response {
    error(StatusCode::NOT_FOUND, "no such page")
}

async fn method_not_allowed() -> Response {
    let mut r = error(
        StatusCode::METHOD_NOT_ALLOWED,
        "the dashboard is read-only: only GET is served",
    );
    r.headers_mut()
        .insert(header::ALLOW, header::HeaderValue::from_static("GET, HEAD"));
    r
}

/// The dashboard's routes over the store at `store_location` (a SQLite path or a `postgres://`
/// URL), with the live view fed by `hub`. Only `GET` routes: the dashboard changes nothing.
///
/// # Errors
/// [`WebError::Store`] when the store cannot be opened (it is opened once here, migrating it).
pub fn router(store_location: &str, hub: Arc<Hub>) -> Result<Router, WebError> {
    let first = gonio_store::open(store_location)?;
    let pool = Arc::new(Pool::new(store_location, first, 8));
    let state = AppState {
        pool,
        hub,
        streams: Arc::new(tokio::sync::Semaphore::new(MAX_STREAMS)),
    };
    Ok(Router::new()
        .route("/", get(live_page))
        .route("/history", get(|| async { Html(assets::HISTORY_HTML) }))
        .route("/parts/{id}", get(pages::part_page))
        .route("/calibrations", get(pages::calibrations_page))
        .route("/calibrations/{id}", get(pages::calibration_page))
        .route("/static/{file}", get(assets::file))
        .route("/api/parts", get(api_parts))
        .route("/api/parts/{id}", get(api_part))
        .route("/api/stats", get(api_stats))
        .route("/api/calibrations", get(api_calibrations))
        .route("/api/calibrations/{id}", get(api_calibration))
        .route("/api/live", get(api_live))
        .route("/api/status", get(api_status))
        .route("/api/events", get(api_events))
        .fallback(not_found)
        .method_not_allowed_fallback(method_not_allowed)
        .with_state(state))
}
