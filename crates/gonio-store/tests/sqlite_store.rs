//! The SQLite store: parts round-trip whole (turns, pushes, NaN as null), filters, duplicates
//! refused, the learned state and part count a resumed batch needs, calibrations with their
//! indexed fields, and the migration runner.

mod common;

use gonio_store::StoreError;
use gonio_store::migrate::{MIGRATIONS, Migration};

#[test]
fn parts_round_trip_with_filters_and_resume_state() {
    let d = tempfile::tempdir().unwrap();
    common::round_trip(d.path().join("r.sqlite").to_str().unwrap());
}

#[test]
fn migrations_apply_once_in_order_and_a_newer_database_is_refused() {
    let d = tempfile::tempdir().unwrap();
    let path = d.path().join("m.sqlite");
    let loc = path.to_str().unwrap();
    assert_eq!(gonio_store::open(loc).unwrap().schema_version(), 1);
    // Opening again applies nothing (the tables exist: a second apply would fail).
    assert_eq!(gonio_store::open(loc).unwrap().schema_version(), 1);
    // A later version: only it is applied, on the existing data.
    let mut v2: Vec<Migration> = MIGRATIONS.to_vec();
    v2.push(Migration {
        version: 2,
        name: "operator",
        sql: "ALTER TABLE parts ADD COLUMN operator TEXT;",
    });
    assert_eq!(
        gonio_store::open_with(loc, &v2).unwrap().schema_version(),
        2
    );
    // This software (version 1) refuses the newer database rather than misreading it.
    let e = gonio_store::open(loc).err().expect("refused");
    assert!(
        matches!(
            e,
            StoreError::SchemaTooNew {
                expected: 1,
                found: 2
            }
        ),
        "{e}"
    );
}

#[test]
fn a_missing_directory_is_an_open_error_naming_the_path() {
    let e = gonio_store::open("/nonexistent-dir/x/r.sqlite")
        .err()
        .unwrap();
    let m = e.to_string();
    assert!(
        m.starts_with("cannot open /nonexistent-dir/x/r.sqlite"),
        "{m}"
    );
}

#[test]
fn writers_on_several_connections_share_one_file() {
    // Four connections (as four station processes would) write 10 parts each into one file:
    // WAL and the busy timeout serialise the transactions, nothing is lost or mixed.
    let d = tempfile::tempdir().unwrap();
    let loc = d.path().join("shared.sqlite").to_str().unwrap().to_string();
    let handles: Vec<_> = (0..4)
        .map(|w| {
            let loc = loc.clone();
            std::thread::spawn(move || common::write_batch(&loc, &format!("w{w}"), 10))
        })
        .collect();
    for h in handles {
        assert_eq!(h.join().unwrap().len(), 10);
    }
    common::check_batches(&loc, 4, 10);
}
