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
    assert_eq!(gonio_store::open(loc).unwrap().schema_version(), 2);
    // Opening again applies nothing (the tables exist: a second apply would fail).
    assert_eq!(gonio_store::open(loc).unwrap().schema_version(), 2);
    // A later version: only it is applied, on the existing data.
    let mut v3: Vec<Migration> = MIGRATIONS.to_vec();
    v3.push(Migration {
        version: 3,
        name: "operator",
        sql: "ALTER TABLE parts ADD COLUMN operator TEXT;",
    });
    assert_eq!(
        gonio_store::open_with(loc, &v3).unwrap().schema_version(),
        3
    );
    // This software (version 2) refuses the newer database rather than misreading it.
    let e = gonio_store::open(loc).err().expect("refused");
    assert!(
        matches!(
            e,
            StoreError::SchemaTooNew {
                expected: 2,
                found: 3
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

#[test]
fn a_store_is_a_regular_file_and_reading_never_creates_one() {
    let d = tempfile::tempdir().unwrap();
    // Devices, directories and names that are no file are refused, and nothing is left beside
    // them (SQLite would have put its journal next to /dev/null).
    let dir = d.path().display().to_string();
    let beside = ["/dev/null-journal", "/dev/null-wal"].map(|p| std::path::Path::new(p).exists());
    for loc in ["/dev/null", dir.as_str(), "", ":memory:"] {
        let e = gonio_store::open(loc).err().map(|e| e.to_string());
        assert!(
            e.as_deref()
                .is_some_and(|e| e.contains("a SQLite store is a regular file")),
            "{loc:?}: {e:?}"
        );
    }
    assert_eq!(
        ["/dev/null-journal", "/dev/null-wal"].map(|p| std::path::Path::new(p).exists()),
        beside
    );
    // A mistyped path: open_existing names it and creates nothing.
    let typo = d.path().join("typo.sqlite");
    let t = typo.display().to_string();
    match gonio_store::open_existing(&t) {
        Err(gonio_store::StoreError::Missing { location }) => assert_eq!(location, t),
        other => panic!("{:?}", other.err()),
    }
    assert_eq!(std::fs::read_dir(d.path()).unwrap().count(), 0);
    // An existing store opens.
    drop(gonio_store::open(&t).unwrap());
    assert!(gonio_store::open_existing(&t).is_ok());
}

#[test]
fn a_store_is_read_page_by_page_as_it_is_read_whole() {
    use gonio_store::PartQuery;
    let d = tempfile::tempdir().unwrap();
    let loc = d.path().join("r.sqlite").display().to_string();
    let a = common::write_batch(&loc, "A", 23);
    let b = common::write_batch(&loc, "B", 7);
    let mut s = gonio_store::open(&loc).unwrap();
    for q in [
        PartQuery::default(),
        PartQuery {
            limit: Some(9),
            ..PartQuery::default()
        },
        PartQuery {
            station: Some("A".into()),
            ..PartQuery::default()
        },
        PartQuery {
            after: Some(a[4]),
            through: Some(b[2]),
            ..PartQuery::default()
        },
    ] {
        let whole = s.parts(&q).unwrap();
        for page in [1, 5, 64] {
            let mut pages = Vec::new();
            let mut biggest = 0;
            s.for_each_page(&q, page, &mut |p| {
                biggest = biggest.max(p.len());
                pages.extend(p);
                true
            })
            .unwrap();
            // As JSON: NaN (undefined) fields compare equal there.
            assert_eq!(
                serde_json::to_string(&pages).unwrap(),
                serde_json::to_string(&whole).unwrap(),
                "{q:?}, pages of {page}"
            );
            assert!(biggest <= page);
        }
        let ids: Vec<i64> = whole.iter().map(|p| p.part).collect();
        assert_eq!(s.part_ids(&q).unwrap(), ids);
    }
    // after / through are id bounds: (a[4], b[2]] holds a[5..] and b[..=2].
    let q = PartQuery {
        after: Some(a[4]),
        through: Some(b[2]),
        ..PartQuery::default()
    };
    assert_eq!(s.part_ids(&q).unwrap().len(), 23 - 5 + 3);
    // Stopping early reads no further.
    let mut seen = 0;
    s.for_each_page(&PartQuery::default(), 4, &mut |p| {
        seen += p.len();
        false
    })
    .unwrap();
    assert_eq!(seen, 4);
}
