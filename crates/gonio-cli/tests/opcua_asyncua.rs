//! `gonio serve --opcua` against an MES gonio did not write: the Python `asyncua` client
//! (PyPI, in its own virtualenv under target/, made here when missing, with `argon2-cffi` for
//! the users file's hashes) runs tests/opcua/mes_check.py, which starts `gonio serve` itself
//! on 127.0.0.1 port 0 (or, off loopback, on 192.0.2.1 inside a network namespace the test
//! makes with `unshare -n`) and stops it. Also the flags' errors, without Python.

mod common;

use common::{gonio, repo, stderr};
use std::path::{Path, PathBuf};
use std::process::Command;

/// The test's virtualenv with asyncua and argon2-cffi (target/opcua-venv, made once).
fn venv_python() -> PathBuf {
    static VENV: std::sync::OnceLock<PathBuf> = std::sync::OnceLock::new();
    VENV.get_or_init(|| {
        common::venv_python(
            "opcua-venv",
            "import asyncua, argon2",
            &["asyncua>=1.1,<3", "argon2-cffi>=21,<26"],
        )
    })
    .clone()
}

/// Runs tests/opcua/mes_check.py in `mode` against the store `db` (working files in `work`),
/// through `wrap` (a command line the script runs under, or none).
fn check(mode: &str, db: &str, work: &Path, wrap: &[&str]) {
    let py = venv_python();
    let script = repo("crates/gonio-cli/tests/opcua/mes_check.py");
    let args = [
        py.to_str().unwrap(),
        &script,
        env!("CARGO_BIN_EXE_gonio"),
        mode,
        db,
        work.to_str().unwrap(),
    ];
    let out = match wrap.split_first() {
        Some((first, rest)) => Command::new(first).args(rest).args(args).output(),
        None => Command::new(args[0]).args(&args[1..]).output(),
    }
    .expect("python runs");
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success() && text.contains("all checks passed"),
        "mes_check.py {mode} failed:\n{text}\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    eprintln!("{}", text.trim());
}

/// A store with one part of station `line-2`.
fn store_with_a_part(dir: &Path) -> String {
    let db = dir.join("results.sqlite").display().to_string();
    let o = gonio(&[
        "mount",
        "--sim",
        "--parts",
        "1",
        "--seed",
        "9",
        "--db",
        &db,
        "--station-name",
        "line-2",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    db
}

#[test]
fn an_mes_gets_three_events_and_the_stores_results_from_a_simulated_batch() {
    // The command on SQLite; a part of another station was stored before the start.
    let d = tempfile::tempdir().unwrap();
    let db = d.path().join("results.sqlite").display().to_string();
    check("batch", &db, d.path(), &[]);
}

#[test]
fn a_postgresql_fleet_serves_every_stations_results_by_id() {
    let pg = gonio_store::scratch::ScratchServer::start()
        .unwrap_or_else(|why| panic!("cannot start PostgreSQL: {why}"));
    let url = pg.create_database("opcua").unwrap();
    let d = tempfile::tempdir().unwrap();
    check("batch", &url, d.path(), &[]);
}

#[test]
fn users_log_in_only_encrypted_and_anonymous_is_refused_where_configured() {
    let d = tempfile::tempdir().unwrap();
    let db = store_with_a_part(d.path());
    check("security", &db, d.path(), &[]);
}

#[test]
fn off_loopback_only_sign_and_encrypt_with_a_user() {
    // A network namespace of the test's own, where 192.0.2.1 (TEST-NET-1, documentation
    // addresses) is a local address that is not loopback.
    let d = tempfile::tempdir().unwrap();
    let db = store_with_a_part(d.path());
    let probe = Command::new("unshare")
        .args(["-n", "--", "ip", "link", "set", "lo", "up"])
        .output();
    assert!(
        probe.as_ref().is_ok_and(|o| o.status.success()),
        "this test needs `unshare -n` (util-linux) and `ip` (iproute2) with the right to make a network namespace: {probe:?}"
    );
    let setup = "ip link set lo up && ip addr add 192.0.2.1/32 dev lo && exec \"$@\"";
    check(
        "offloop",
        &db,
        d.path(),
        &["unshare", "-n", "--", "sh", "-c", setup, "sh"],
    );
}

#[test]
fn fifty_clients_garbage_bytes_and_a_killed_client_leave_the_station_and_store_intact() {
    let d = tempfile::tempdir().unwrap();
    let db = d.path().join("results.sqlite").display().to_string();
    check("robust", &db, d.path(), &[]);
}

/// `gonio serve` with `args` fails at once with exit code 2 and one line containing `text`.
fn refused(args: &[&str], text: &str) {
    let o = gonio(args);
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(2), "{args:?}: {err}");
    assert!(err.contains(text), "{args:?}: {err}");
    assert_eq!(err.trim().lines().count(), 1, "one line: {err}");
}

#[test]
fn the_opcua_flags_refuse_what_cannot_be_served_in_one_line() {
    let d = tempfile::tempdir().unwrap();
    let db = store_with_a_part(d.path());
    let base = ["serve", "--db", db.as_str(), "--addr", "127.0.0.1:0"];
    fn with<'a>(base: &[&'a str], more: &[&'a str]) -> Vec<&'a str> {
        [base, more].concat()
    }
    refused(
        &with(&base, &["--opcua", "192.0.2.1:4840", "--opcua-anonymous"]),
        "anonymous access is for a loopback address only",
    );
    refused(
        &with(&base, &["--opcua", "127.0.0.1:0"]),
        "no way to log in: give --opcua-users FILE",
    );
    refused(
        &with(&base, &["--opcua", "localhost:4840", "--opcua-anonymous"]),
        "--opcua localhost:4840: expected HOST:PORT with an IP address",
    );
    let users = d.path().join("users.txt");
    std::fs::write(
        &users,
        "# MES\nmes $argon2id$v=19$m=8,t=1,p=1$c2FsdHNhbHQ$aGFzaGhhc2hoYXNo\n",
    )
    .unwrap();
    let u = users.display().to_string();
    refused(
        &with(&base, &["--opcua", "127.0.0.1:0", "--opcua-users", &u]),
        &format!("{u}:2:1: expected NAME:HASH"),
    );
    std::fs::write(
        &users,
        "mes:$argon2id$v=19$m=8,t=1,p=1$c2FsdHNhbHQ$aGFzaGhhc2hoYXNo\n",
    )
    .unwrap();
    refused(
        &with(&base, &["--opcua", "127.0.0.1:0", "--opcua-users", &u]),
        "need --opcua-pki DIR",
    );
    let junk = d.path().join("junk.pem");
    std::fs::write(&junk, "not a certificate").unwrap();
    let (j, pki) = (
        junk.display().to_string(),
        d.path().join("pki").display().to_string(),
    );
    refused(
        &with(
            &base,
            &[
                "--opcua",
                "127.0.0.1:0",
                "--opcua-users",
                &u,
                "--opcua-pki",
                &pki,
                "--opcua-cert",
                &j,
                "--opcua-key",
                &j,
            ],
        ),
        &format!("{j}: not an X.509 certificate in PEM form"),
    );
    // Without --opcua its flags mean nothing: refused rather than ignored.
    let o = gonio(&with(&base, &["--opcua-anonymous"]));
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("--opcua"), "{}", stderr(&o));
}
