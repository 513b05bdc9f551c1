//! The results store as the server reads it: connections reused between calls, each call on
//! a blocking thread (SQLite and the PostgreSQL client block; neither may run on the server's
//! tasks), at most [`MAX_IDLE`] connections kept.

use gonio_store::pool::Pool;
use gonio_store::{Store, StoreError};
use std::sync::Arc;

/// Idle connections kept for reuse.
const MAX_IDLE: usize = 4;

/// Connections to one store.
pub(crate) struct Stores {
    pool: Pool,
}

impl Stores {
    /// Opens the store at `location` once (it must exist) and keeps the connection.
    pub(crate) fn open(location: &str) -> Result<Arc<Stores>, StoreError> {
        let first = gonio_store::open_existing(location)?;
        Ok(Arc::new(Stores {
            pool: Pool::new(location, first, MAX_IDLE),
        }))
    }

    /// Runs `f` with a connection on a blocking thread (an idle connection, else a new one;
    /// kept when `f` succeeds).
    pub(crate) async fn with<T: Send + 'static>(
        self: &Arc<Self>,
        f: impl FnOnce(&mut dyn Store) -> Result<T, StoreError> + Send + 'static,
    ) -> Result<T, StoreError> {
        let me = self.clone();
        tokio::task::spawn_blocking(move || me.with_blocking(f))
            .await
            .unwrap_or_else(|e| {
                Err(StoreError::Database {
                    during: "a read for OPC UA".into(),
                    message: e.to_string(),
                })
            })
    }

    /// As [`Stores::with`] on the calling thread (not a server task).
    pub(crate) fn with_blocking<T>(
        &self,
        f: impl FnOnce(&mut dyn Store) -> Result<T, StoreError>,
    ) -> Result<T, StoreError> {
        self.pool.with(f)
    }
}
