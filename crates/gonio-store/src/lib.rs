//! The results store of the mounting station and the calibration lab: one record per mounted
//! part (its turns, pushes, verdict and times) and per calibration certificate, behind a small
//! trait ([`Store`]) with two databases:
//!
//! - **SQLite** (embedded, the default): a file path. WAL journal (the dashboard reads while
//!   the station writes), each part committed in one transaction as it finishes, full sync on
//!   commit: a killed process loses nothing that was committed and leaves nothing half-stored.
//! - **PostgreSQL** (a fleet of stations sharing one server): a `postgres://` URL.
//!
//! Both run the same versioned migrations ([`migrate`]) and the same statements.
//!
//! ```
//! use gonio_store::{PartQuery, Store};
//! let dir = tempfile::tempdir().unwrap();
//! let mut store = gonio_store::open(dir.path().join("results.sqlite").to_str().unwrap()).unwrap();
//! assert_eq!(store.schema_version(), gonio_store::migrate::latest_version());
//! assert!(store.parts(&PartQuery::default()).unwrap().is_empty());
//! ```
#![deny(missing_docs)]

mod backend;
mod error;
pub mod migrate;
pub mod new_store;
mod pg;
pub mod pool;
pub mod record;
pub mod scratch;
mod sql;
mod sqlite;
pub mod time;
pub mod writer;

pub use error::StoreError;
pub use record::{
    BatchInfo, NewBatch, NewPart, PartQuery, PartStats, PartSummary, StoredCalibration, StoredPart,
    StoredTurn, Verdict,
};
pub use sql::RESULT_NAMES;

use gonio_calib::certificate::Certificate;
use sha2::{Digest, Sha256};

/// How a batch ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BatchStatus {
    /// Still running (or interrupted: resumable).
    Running,
    /// Every planned part was mounted.
    Complete,
    /// Stopped early (a device error under `on_device_error = "stop"`): resumable.
    Stopped,
}

impl BatchStatus {
    /// `running`, `complete` or `stopped`.
    pub fn name(self) -> &'static str {
        match self {
            BatchStatus::Running => "running",
            BatchStatus::Complete => "complete",
            BatchStatus::Stopped => "stopped",
        }
    }
}

/// A results store. Every method is one round of statements; [`Store::insert_part`] stores a
/// part whole (its turns and pushes) in one transaction or not at all.
pub trait Store: Send {
    /// The schema version of the database (after migration).
    fn schema_version(&self) -> u32;

    /// Records a batch about to start; returns its id.
    ///
    /// # Errors
    /// [`StoreError::Database`].
    fn begin_batch(&mut self, b: &NewBatch<'_>) -> Result<i64, StoreError>;

    /// A batch with its stored part count and the learned state after its last part.
    ///
    /// # Errors
    /// [`StoreError::Gap`] when a part is missing from the batch; [`StoreError::Database`].
    fn batch(&mut self, id: i64) -> Result<Option<BatchInfo>, StoreError>;

    /// The most recent batch of `station` started with exactly this configuration (for
    /// `--resume`).
    ///
    /// # Errors
    /// As [`Store::batch`].
    fn latest_batch(
        &mut self,
        station: &str,
        config_json: &str,
    ) -> Result<Option<BatchInfo>, StoreError>;

    /// Marks a batch complete or stopped.
    ///
    /// # Errors
    /// [`StoreError::Database`].
    fn end_batch(
        &mut self,
        id: i64,
        status: BatchStatus,
        reason: Option<&str>,
    ) -> Result<(), StoreError>;

    /// Stores one part, its turns and its pushes in one transaction; returns its id.
    ///
    /// # Errors
    /// [`StoreError::Duplicate`] when the batch already has a part at that index (nothing is
    /// stored); [`StoreError::Database`].
    fn insert_part(&mut self, p: &NewPart<'_>) -> Result<i64, StoreError>;

    /// The parts matching `q`, with their turns and pushes, in id order.
    ///
    /// # Errors
    /// [`StoreError::Invalid`] for an unknown verdict; [`StoreError::Database`],
    /// [`StoreError::Corrupt`].
    fn parts(&mut self, q: &PartQuery) -> Result<Vec<StoredPart>, StoreError>;

    /// As [`Store::parts`] without turns and pushes (a table).
    ///
    /// # Errors
    /// As [`Store::parts`].
    fn part_summaries(&mut self, q: &PartQuery) -> Result<Vec<PartSummary>, StoreError>;

    /// The ids of the parts matching `q` (its limit applied), ascending: a large store is
    /// walked page by page with [`Store::for_each_page`] without holding it in memory.
    ///
    /// # Errors
    /// As [`Store::parts`].
    fn part_ids(&mut self, q: &PartQuery) -> Result<Vec<i64>, StoreError>;

    /// The parts matching `q`, as [`Store::parts`], handed to `each` at most `page` at a time
    /// (in id order): memory holds one page, not the store. `each` returning `false` stops.
    ///
    /// # Errors
    /// As [`Store::parts`].
    fn for_each_page(
        &mut self,
        q: &PartQuery,
        page: usize,
        each: &mut dyn FnMut(Vec<StoredPart>) -> bool,
    ) -> Result<(), StoreError> {
        let ids = self.part_ids(q)?;
        for chunk in ids.chunks(page.max(1)) {
            let (Some(&first), Some(&last)) = (chunk.first(), chunk.last()) else {
                continue;
            };
            let parts = self.parts(&PartQuery {
                after: Some(first - 1),
                through: Some(last),
                limit: None,
                ..q.clone()
            })?;
            if !each(parts) {
                break;
            }
        }
        Ok(())
    }

    /// One part by id.
    ///
    /// # Errors
    /// As [`Store::parts`].
    fn part(&mut self, id: i64) -> Result<Option<StoredPart>, StoreError>;

    /// Counters over the parts matching `q` (its `limit` is ignored).
    ///
    /// # Errors
    /// As [`Store::parts`].
    fn stats(&mut self, q: &PartQuery) -> Result<PartStats, StoreError>;

    /// Stores a calibration certificate whole, with its indexed fields (item, procedure, method,
    /// date, largest |α|, largest U); returns its id.
    ///
    /// # Errors
    /// [`StoreError::Database`].
    fn insert_calibration(
        &mut self,
        cert: &Certificate,
        source: &str,
        software_version: &str,
    ) -> Result<i64, StoreError>;

    /// Every calibration, without the certificate itself, in id order.
    ///
    /// # Errors
    /// [`StoreError::Database`], [`StoreError::Corrupt`].
    fn calibrations(&mut self) -> Result<Vec<StoredCalibration>, StoreError>;

    /// One calibration with its whole certificate.
    ///
    /// # Errors
    /// As [`Store::calibrations`].
    fn calibration(&mut self, id: i64) -> Result<Option<StoredCalibration>, StoreError>;
}

/// Whether `location` names a PostgreSQL server (`postgres://…` or `postgresql://…`).
pub fn is_postgres(location: &str) -> bool {
    location.starts_with("postgres://") || location.starts_with("postgresql://")
}

/// Opens a store: a `postgres://` URL, or a SQLite file path (created if missing; an existing
/// path must be a regular file, not a device, FIFO or directory). Applies the missing
/// migrations.
///
/// # Errors
/// [`StoreError::Open`] when the database cannot be opened or reached, or the path is not a
/// regular file; [`StoreError::SchemaTooNew`]; [`StoreError::Database`] when a migration fails.
pub fn open(location: &str) -> Result<Box<dyn Store>, StoreError> {
    open_with(location, migrate::MIGRATIONS)
}

/// As [`open`], but a SQLite file must already exist (a command that only reads never creates
/// a store: a mistyped path is an error, not an empty store).
///
/// # Errors
/// [`StoreError::Missing`] when the SQLite file does not exist; as [`open`].
pub fn open_existing(location: &str) -> Result<Box<dyn Store>, StoreError> {
    if !is_postgres(location) {
        let path = std::path::Path::new(location);
        if std::fs::metadata(path).is_err() {
            return Err(StoreError::Missing {
                location: location.to_string(),
            });
        }
    }
    open(location)
}

/// As [`open`] with a list of migrations of the caller's (tests of the migration runner).
///
/// # Errors
/// As [`open`].
pub fn open_with(
    location: &str,
    migrations: &[migrate::Migration],
) -> Result<Box<dyn Store>, StoreError> {
    let mut db: Box<dyn backend::Backend> = if is_postgres(location) {
        Box::new(pg::Postgres::connect(location)?)
    } else {
        Box::new(sqlite::Sqlite::open(std::path::Path::new(location))?)
    };
    let version = migrate::migrate(db.as_mut(), migrations, &time::now_utc())?;
    Ok(Box::new(sql::SqlStore { db, version }))
}

/// SHA-256 of `bytes`, lower-case hex (recipe and batch-configuration hashes).
pub fn sha256_hex(bytes: &[u8]) -> String {
    Sha256::digest(bytes)
        .iter()
        .map(|b| format!("{b:02x}"))
        .collect()
}

/// The location for messages: a URL with its password hidden, or the path.
pub fn display_location(location: &str) -> String {
    pg::redact(location)
}
