//! What the API's handlers ([`crate::api`]) and the pages ([`crate::pages`]) share: the state
//! every request gets ([`AppState`]: the store's connections, the live view's hub), store calls
//! on a blocking thread, and the JSON error responses.

use crate::live::Hub;
use axum::http::{StatusCode, header};
use axum::response::{IntoResponse, Response};
use gonio_store::{Store, StoreError};
use serde_json::json;
use std::sync::{Arc, Mutex};

/// Connections to the store, reused between requests (each request runs on a blocking thread
/// with one connection of its own).
pub(crate) struct Pool {
    location: String,
    idle: Mutex<Vec<Box<dyn Store>>>,
}

impl Pool {
    /// A pool for the store at `location`, holding `first`, a connection already open.
    pub(crate) fn new(location: &str, first: Box<dyn Store>) -> Pool {
        Pool {
            location: location.to_string(),
            idle: Mutex::new(vec![first]),
        }
    }

    /// Runs `f` with a connection (an idle one, else a new one; kept for reuse when `f`
    /// succeeds).
    pub(crate) fn with<T>(
        &self,
        f: impl FnOnce(&mut dyn Store) -> Result<T, StoreError>,
    ) -> Result<T, StoreError> {
        let cached = self.idle.lock().ok().and_then(|mut v| v.pop());
        let mut s = match cached {
            Some(s) => s,
            None => gonio_store::open(&self.location)?,
        };
        let r = f(s.as_mut());
        if r.is_ok()
            && let Ok(mut v) = self.idle.lock()
            && v.len() < 8
        {
            v.push(s);
        }
        r
    }
}

impl Drop for Pool {
    /// Closes the idle connections on a thread of their own: a PostgreSQL connection closes
    /// through a runtime of its own, which cannot run on the server's.
    fn drop(&mut self) {
        let idle = self.idle.get_mut().map(std::mem::take).unwrap_or_default();
        if !idle.is_empty() {
            let _ = std::thread::spawn(move || drop(idle)).join();
        }
    }
}

/// What every handler shares: the store's connections, the live view's hub, and the permits
/// of the part arrays streamed at once.
#[derive(Clone)]
pub(crate) struct AppState {
    pub(crate) pool: Arc<Pool>,
    pub(crate) hub: Arc<Hub>,
    /// Arrays of parts streamed at once (each holds a store connection and a page).
    pub(crate) streams: Arc<tokio::sync::Semaphore>,
}

/// A JSON error response.
pub(crate) fn error(status: StatusCode, message: impl std::fmt::Display) -> Response {
    (
        status,
        [(header::CONTENT_TYPE, "application/json")],
        json!({"error": message.to_string()}).to_string(),
    )
        .into_response()
}

pub(crate) fn store_error(e: StoreError) -> Response {
    match e {
        StoreError::Invalid { .. } => error(StatusCode::BAD_REQUEST, e),
        e => error(StatusCode::INTERNAL_SERVER_ERROR, e),
    }
}

/// Runs a store call on a blocking thread.
pub(crate) async fn blocking<T: Send + 'static>(
    pool: &Arc<Pool>,
    f: impl FnOnce(&mut dyn Store) -> Result<T, StoreError> + Send + 'static,
) -> Result<T, Response> {
    let pool = pool.clone();
    match tokio::task::spawn_blocking(move || pool.with(f)).await {
        Ok(Ok(v)) => Ok(v),
        Ok(Err(e)) => Err(store_error(e)),
        Err(e) => Err(error(StatusCode::INTERNAL_SERVER_ERROR, e)),
    }
}

/// A record's id from the path: a whole number, or a 400 naming what was expected.
pub(crate) fn parse_id(what: &str, id: &str) -> Result<i64, Box<Response>> {
    id.parse::<i64>().map_err(|_| {
        Box::new(error(
            StatusCode::BAD_REQUEST,
            format!("{what} id {id:?}: expected a whole number"),
        ))
    })
}
