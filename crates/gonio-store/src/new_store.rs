//! A SQLite store a command is about to create, removed again (with its `-journal`, `-wal` and
//! `-shm` files) unless the command keeps it: a command that fails while setting up leaves no
//! empty store behind. A store that already existed, or a `postgres://` URL, is never touched.
//!
//! ```
//! use gonio_store::new_store::NewStore;
//! let d = tempfile::tempdir().unwrap();
//! let path = d.path().join("r.sqlite");
//! let location = path.to_str().unwrap();
//! let created = NewStore::before_open(location);
//! drop(gonio_store::open(location).unwrap());
//! drop(created); // set-up failed: the new store goes
//! assert!(!path.exists());
//! ```

/// A SQLite store a command is about to create, removed again (with its journal files) unless
/// the command [`NewStore::keep`]s it: a command that fails while setting up (a station whose
/// devices do not answer) leaves no empty store behind. A store that already existed, or a
/// `postgres://` URL, is never touched.
#[derive(Debug)]
pub struct NewStore(Option<std::path::PathBuf>);

impl NewStore {
    /// Notes whether `location` is a SQLite file that does not exist yet (before opening it).
    pub fn before_open(location: &str) -> Self {
        let path = std::path::Path::new(location);
        NewStore((!crate::is_postgres(location) && !path.exists()).then(|| path.to_path_buf()))
    }

    /// The command is set up: the store stays, whatever happens next.
    pub fn keep(mut self) {
        self.0 = None;
    }
}

impl Drop for NewStore {
    fn drop(&mut self) {
        if let Some(path) = self.0.take() {
            for suffix in ["", "-journal", "-wal", "-shm"] {
                let mut p = path.clone().into_os_string();
                p.push(suffix);
                let _ = std::fs::remove_file(p);
            }
        }
    }
}
