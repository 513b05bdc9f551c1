//! Versioned schema migrations, one SQL file per version shared by both databases
//! (`migrations/NNNN_name.sql`; `{{id}}` is the dialect's auto-increment key). Opening a store
//! applies the missing ones in order, each recorded in `schema_migrations`, all in one
//! transaction under a lock, so two stations starting at once on a new server cannot both
//! migrate it. A database newer than this software is refused.

use crate::StoreError;
use crate::backend::{Backend, Dialect, Value};

/// One migration.
#[derive(Debug, Clone, Copy)]
pub struct Migration {
    /// Its version (1, 2, …, in order without gaps).
    pub version: u32,
    /// A short name.
    pub name: &'static str,
    /// The SQL, with `{{id}}` for an auto-increment primary key.
    pub sql: &'static str,
}

/// Every migration this software knows, oldest first.
pub const MIGRATIONS: &[Migration] = &[
    Migration {
        version: 1,
        name: "parts_and_calibrations",
        sql: include_str!("../migrations/0001_parts_and_calibrations.sql"),
    },
    Migration {
        version: 2,
        name: "parts_simulated",
        sql: include_str!("../migrations/0002_parts_simulated.sql"),
    },
    Migration {
        version: 3,
        name: "push_phase_times",
        sql: include_str!("../migrations/0003_push_phase_times.sql"),
    },
];

/// The schema version this software writes.
pub fn latest_version() -> u32 {
    MIGRATIONS.last().map_or(0, |m| m.version)
}

fn dialect_sql(sql: &str, d: Dialect) -> String {
    let id = match d {
        Dialect::Sqlite => "INTEGER PRIMARY KEY AUTOINCREMENT",
        Dialect::Postgres => "BIGSERIAL PRIMARY KEY",
    };
    sql.replace("{{id}}", id)
}

/// Applies the migrations of `list` the database does not have yet; returns its version.
pub(crate) fn migrate(
    db: &mut dyn Backend,
    list: &[Migration],
    now: &str,
) -> Result<u32, StoreError> {
    db.begin()?;
    let r = migrate_in(db, list, now);
    match r {
        Ok(v) => {
            db.commit()?;
            Ok(v)
        }
        Err(e) => {
            db.rollback();
            Err(e)
        }
    }
}

fn migrate_in(db: &mut dyn Backend, list: &[Migration], now: &str) -> Result<u32, StoreError> {
    if db.dialect() == Dialect::Postgres {
        // One migrator at a time on a shared server (released at commit).
        db.query("SELECT pg_advisory_xact_lock(7061626)", &[])?;
    }
    db.exec_script(
        "CREATE TABLE IF NOT EXISTS schema_migrations (
            version BIGINT PRIMARY KEY,
            name TEXT NOT NULL,
            applied_at TEXT NOT NULL
        )",
    )?;
    let rows = db.query("SELECT MAX(version) FROM schema_migrations", &[])?;
    let have = rows
        .first()
        .and_then(|r| r.first())
        .and_then(Value::int)
        .unwrap_or(0) as u32;
    let latest = list.last().map_or(0, |m| m.version);
    if have > latest {
        return Err(StoreError::SchemaTooNew {
            expected: latest,
            found: have,
        });
    }
    for m in list.iter().filter(|m| m.version > have) {
        db.exec_script(&dialect_sql(m.sql, db.dialect()))
            .map_err(|e| StoreError::db(format!("migration {} ({})", m.version, m.name), e))?;
        db.exec(
            "INSERT INTO schema_migrations (version, name, applied_at) VALUES ($1, $2, $3)",
            &[m.version.into(), m.name.into(), now.into()],
        )?;
    }
    Ok(latest.max(have))
}
