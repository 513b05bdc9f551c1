//! The station's dashboard: a live view of the station at work (the current frame, c(θ)
//! filling in as the turn proceeds and then its fit, each push, the counters beside the figures
//! of Yu et al., 2024), the history of parts with a page per part (the report's plots), the
//! calibration certificates, and a read-only JSON API with server-sent events.
//!
//! - `GET /` live view, `/history`, `/parts/{id}`, `/calibrations`, `/calibrations/{id}`;
//! - `GET /api/parts` (the same array as `gonio parts --json`, with the same filters as query
//!   parameters: `since`, `verdict`, `serial`, `batch`, `limit`, and `after` / `through` (part
//!   ids) for paging; `view=summary` for table rows), streamed a page of parts at a time (at
//!   most 8 such arrays at once: a request holds a page in memory, never the store),
//!   `/api/parts/{id}`, `/api/stats`, `/api/calibrations`, `/api/calibrations/{id}`,
//!   `/api/live` (the live view's state), `/api/status` (the station's frame timing, or its
//!   PLC link's figures), `/api/events` (server-sent events).
//!
//! Everything is read-only (only `GET`), and every asset is built into the binary: no CDN, no
//! network. Errors are JSON (`{"error": "…"}`), bad query strings included. How connections
//! are limited, hosts checked, and TLS and a bearer token served: [`server`]; the token and the
//! key are read from files only their owner may read: [`secret`]. The station publishes through [`live::LiveObserver`]; the web layer never calls
//! the station. Its camera's frames become the live thumbnail through [`thumbnails`], and a
//! station link's figures the status's `plc` through [`link_watch`].
//!
//! ```no_run
//! # async fn doc() -> Result<(), gonio_web::WebError> {
//! let hub = gonio_web::live::Hub::new(false);
//! let app = gonio_web::router("results.sqlite", hub)?;
//! let listener = tokio::net::TcpListener::bind("127.0.0.1:8080").await.unwrap();
//! axum::serve(listener, app).await.unwrap();
//! # Ok(()) }
//! ```
#![deny(missing_docs)]

mod api;
mod assets;
pub mod link_watch;
pub mod live;
mod pages;
pub mod secret;
pub mod server;
mod state;
pub mod thumbnails;

use std::sync::Arc;
use thiserror::Error;

pub use api::router;
pub use server::{BearerToken, ServeOptions, Tls};

/// An error of the dashboard.
#[derive(Debug, Error)]
#[non_exhaustive]
pub enum WebError {
    /// The results store failed.
    #[error("results store: {0}")]
    Store(#[from] gonio_store::StoreError),
    /// The server failed.
    #[error("server: {message}")]
    Serve {
        /// Why.
        message: String,
    },
    /// A TLS certificate or key that cannot be used.
    #[error("TLS: {message}")]
    Tls {
        /// What is wrong with it.
        message: String,
    },
    /// A bearer token that cannot be used.
    #[error("token: {message}")]
    Token {
        /// What is wrong with it (never the token).
        message: String,
    },
}

/// Serves the dashboard on `listener` with `options` (limits, names, TLS, token: see
/// [`server`]) until Ctrl-C (or SIGTERM).
///
/// # Errors
/// [`WebError::Store`] when the store cannot be opened; [`WebError::Serve`].
pub async fn serve(
    listener: tokio::net::TcpListener,
    store_location: &str,
    hub: Arc<live::Hub>,
    options: ServeOptions,
) -> Result<(), WebError> {
    // Opening the store blocks (PostgreSQL's client runs a runtime of its own, which may not
    // be started from this one's tasks): on a blocking thread.
    let location = store_location.to_string();
    let app = tokio::task::spawn_blocking(move || router(&location, hub))
        .await
        .map_err(|e| WebError::Serve {
            message: e.to_string(),
        })??;
    server::run(listener, app, options, shutdown()).await
}

/// As [`serve`] on a listener bound by the caller (`std`), on a runtime of its own: for a
/// program without one. Blocks until Ctrl-C (or SIGTERM).
///
/// # Errors
/// As [`serve`]; [`WebError::Serve`] when the runtime cannot start.
pub fn serve_blocking(
    listener: std::net::TcpListener,
    store_location: &str,
    hub: Arc<live::Hub>,
    options: ServeOptions,
) -> Result<(), WebError> {
    let serve_err = |e: std::io::Error| WebError::Serve {
        message: e.to_string(),
    };
    let rt = tokio::runtime::Builder::new_multi_thread()
        .worker_threads(2)
        .enable_all()
        .build()
        .map_err(serve_err)?;
    rt.block_on(async move {
        listener.set_nonblocking(true).map_err(serve_err)?;
        let listener = tokio::net::TcpListener::from_std(listener).map_err(serve_err)?;
        serve(listener, store_location, hub, options).await
    })
}

async fn shutdown() {
    let ctrl_c = async {
        let _ = tokio::signal::ctrl_c().await;
    };
    let term = async {
        match tokio::signal::unix::signal(tokio::signal::unix::SignalKind::terminate()) {
            Ok(mut s) => {
                s.recv().await;
            }
            Err(_) => std::future::pending::<()>().await,
        }
    };
    tokio::select! {
        _ = ctrl_c => {},
        _ = term => {},
    }
}
