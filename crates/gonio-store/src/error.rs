//! The store's errors.

use thiserror::Error;

/// An error of the results store.
#[derive(Debug, Error)]
#[non_exhaustive]
pub enum StoreError {
    /// The database could not be opened or reached.
    #[error("cannot open {location}: {message}")]
    Open {
        /// The path or URL (password removed).
        location: String,
        /// What went wrong.
        message: String,
    },
    /// A store that should exist does not (a command that only reads never creates one).
    #[error(
        "no store at {location}: a command that only reads does not create one (check the path; gonio mount --db creates a store)"
    )]
    Missing {
        /// The path.
        location: String,
    },
    /// A statement failed.
    #[error("database error during {during}: {message}")]
    Database {
        /// What the store was doing (`insert part`, `migration 1`, …).
        during: String,
        /// The database's message.
        message: String,
    },
    /// The database's schema is newer than this software understands.
    #[error(
        "the database has schema version {found}, newer than this gonio knows ({expected}): upgrade gonio"
    )]
    SchemaTooNew {
        /// The newest version this software knows.
        expected: u32,
        /// The database's version.
        found: u32,
    },
    /// A value in the database is not what the schema says.
    #[error("{table} row {row}: column {column}: {message}")]
    Corrupt {
        /// The table.
        table: &'static str,
        /// The row's key.
        row: i64,
        /// The column.
        column: &'static str,
        /// What was expected.
        message: String,
    },
    /// An argument is not valid (a `--since` time, a filter).
    #[error("{what} = {value:?}: expected {expected}")]
    Invalid {
        /// Which argument.
        what: &'static str,
        /// The value given.
        value: String,
        /// What is allowed.
        expected: &'static str,
    },
    /// A part is stored twice in one batch (a resumed batch that would duplicate a part).
    #[error("batch {batch} already has part {index}: not stored twice")]
    Duplicate {
        /// The batch.
        batch: i64,
        /// 0-based index of the part in the batch.
        index: usize,
    },
    /// The batch's stored parts have a gap (a part lost): it cannot be resumed safely.
    #[error(
        "batch {batch} has {stored} parts stored but its last is part {last} (0-based): a part is missing"
    )]
    Gap {
        /// The batch.
        batch: i64,
        /// Parts stored.
        stored: usize,
        /// Index of the last stored part.
        last: usize,
    },
}

impl StoreError {
    pub(crate) fn db(during: impl Into<String>, e: impl std::fmt::Display) -> Self {
        StoreError::Database {
            during: during.into(),
            message: e.to_string().replace('\n', " "),
        }
    }
}
