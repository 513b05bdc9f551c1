//! What the API's handlers ([`crate::api`]) and the pages ([`crate::pages`]) share: the state
//! every request gets ([`AppState`]: the store's connections, the live view's hub), store calls
//! on a blocking thread, and the JSON error responses.

use crate::live::Hub;
use axum::http::{StatusCode, header};
use axum::response::{IntoResponse, Response};
use gonio_store::pool::Pool;
use gonio_store::{Store, StoreError};
use serde_json::json;
use std::sync::Arc;

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
