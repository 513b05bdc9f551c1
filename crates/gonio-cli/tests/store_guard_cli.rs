//! No data loss through the results store: the store belongs to the command's set of inputs
//! and outputs, which never overlap (`--db X --json X`, `--compensation X`, `parts --db X --out
//! X` are refused before any work, the store intact, whether it exists yet or not); a command
//! that only reads (`parts`, `serve` without a station) never creates a store; a device is not
//! a store; a store that fails half-way through `parts --json` leaves nothing written, on
//! standard output either.

mod common;

use common::{gonio, simulated_lab, stderr};
use std::path::Path;

fn s(p: &Path) -> String {
    p.display().to_string()
}

/// The parts of the store at `db`, as `gonio parts --json` prints them.
fn parts_json(db: &str) -> serde_json::Value {
    let o = gonio(&["parts", "--db", db, "--json"]);
    assert!(o.status.success(), "{}", stderr(&o));
    serde_json::from_slice(&o.stdout).unwrap()
}

fn refused(args: &[&str], says: &str) {
    let o = gonio(args);
    let e = stderr(&o);
    assert_eq!(o.status.code(), Some(2), "{args:?}: {e}");
    assert_eq!(e.lines().count(), 1, "{e}");
    assert!(e.contains(says), "{args:?}: {e}");
}

#[test]
fn the_store_is_never_an_output() {
    let d = tempfile::tempdir().unwrap();
    let db = s(&d.path().join("results.sqlite"));
    let o = gonio(&["mount", "--sim", "--parts", "2", "--seed", "4", "--db", &db]);
    assert!(o.status.success(), "{}", stderr(&o));
    let before = parts_json(&db);
    assert_eq!(before.as_array().unwrap().len(), 2);
    let size = std::fs::metadata(&db).unwrap().len();

    // Named as an output, under its own name or another: refused, the store unchanged.
    let dotted = s(&d.path().join(".").join("results.sqlite"));
    for args in [
        vec![
            "mount", "--sim", "--parts", "1", "--seed", "1", "--db", &db, "--json", &db,
        ],
        vec![
            "mount", "--sim", "--parts", "1", "--seed", "1", "--db", &db, "--json", &dotted,
        ],
        vec!["parts", "--db", &db, "--out", &db],
        vec!["parts", "--db", &db, "--json", "--out", &dotted],
    ] {
        refused(&args, "results store");
    }
    // Its SQLite companions are the store's too.
    let wal = format!("{db}-wal");
    refused(
        &["parts", "--db", &db, "--csv", "--out", &wal],
        "results store",
    );
    assert_eq!(parts_json(&db), before);
    assert!(std::fs::metadata(&db).unwrap().len() >= size);

    // A calibration's --json and --compensation, with a store that does not exist yet: refused
    // before any work, and no store is created.
    let (lab, _) = simulated_lab(d.path(), "3", &["--seed", "5"], &["--seed", "6"]);
    let lab = s(&lab);
    let new_db = s(&d.path().join("cal.sqlite"));
    for flag in ["--json", "--compensation"] {
        refused(
            &["shift-angle", &lab, "--db", &new_db, flag, &new_db],
            "results store",
        );
        assert!(!Path::new(&new_db).exists(), "{flag}");
    }
}

#[test]
fn reading_never_creates_a_store_and_a_device_is_no_store() {
    let d = tempfile::tempdir().unwrap();
    let typo = s(&d.path().join("typo.sqlite"));
    refused(&["parts", "--db", &typo], "typo.sqlite");
    refused(&["parts", "--db", &typo, "--json"], "does not create");
    refused(
        &["serve", "--db", &typo, "--addr", "127.0.0.1:0"],
        "typo.sqlite",
    );
    assert_eq!(std::fs::read_dir(d.path()).unwrap().count(), 0, "created");

    let dir = s(d.path());
    for (args, says) in [
        (vec!["parts", "--db", "/dev/null"], "is a device"),
        (
            vec![
                "mount",
                "--sim",
                "--parts",
                "1",
                "--seed",
                "1",
                "--db",
                "/dev/null",
            ],
            "is a device",
        ),
        (vec!["parts", "--db", &dir], "is a directory"),
    ] {
        refused(&args, says);
    }
    assert!(!Path::new("/dev/null-journal").exists());
    assert!(!Path::new("/dev/null-wal").exists());
}

/// `parts --json` reads the store a page at a time; a record that cannot be read on a later
/// page ends the command with nothing written: no partial array on standard output, no file.
#[test]
fn a_store_failing_half_way_writes_nothing() {
    let d = tempfile::tempdir().unwrap();
    let db = s(&d.path().join("results.sqlite"));
    // More parts than one page (64), the bad one on the second page.
    let o = gonio(&[
        "mount", "--sim", "--parts", "70", "--seed", "3", "--db", &db,
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(parts_json(&db).as_array().unwrap().len(), 70);
    let c = rusqlite::Connection::open(&db).unwrap();
    let n = c
        .execute(
            "UPDATE turns SET samples_json = '[{oops' \
             WHERE part_id = (SELECT id FROM parts WHERE batch_index = 68)",
            [],
        )
        .unwrap();
    assert!(n > 0);
    drop(c);
    let o = gonio(&["parts", "--db", &db, "--json"]);
    let e = stderr(&o);
    assert_eq!(o.status.code(), Some(2), "{e}");
    assert_eq!(e.lines().count(), 1, "{e}");
    assert!(e.contains("samples_json"), "{e}");
    assert!(o.stdout.is_empty(), "{} bytes on stdout", o.stdout.len());
    let out = d.path().join("parts.json");
    let o = gonio(&["parts", "--db", &db, "--json", "--out", &s(&out)]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(!out.exists());
    assert_eq!(
        std::fs::read_dir(d.path()).unwrap().count(),
        1,
        "a file left behind"
    );
}
