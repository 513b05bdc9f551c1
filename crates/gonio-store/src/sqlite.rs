//! SQLite (embedded, bundled): WAL journal, full sync on commit, foreign keys on, and a busy
//! timeout so several station processes can share one file.

use crate::StoreError;
use crate::backend::{Backend, Dialect, Value};
use rusqlite::types::ValueRef;
use std::path::Path;
use std::time::Duration;

/// How long a statement waits for another connection's lock before it fails.
const BUSY_TIMEOUT: Duration = Duration::from_secs(30);

/// Switches the file's journal to WAL and returns the mode it is in. Switching takes the file's
/// exclusive lock, and SQLite answers `SQLITE_BUSY` at once, without its busy handler, when
/// another connection holds or waits for a lock then (several stations opening a new file at
/// the same moment): the switch is tried again, 1 ms after the first refusal and up to 50 ms
/// apart, until `timeout` has passed. A file already in WAL mode stays so without the lock.
fn to_wal(conn: &rusqlite::Connection, timeout: Duration) -> rusqlite::Result<String> {
    let start = std::time::Instant::now();
    let mut pause = Duration::from_millis(1);
    loop {
        match conn.query_row("PRAGMA journal_mode = WAL", [], |r| r.get(0)) {
            Err(rusqlite::Error::SqliteFailure(e, _))
                if matches!(
                    e.code,
                    rusqlite::ErrorCode::DatabaseBusy | rusqlite::ErrorCode::DatabaseLocked
                ) && start.elapsed() + pause < timeout =>
            {
                std::thread::sleep(pause);
                pause = (pause * 2).min(Duration::from_millis(50));
            }
            r => return r,
        }
    }
}

pub(crate) struct Sqlite {
    conn: rusqlite::Connection,
}

impl Sqlite {
    pub(crate) fn open(path: &Path) -> Result<Self, StoreError> {
        let open_err = |e: rusqlite::Error| StoreError::Open {
            location: path.display().to_string(),
            message: e.to_string(),
        };
        if let Some(kind) = not_a_store_file(path) {
            return Err(StoreError::Open {
                location: path.display().to_string(),
                message: format!("is {kind}: a SQLite store is a regular file"),
            });
        }
        let conn = rusqlite::Connection::open(path).map_err(open_err)?;
        conn.busy_timeout(BUSY_TIMEOUT).map_err(open_err)?;
        // WAL: readers (the dashboard) never block the station's writes. synchronous = FULL:
        // a committed part survives a power cut, not only a killed process.
        let mode = to_wal(&conn, BUSY_TIMEOUT).map_err(open_err)?;
        if !mode.eq_ignore_ascii_case("wal") {
            return Err(StoreError::Open {
                location: path.display().to_string(),
                message: format!("cannot switch the journal to WAL (got {mode})"),
            });
        }
        conn.execute_batch("PRAGMA synchronous = FULL; PRAGMA foreign_keys = ON;")
            .map_err(open_err)?;
        Ok(Sqlite { conn })
    }
}

/// What an existing `path` is when it is not a regular file (following symbolic links): SQLite
/// would open a device (`/dev/null`) and leave its journal beside it. `None` for a regular file
/// or a path that does not exist (yet). An empty path or an in-memory name is refused too.
fn not_a_store_file(path: &Path) -> Option<&'static str> {
    let s = path.as_os_str();
    if s.is_empty() {
        return Some("an empty path");
    }
    if s == ":memory:" || path.to_string_lossy().starts_with("file:") {
        return Some("an in-memory or URI name, not a file");
    }
    let m = std::fs::metadata(path).ok()?;
    let t = m.file_type();
    if t.is_file() {
        return None;
    }
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt;
        if t.is_block_device() || t.is_char_device() {
            return Some("a device");
        }
        if t.is_fifo() {
            return Some("a FIFO (named pipe)");
        }
        if t.is_socket() {
            return Some("a socket");
        }
    }
    if t.is_dir() {
        return Some("a directory");
    }
    Some("not a regular file")
}

/// `$1` → `?1`: SQLite numbers `?NNN` parameters exactly as PostgreSQL numbers `$n`.
fn translate(sql: &str) -> String {
    let mut out = String::with_capacity(sql.len());
    let mut it = sql.chars().peekable();
    while let Some(c) = it.next() {
        if c == '$' && it.peek().is_some_and(char::is_ascii_digit) {
            out.push('?');
        } else {
            out.push(c);
        }
    }
    out
}

fn to_sql(v: &Value) -> rusqlite::types::Value {
    match v {
        Value::Null => rusqlite::types::Value::Null,
        Value::Int(i) => rusqlite::types::Value::Integer(*i),
        Value::Real(f) => rusqlite::types::Value::Real(*f),
        Value::Text(s) => rusqlite::types::Value::Text(s.clone()),
    }
}

fn from_sql(v: ValueRef<'_>) -> Value {
    match v {
        ValueRef::Null => Value::Null,
        ValueRef::Integer(i) => Value::Int(i),
        ValueRef::Real(f) => Value::Real(f),
        ValueRef::Text(t) | ValueRef::Blob(t) => Value::Text(String::from_utf8_lossy(t).into()),
    }
}

fn err(e: rusqlite::Error) -> StoreError {
    StoreError::db("sqlite", e)
}

impl Backend for Sqlite {
    fn dialect(&self) -> Dialect {
        Dialect::Sqlite
    }

    fn exec(&mut self, sql: &str, params: &[Value]) -> Result<u64, StoreError> {
        let mut st = self.conn.prepare_cached(&translate(sql)).map_err(err)?;
        let n = st
            .execute(rusqlite::params_from_iter(params.iter().map(to_sql)))
            .map_err(err)?;
        Ok(n as u64)
    }

    fn query(&mut self, sql: &str, params: &[Value]) -> Result<Vec<Vec<Value>>, StoreError> {
        let mut st = self.conn.prepare_cached(&translate(sql)).map_err(err)?;
        let cols = st.column_count();
        let mut rows = st
            .query(rusqlite::params_from_iter(params.iter().map(to_sql)))
            .map_err(err)?;
        let mut out = Vec::new();
        while let Some(r) = rows.next().map_err(err)? {
            let mut row = Vec::with_capacity(cols);
            for i in 0..cols {
                row.push(from_sql(r.get_ref(i).map_err(err)?));
            }
            out.push(row);
        }
        Ok(out)
    }

    fn exec_script(&mut self, sql: &str) -> Result<(), StoreError> {
        self.conn.execute_batch(sql).map_err(err)
    }

    fn begin(&mut self) -> Result<(), StoreError> {
        self.conn.execute_batch("BEGIN IMMEDIATE").map_err(err)
    }

    fn commit(&mut self) -> Result<(), StoreError> {
        self.conn.execute_batch("COMMIT").map_err(err)
    }

    fn rollback(&mut self) {
        let _ = self.conn.execute_batch("ROLLBACK");
    }
}

#[cfg(test)]
mod tests {
    #[test]
    fn parameters_are_renumbered() {
        assert_eq!(
            super::translate("SELECT $1, '$x', $12"),
            "SELECT ?1, '$x', ?12"
        );
    }

    /// While another connection holds a write lock on a file not yet in WAL mode, SQLite
    /// refuses the switch at once, busy timeout or not; the switch waits for the lock instead.
    #[test]
    fn the_switch_to_wal_waits_for_another_connections_lock() {
        use std::time::Duration;
        let d = tempfile::tempdir().unwrap();
        let path = d.path().join("new.sqlite");
        let writer = rusqlite::Connection::open(&path).unwrap();
        writer
            .execute_batch("CREATE TABLE t (x); BEGIN IMMEDIATE; INSERT INTO t VALUES (1);")
            .unwrap();
        let opener = rusqlite::Connection::open(&path).unwrap();
        opener.busy_timeout(super::BUSY_TIMEOUT).unwrap();
        let refused = super::to_wal(&opener, Duration::ZERO).unwrap_err();
        assert!(refused.to_string().contains("locked"), "{refused}");
        let holder = std::thread::spawn(move || {
            std::thread::sleep(Duration::from_millis(200));
            writer.execute_batch("COMMIT").unwrap();
        });
        assert_eq!(
            super::to_wal(&opener, Duration::from_secs(20)).unwrap(),
            "wal"
        );
        holder.join().unwrap();
    }
}
