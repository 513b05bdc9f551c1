//! The routes: the read-only JSON API, the server-sent events and the pages.

use crate::live::Hub;
use crate::state::{AppState, Pool, blocking, error, parse_id};
use crate::{WebError, assets, pages};
use axum::Router;
use axum::extract::{Path, Query, State};
use axum::http::{StatusCode, header};
use axum::response::sse::{Event as SseEvent, KeepAlive, Sse};
use axum::response::{Html, IntoResponse, Response};
use axum::routing::get;
use gonio_store::PartQuery;
use serde::Deserialize;
use serde_json::json;
use std::convert::Infallible;
use std::sync::Arc;
use tokio_stream::StreamExt;
use tokio_stream::wrappers::BroadcastStream;
use tokio_stream::wrappers::errors::BroadcastStreamRecvError;

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
            ..PartQuery::default()
        })
    }
}

async fn api_parts(State(st): State<AppState>, Query(p): Query<PartsParams>) -> Response {
    let q = match p.query() {
        Ok(q) => q,
        Err(r) => return *r,
    };
    match p.view.as_deref() {
        None | Some("") | Some("full") => match blocking(&st.pool, move |s| s.parts(&q)).await {
            Ok(v) => json_response(&v),
            Err(r) => r,
        },
        Some("summary") => match blocking(&st.pool, move |s| s.part_summaries(&q)).await {
            Ok(v) => json_response(&v),
            Err(r) => r,
        },
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
    json!({
        "source": "Yu et al., 2024 (25 real parts)",
        "parts": 25,
        "mean_time_s": 25.1,
        "mean_pushes": 2.1,
        "max_pushes": 5,
        "mean_final_e_um": 3.8,
    })
}

async fn api_stats(State(st): State<AppState>, Query(p): Query<PartsParams>) -> Response {
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

/// The dashboard's routes over the store at `store_location` (a SQLite path or a `postgres://`
/// URL), with the live view fed by `hub`. Only `GET` routes: the dashboard changes nothing.
///
/// # Errors
/// [`WebError::Store`] when the store cannot be opened (it is opened once here, migrating it).
pub fn router(store_location: &str, hub: Arc<Hub>) -> Result<Router, WebError> {
    let first = gonio_store::open(store_location)?;
    let pool = Arc::new(Pool::new(store_location, first));
    let state = AppState { pool, hub };
    Ok(Router::new()
        .route("/", get(|| async { Html(assets::LIVE_HTML) }))
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
        .with_state(state))
}
