//! The dashboard's JSON API against the command line: `/api/parts` is the same array as
//! `gonio parts --json` (with the same filters), `/api/parts/{id}` one of its elements; bad ids
//! and filters are JSON errors; nothing but GET is served (read-only); the pages use no
//! resource from the network; another address than loopback needs --allow-remote.

mod common;

use common::{gonio, http_get, start_serve};
use serde_json::Value;
use std::io::{BufRead, BufReader, Read, Write};
use std::net::TcpStream;
use std::process::Output;
use std::time::Duration;

fn json_of(o: &Output) -> Value {
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    serde_json::from_slice(&o.stdout).expect("JSON")
}

/// A request with another method: its status code.
fn status_of(addr: &str, method: &str, path: &str) -> u16 {
    let mut s = TcpStream::connect(addr).unwrap();
    s.set_read_timeout(Some(Duration::from_secs(10))).unwrap();
    s.write_all(
        format!("{method} {path} HTTP/1.1\r\nHost: {addr}\r\nContent-Length: 0\r\nConnection: close\r\n\r\n")
            .as_bytes(),
    )
    .unwrap();
    let mut line = String::new();
    BufReader::new(&s).read_line(&mut line).unwrap();
    let mut rest = Vec::new();
    let _ = (&s).read_to_end(&mut rest);
    line.split_whitespace()
        .nth(1)
        .and_then(|c| c.parse().ok())
        .unwrap()
}

#[test]
fn the_api_serves_what_gonio_parts_prints() {
    let d = tempfile::tempdir().unwrap();
    let db = d.path().join("results.sqlite").display().to_string();
    // A recipe that rejects some parts (a timeout over by the end of the first push, about
    // 11 s: a part that needs a second push is rejected), then a normal batch.
    let recipe = d.path().join("tight.toml");
    std::fs::write(&recipe, "timeout_s = 9.0\n").unwrap();
    let r = recipe.display().to_string();
    for extra in [vec!["--recipe", r.as_str()], vec![]] {
        let mut a = vec![
            "mount",
            "--sim",
            "--parts",
            "6",
            "--seed",
            "3",
            "--strategy",
            "learned",
            "--db",
            &db,
        ];
        a.extend(extra);
        assert!(gonio(&a).status.success());
    }
    let all = json_of(&gonio(&["parts", "--db", &db, "--json"]));
    let rejects = json_of(&gonio(&[
        "parts",
        "--db",
        &db,
        "--json",
        "--verdict",
        "reject",
    ]));
    let last3 = json_of(&gonio(&["parts", "--db", &db, "--json", "--limit", "3"]));
    assert_eq!(all.as_array().unwrap().len(), 12);
    let n_rej = rejects.as_array().unwrap().len();
    assert!(n_rej > 0 && n_rej < 12, "{n_rej} rejects");

    let (_serve, addr) = start_serve(
        env!("CARGO_BIN_EXE_gonio"),
        &["serve", "--db", &db, "--addr", "127.0.0.1:0"],
    );
    let get = |path: &str| -> (u16, Value) {
        let (status, body) = http_get(&addr, path);
        (status, serde_json::from_str(&body).unwrap_or(Value::Null))
    };
    assert_eq!(get("/api/parts"), (200, all.clone()));
    assert_eq!(get("/api/parts?verdict=reject"), (200, rejects));
    assert_eq!(get("/api/parts?limit=3"), (200, last3));
    let third = all.as_array().unwrap()[2].clone();
    let id = third["part"].as_i64().unwrap();
    assert_eq!(get(&format!("/api/parts/{id}")), (200, third));

    // Errors are JSON with the status a client can act on.
    let (s, v) = get("/api/parts/999");
    assert_eq!(s, 404);
    assert_eq!(v["error"], "no part 999");
    let (s, v) = get("/api/parts/abc");
    assert_eq!(s, 400);
    assert!(
        v["error"]
            .as_str()
            .unwrap()
            .contains("expected a whole number")
    );
    let (s, v) = get("/api/parts?verdict=maybe");
    assert_eq!(s, 400, "{v}");
    let (s, v) = get("/api/parts?since=yesterday");
    assert_eq!(s, 400, "{v}");

    // Counters: this store beside Yu et al., 2024.
    let (s, v) = get("/api/stats");
    assert_eq!(s, 200);
    assert_eq!(v["store"]["parts"], 12);
    assert_eq!(v["store"]["reject"], n_rej);
    assert_eq!(v["paper"]["mean_time_s"], 25.1);

    // No station under this dashboard: the live view says so and shows no frame or turn panel.
    let (s, page) = http_get(&addr, "/");
    assert_eq!(s, 200);
    assert!(page.contains("<body class=\"no-station\">"), "{page}");
    assert!(page.contains("No station is attached"), "{page}");

    // Read-only: no method but GET changes anything or is even served.
    for (m, p) in [
        ("POST", "/api/parts"),
        ("PUT", "/api/parts/1"),
        ("DELETE", "/api/parts/1"),
    ] {
        assert_eq!(status_of(&addr, m, p), 405, "{m} {p}");
    }
    assert_eq!(get("/api/parts"), (200, all));

    // Every page and asset is served from the binary, and none asks the network for anything
    // (the only URL is the SVG namespace name, which is not fetched).
    for path in [
        "/",
        "/history",
        "/calibrations",
        &format!("/parts/{id}"),
        "/static/live.js",
        "/static/history.js",
        "/static/style.css",
        "/static/icon.svg",
    ] {
        let (s, body) = http_get(&addr, path);
        assert_eq!(s, 200, "{path}");
        let stripped = body.replace("http://www.w3.org/2000/svg", "");
        assert!(
            !stripped.contains("http://") && !stripped.contains("https://"),
            "{path} refers to the network"
        );
    }
}

#[test]
fn another_address_than_loopback_needs_allow_remote() {
    let d = tempfile::tempdir().unwrap();
    let db = d.path().join("r.sqlite").display().to_string();
    let o = gonio(&["serve", "--db", &db, "--addr", "0.0.0.0:0"]);
    assert_eq!(o.status.code(), Some(2));
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(err.lines().count(), 1, "{err}");
    assert!(err.contains("--allow-remote"), "{err}");
    let o = gonio(&["serve", "--db", &db, "--addr", "localhost"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("expected HOST:PORT"));
}

#[test]
fn the_plc_station_needs_its_flags_and_refuses_the_simulations() {
    let d = tempfile::tempdir().unwrap();
    let db = d.path().join("r.sqlite").display().to_string();
    let serve = ["serve", "--db", &db, "--addr", "127.0.0.1:0"];
    let refused = |extra: &[&str], says: &str| {
        let o = gonio(&[&serve[..], extra].concat());
        assert_eq!(o.status.code(), Some(2), "{extra:?}");
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(err.lines().count(), 1, "{extra:?}: {err}");
        assert!(err.contains(says), "{extra:?}: {err}");
    };
    let plc = [
        "--station",
        "plc",
        "--plc",
        "modbus://127.0.0.1:9",
        "--camera",
        "nope",
    ];
    refused(&["--station", "plc"], "--station plc needs --plc");
    refused(
        &["--station", "plc", "--plc", "modbus://127.0.0.1:9"],
        "--camera ID",
    );
    refused(
        &[&plc[..], &["--seed", "3"]].concat(),
        "--seed is for --station sim only",
    );
    refused(
        &[&plc[..], &["--speed", "2", "--resume"]].concat(),
        "--speed, --resume are for --station sim only",
    );
    refused(
        &["--station", "sim", "--plc", "modbus://127.0.0.1:9"],
        "for --station plc only",
    );
    refused(
        &[
            "--station",
            "plc",
            "--plc",
            "127.0.0.1:9",
            "--camera",
            "nope",
        ],
        "expected modbus://HOST:PORT",
    );
    // No such camera (or no GenICam in this build): refused before the dashboard listens, and
    // the store this run would have created is not left behind empty.
    refused(&plc, "--camera nope");
    assert!(
        !std::path::Path::new(&db).exists(),
        "a failed station left an empty store"
    );
    // A store that existed stays, whatever the station does.
    std::fs::write(&db, b"").unwrap();
    refused(&plc, "--camera nope");
    assert!(
        std::path::Path::new(&db).exists(),
        "an existing store was removed"
    );
}
