//! The store on a real PostgreSQL server that the test starts itself (a throw-away cluster in
//! a temporary directory, on a Unix socket): the same checks as on SQLite, the migrations, and
//! concurrent writers.

mod common;

use gonio_store::scratch::ScratchServer;

fn server() -> ScratchServer {
    ScratchServer::start().unwrap_or_else(|why| panic!("cannot start PostgreSQL: {why}"))
}

#[test]
fn postgres_passes_the_same_checks_as_sqlite() {
    let pg = server();
    let url = pg.create_database("roundtrip").unwrap();
    common::round_trip(&url);
    // Opening again applies no migration a second time.
    assert_eq!(gonio_store::open(&url).unwrap().schema_version(), 2);
}

#[test]
fn writers_on_many_connections_get_distinct_ids_and_keep_their_rows() {
    // Eight connections open (and migrate) a new database at once, then each stores its own
    // batch of parts: the migration runs once, every part gets its own id, and every part's
    // turns and pushes stay with it.
    let pg = server();
    let url = pg.create_database("many").unwrap();
    let handles: Vec<_> = (0..8)
        .map(|w| {
            let url = url.clone();
            std::thread::spawn(move || common::write_batch(&url, &format!("w{w}"), 10))
        })
        .collect();
    let mut ids: Vec<i64> = handles
        .into_iter()
        .flat_map(|h| h.join().unwrap())
        .collect();
    ids.sort();
    ids.dedup();
    assert_eq!(ids.len(), 80);
    common::check_batches(&url, 8, 10);
}
