//! Connections to one store reused between calls: a call takes an idle connection (or opens a
//! new one), and gives it back when it succeeded, up to a number kept idle. A server runs each
//! call on a blocking thread (SQLite and the PostgreSQL client block); the pool itself is
//! plain and thread-safe. Errors: the store's ([`StoreError`]), from opening or from the call.
//!
//! ```
//! use gonio_store::pool::Pool;
//! let dir = tempfile::tempdir().unwrap();
//! let path = dir.path().join("results.sqlite");
//! let first = gonio_store::open(path.to_str().unwrap()).unwrap();
//! let pool = Pool::new(path.to_str().unwrap(), first, 4);
//! assert_eq!(pool.with(|s| Ok(s.schema_version())).unwrap(), gonio_store::migrate::latest_version());
//! ```

use crate::{Store, StoreError};
use std::sync::Mutex;

/// Connections to the store at one location (see the module documentation).
pub struct Pool {
    location: String,
    max_idle: usize,
    idle: Mutex<Vec<Box<dyn Store>>>,
}

impl Pool {
    /// A pool for the store at `location`, holding `first` (a connection already open, so
    /// that a wrong location fails before the pool exists), keeping at most `max_idle`
    /// connections idle.
    pub fn new(location: &str, first: Box<dyn Store>, max_idle: usize) -> Pool {
        Pool {
            location: location.to_string(),
            max_idle,
            idle: Mutex::new(vec![first]),
        }
    }

    /// Runs `f` with a connection: an idle one, else a new one, kept for reuse when `f`
    /// succeeds (a failed call's connection is dropped: it may be broken).
    ///
    /// # Errors
    /// Opening a new connection, or `f`'s error.
    pub fn with<T>(
        &self,
        f: impl FnOnce(&mut dyn Store) -> Result<T, StoreError>,
    ) -> Result<T, StoreError> {
        let cached = self.idle.lock().ok().and_then(|mut v| v.pop());
        let mut s = match cached {
            Some(s) => s,
            None => crate::open(&self.location)?,
        };
        let r = f(s.as_mut());
        if r.is_ok()
            && let Ok(mut v) = self.idle.lock()
            && v.len() < self.max_idle
        {
            v.push(s);
        }
        r
    }
}

impl Drop for Pool {
    /// Closes the idle connections on a thread of their own: a PostgreSQL connection closes
    /// through a runtime of its own, which cannot run on an async server's thread.
    fn drop(&mut self) {
        let idle = self.idle.get_mut().map(std::mem::take).unwrap_or_default();
        if !idle.is_empty() {
            let _ = std::thread::spawn(move || drop(idle)).join();
        }
    }
}
