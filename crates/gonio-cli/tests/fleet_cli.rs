//! A fleet on PostgreSQL: two station processes write 200 parts each into one database at the
//! same time; the database then holds 400 records, each station's 200 exactly as the same batch
//! gives when run alone (nothing lost, nothing mixed between the stations). The server is a
//! throw-away cluster the test starts itself (Debian `postgresql`, installed by `.ci/run`).

use gonio_store::scratch::ScratchServer;
use serde_json::Value;
use std::process::{Command, Stdio};

fn parts_json(db: &str) -> Vec<Value> {
    let o = Command::new(env!("CARGO_BIN_EXE_gonio"))
        .args(["parts", "--db", db, "--json"])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let v: Value = serde_json::from_slice(&o.stdout).unwrap();
    v.as_array().unwrap().clone()
}

/// A record without what differs between databases and runs: ids and wall-clock times.
fn content(p: &Value) -> Value {
    let mut p = p.clone();
    let o = p.as_object_mut().unwrap();
    for k in ["part", "batch", "started_at", "ended_at"] {
        o.remove(k);
    }
    p
}

fn mount(seed: &str, station: &str, db: &str) -> std::process::Child {
    Command::new(env!("CARGO_BIN_EXE_gonio"))
        .args([
            "mount",
            "--sim",
            "--seed",
            seed,
            "--parts",
            "200",
            "--db",
            db,
            "--station-name",
            station,
        ])
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap()
}

#[test]
fn two_stations_write_400_parts_into_one_postgres_database() {
    let pg = ScratchServer::start().unwrap_or_else(|why| panic!("cannot start PostgreSQL: {why}"));
    let url = pg.create_database("fleet").unwrap();
    let (a, b) = (mount("21", "line1-s1", &url), mount("22", "line1-s2", &url));
    for c in [a, b] {
        let o = c.wait_with_output().unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    }
    let all = parts_json(&url);
    assert_eq!(all.len(), 400, "400 records");
    let mut ids: Vec<i64> = all.iter().map(|p| p["part"].as_i64().unwrap()).collect();
    ids.dedup();
    assert_eq!(ids.len(), 400, "distinct ids");
    eprintln!(
        "PostgreSQL: two stations wrote {} records concurrently",
        all.len()
    );

    // Each station's records, against the same batch run alone into SQLite.
    let d = tempfile::tempdir().unwrap();
    for (seed, station) in [("21", "line1-s1"), ("22", "line1-s2")] {
        let solo = d.path().join(format!("{station}.sqlite"));
        let solo = solo.to_str().unwrap();
        let o = mount(seed, station, solo).wait_with_output().unwrap();
        assert!(o.status.success());
        let want: Vec<Value> = parts_json(solo).iter().map(content).collect();
        let got: Vec<Value> = all
            .iter()
            .filter(|p| p["station"] == station)
            .map(content)
            .collect();
        assert_eq!(got.len(), 200, "{station}: 200 parts");
        for (i, (g, w)) in got.iter().zip(&want).enumerate() {
            assert_eq!(g["serial"], format!("SIM-{seed}-{:04}", i + 1));
            assert_eq!(g, w, "{station} part {}: not as when run alone", i + 1);
        }
    }
}
