//! The dashboard off loopback and under hostile clients: `--allow-remote` without TLS and a
//! bearer token is refused (exit 2, naming what is missing); with them a request without the
//! token gets 401, with it 200, and plain HTTP gets no answer on that port; the Host header is
//! checked (DNS rebinding); bad query strings are JSON errors; clients that connect and send
//! nothing do not lock the dashboard out, and a request head beyond its bound is answered 431;
//! a token or key file its group or others may read is refused (a warning with
//! --allow-insecure-permissions).
//!
//! The servers bound to 0.0.0.0 are reached through 127.0.0.1 only; the certificates are made
//! by the test (rcgen), none is committed.

mod common;

use common::{Guard, gonio, http_get, wait_for_line};
use std::io::{BufRead, BufReader, Read, Write};
use std::net::TcpStream;
use std::path::Path;
use std::sync::Arc;
use std::time::{Duration, Instant};

/// Starts `gonio serve` with `args`; the child and the port it listens on.
fn start(args: &[&str]) -> (Guard, u16) {
    let mut child = std::process::Command::new(env!("CARGO_BIN_EXE_gonio"))
        .args(args)
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .expect("gonio serve starts");
    let line = wait_for_line(&mut child, "gonio dashboard on ", Duration::from_secs(30));
    let port = line
        .split("://")
        .nth(1)
        .and_then(|r| r.split('/').next())
        .and_then(|a| a.rsplit(':').next())
        .and_then(|p| p.parse().ok())
        .unwrap_or_else(|| panic!("no port in {line:?}"));
    (Guard(child), port)
}

/// A certificate for `localhost` and 127.0.0.1 with its key, written into `dir`; the
/// certificate's DER (for the client's trust).
fn certificate(dir: &Path) -> (String, String, Vec<u8>) {
    let c =
        rcgen::generate_simple_self_signed(vec!["localhost".into(), "127.0.0.1".into()]).unwrap();
    let (cert, key) = (dir.join("station.crt"), dir.join("station.key"));
    std::fs::write(&cert, c.cert.pem()).unwrap();
    std::fs::write(&key, c.signing_key.serialize_pem()).unwrap();
    private(&key);
    (
        cert.display().to_string(),
        key.display().to_string(),
        c.cert.der().to_vec(),
    )
}

/// Makes a file readable by its owner only (a key or a token, as ssh wants them).
fn private(p: &Path) {
    use std::os::unix::fs::PermissionsExt;
    std::fs::set_permissions(p, std::fs::Permissions::from_mode(0o600)).unwrap();
}

/// Gives a file the mode `mode`.
fn chmod(p: &Path, mode: u32) {
    use std::os::unix::fs::PermissionsExt;
    std::fs::set_permissions(p, std::fs::Permissions::from_mode(mode)).unwrap();
}

/// `GET path` over TLS on 127.0.0.1:`port`, trusting `ca`, with `headers`: the status and body
/// (read to the end: `Connection: close`).
fn https_get(port: u16, ca: &[u8], path: &str, headers: &str) -> (u16, String) {
    let mut roots = rustls::RootCertStore::empty();
    roots
        .add(rustls::pki_types::CertificateDer::from(ca.to_vec()))
        .unwrap();
    let config = rustls::ClientConfig::builder_with_provider(Arc::new(
        rustls::crypto::ring::default_provider(),
    ))
    .with_safe_default_protocol_versions()
    .unwrap()
    .with_root_certificates(roots)
    .with_no_client_auth();
    let name = rustls::pki_types::ServerName::try_from("localhost").unwrap();
    let conn = rustls::ClientConnection::new(Arc::new(config), name).unwrap();
    let sock = TcpStream::connect(("127.0.0.1", port)).unwrap();
    sock.set_read_timeout(Some(Duration::from_secs(20)))
        .unwrap();
    let mut tls = rustls::StreamOwned::new(conn, sock);
    write!(
        tls,
        "GET {path} HTTP/1.1\r\nHost: 127.0.0.1:{port}\r\n{headers}Connection: close\r\n\r\n"
    )
    .unwrap();
    let mut out = Vec::new();
    // The server may close without close_notify after the response: what was read counts.
    let _ = tls.read_to_end(&mut out);
    let text = String::from_utf8_lossy(&out).into_owned();
    let status = text
        .split_whitespace()
        .nth(1)
        .and_then(|c| c.parse().ok())
        .unwrap_or_else(|| panic!("GET {path}: {text:?}"));
    let body = text.split("\r\n\r\n").nth(1).unwrap_or("").to_string();
    (status, body)
}

/// A raw request on `addr`: the status line's code (0 when the connection closed without an
/// HTTP answer).
fn raw_status(addr: &str, request: &str) -> u16 {
    let mut s = TcpStream::connect(addr).unwrap();
    s.set_read_timeout(Some(Duration::from_secs(20))).unwrap();
    let _ = s.write_all(request.as_bytes());
    let mut line = String::new();
    let _ = BufReader::new(&s).read_line(&mut line);
    if !line.starts_with("HTTP/1.") {
        return 0;
    }
    line.split_whitespace()
        .nth(1)
        .and_then(|c| c.parse().ok())
        .unwrap_or(0)
}

#[test]
fn off_loopback_the_dashboard_needs_tls_and_a_token() {
    let d = tempfile::tempdir().unwrap();
    let db = d.path().join("r.sqlite").display().to_string();
    drop(gonio_store::open(&db).unwrap());
    let (cert, key, ca) = certificate(d.path());
    let token_file = d.path().join("token");
    let token = "s3cret-token-of-the-test-0123";
    std::fs::write(&token_file, format!("{token}\n")).unwrap();
    private(&token_file);
    let tf = token_file.display().to_string();

    // Without TLS and a token it does not start, and says what is missing.
    for (extra, missing, present) in [
        (
            vec![],
            vec!["--tls-cert", "--tls-key", "--token-file"],
            vec![],
        ),
        (
            vec!["--token-file", &tf],
            vec!["--tls-cert"],
            vec!["--token-file"],
        ),
        (
            vec!["--tls-cert", &cert, "--tls-key", &key],
            vec!["--token-file"],
            vec!["--tls-cert"],
        ),
    ] {
        let mut a = vec![
            "serve",
            "--db",
            &db,
            "--addr",
            "0.0.0.0:0",
            "--allow-remote",
        ];
        a.extend(extra);
        let o = gonio(&a);
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{a:?}: {err}");
        assert_eq!(err.lines().count(), 1, "{err}");
        for m in missing {
            assert!(err.contains(m), "{a:?}: {err}");
        }
        for p in present {
            assert!(!err.contains(p), "{a:?}: {err}");
        }
    }
    // A token too short, a certificate without its key, a key that is not the certificate's.
    std::fs::write(d.path().join("short"), "abc\n").unwrap();
    private(&d.path().join("short"));
    let short = d.path().join("short").display().to_string();
    let other = rcgen::generate_simple_self_signed(vec!["localhost".into()]).unwrap();
    std::fs::write(
        d.path().join("other.key"),
        other.signing_key.serialize_pem(),
    )
    .unwrap();
    private(&d.path().join("other.key"));
    let other_key = d.path().join("other.key").display().to_string();
    for (a, says) in [
        (vec!["--token-file", short.as_str()], "at least 16"),
        (vec!["--tls-cert", cert.as_str()], "--tls-key"),
        (
            vec![
                "--tls-cert",
                &cert,
                "--tls-key",
                &other_key,
                "--token-file",
                &tf,
            ],
            "--tls-key",
        ),
        (
            vec![
                "--tls-cert",
                &cert,
                "--tls-key",
                &key,
                "--token-file",
                "/nonexistent/t",
            ],
            "/nonexistent/t",
        ),
    ] {
        let mut args = vec![
            "serve",
            "--db",
            &db,
            "--addr",
            "0.0.0.0:0",
            "--allow-remote",
        ];
        args.extend(a);
        let o = gonio(&args);
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{args:?}: {err}");
        assert!(err.contains(says), "{args:?}: {err}");
    }

    // With them: 401 without the token (or with another), 200 with it.
    let (_serve, port) = start(&[
        "serve",
        "--db",
        &db,
        "--addr",
        "0.0.0.0:0",
        "--allow-remote",
        "--tls-cert",
        &cert,
        "--tls-key",
        &key,
        "--token-file",
        &tf,
    ]);
    let (s, body) = https_get(port, &ca, "/api/stats", "");
    assert_eq!(s, 401, "{body}");
    assert!(body.contains("\"error\""), "{body}");
    let (s, _) = https_get(
        port,
        &ca,
        "/api/stats",
        "Authorization: Bearer s3cret-token-of-the-test-0124\r\n",
    );
    assert_eq!(s, 401);
    let auth = format!("Authorization: Bearer {token}\r\n");
    let (s, body) = https_get(port, &ca, "/api/stats", &auth);
    assert_eq!(s, 200, "{body}");
    let v: serde_json::Value = serde_json::from_str(&body).unwrap();
    assert_eq!(v["store"]["parts"], 0);
    let (s, _) = https_get(port, &ca, "/", &auth);
    assert_eq!(s, 200);
    // Plain HTTP on that port gets no HTTP answer at all.
    let addr = format!("127.0.0.1:{port}");
    let plain =
        format!("GET /api/stats HTTP/1.1\r\nHost: {addr}\r\n{auth}Connection: close\r\n\r\n");
    assert_eq!(raw_status(&addr, &plain), 0);
}

#[test]
fn a_token_or_key_open_to_group_or_others_is_refused_as_ssh_does() {
    let d = tempfile::tempdir().unwrap();
    let db = d.path().join("r.sqlite").display().to_string();
    drop(gonio_store::open(&db).unwrap());
    let (cert, key, ca) = certificate(d.path());
    let token_file = d.path().join("token");
    let token = "s3cret-token-of-the-test-0123";
    std::fs::write(&token_file, format!("{token}\n")).unwrap();
    let tf = token_file.display().to_string();
    let remote = |extra: &[&str]| {
        let mut a = vec![
            "serve",
            "--db",
            &db,
            "--addr",
            "0.0.0.0:0",
            "--allow-remote",
            "--tls-cert",
            &cert,
            "--tls-key",
            &key,
            "--token-file",
            &tf,
        ];
        a.extend_from_slice(extra);
        a.into_iter().map(str::to_string).collect::<Vec<_>>()
    };
    for (file, mode, flag) in [
        (token_file.as_path(), 0o644, "--token-file"),
        (token_file.as_path(), 0o640, "--token-file"),
        (Path::new(&key), 0o604, "--tls-key"),
    ] {
        private(&token_file);
        private(Path::new(&key));
        chmod(file, mode);
        let args = remote(&[]);
        let o = gonio(&args.iter().map(String::as_str).collect::<Vec<_>>());
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{err}");
        assert_eq!(err.lines().count(), 1, "{err}");
        assert!(err.starts_with(&format!("error: {flag}: ")), "{err}");
        assert!(err.contains(&format!("mode 0{mode:o}")), "{err}");
        assert!(err.contains("chmod 600") && err.contains("--allow-insecure-permissions"));
    }
    // With --allow-insecure-permissions it serves, and says why it should not.
    private(Path::new(&key));
    chmod(&token_file, 0o644);
    let args = remote(&["--allow-insecure-permissions"]);
    let mut child = std::process::Command::new(env!("CARGO_BIN_EXE_gonio"))
        .args(&args)
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let err = child.stderr.take().unwrap();
    let _serve = Guard(child);
    let (tx, rx) = std::sync::mpsc::channel();
    std::thread::spawn(move || {
        for line in BufReader::new(err).lines().map_while(Result::ok) {
            let _ = tx.send(line);
        }
    });
    let mut seen = Vec::new();
    let line = loop {
        let l = rx
            .recv_timeout(Duration::from_secs(30))
            .unwrap_or_else(|_| panic!("no dashboard line: {seen:?}"));
        if l.contains("gonio dashboard on ") {
            break l;
        }
        seen.push(l);
    };
    assert!(
        seen.iter()
            .any(|l| l.starts_with("warning: --token-file") && l.contains("mode 0644")),
        "{seen:?}"
    );
    let port: u16 = line
        .split("://")
        .nth(1)
        .and_then(|r| r.split('/').next())
        .and_then(|a| a.rsplit(':').next())
        .and_then(|p| p.parse().ok())
        .unwrap_or_else(|| panic!("no port in {line:?}"));
    let auth = format!("Authorization: Bearer {token}\r\n");
    assert_eq!(https_get(port, &ca, "/api/stats", &auth).0, 200);
}

#[test]
fn a_request_head_beyond_its_bound_is_answered_431() {
    let d = tempfile::tempdir().unwrap();
    let db = d.path().join("r.sqlite").display().to_string();
    drop(gonio_store::open(&db).unwrap());
    let (_serve, port) = start(&["serve", "--db", &db, "--addr", "127.0.0.1:0"]);
    let addr = format!("127.0.0.1:{port}");
    let with_header = |bytes: usize| {
        format!(
            "GET /api/stats HTTP/1.1\r\nHost: {addr}\r\nX-Pad: {}\r\nConnection: close\r\n\r\n",
            "a".repeat(bytes)
        )
    };
    assert_eq!(raw_status(&addr, &with_header(8 << 10)), 200);
    assert_eq!(raw_status(&addr, &with_header(32 << 10)), 431);
    // A header line that never ends: refused once the bound is passed, not collected.
    let mut s = TcpStream::connect(&addr).unwrap();
    s.set_read_timeout(Some(Duration::from_secs(20))).unwrap();
    s.write_all(format!("GET /api/stats HTTP/1.1\r\nHost: {addr}\r\nX-Pad: ").as_bytes())
        .unwrap();
    let chunk = vec![b'a'; 64 << 10];
    for _ in 0..16 {
        if s.write_all(&chunk).is_err() {
            break;
        }
    }
    let mut line = String::new();
    let _ = BufReader::new(&s).read_line(&mut line);
    assert!(line.is_empty() || line.contains(" 431 "), "{line:?}");
    assert_eq!(http_get(&addr, "/api/stats").0, 200);
}

#[test]
fn hosts_queries_and_methods_are_answered_in_json() {
    let d = tempfile::tempdir().unwrap();
    let db = d.path().join("r.sqlite").display().to_string();
    drop(gonio_store::open(&db).unwrap());
    let (_serve, port) = start(&[
        "serve",
        "--db",
        &db,
        "--addr",
        "127.0.0.1:0",
        "--host-name",
        "station.test",
    ]);
    let addr = format!("127.0.0.1:{port}");
    // Loopback stays plain HTTP without a token.
    assert_eq!(http_get(&addr, "/api/stats").0, 200);
    for q in [
        "limit=-1",
        "limit=abc",
        "batch=x",
        "limit=99999999999999999999999",
        "since=yesterday",
        "verdict=maybe",
    ] {
        let (s, body) = http_get(&addr, &format!("/api/parts?{q}"));
        assert_eq!(s, 400, "{q}: {body}");
        let v: serde_json::Value =
            serde_json::from_str(&body).unwrap_or_else(|_| panic!("{q}: not JSON: {body:?}"));
        assert!(v["error"].is_string(), "{q}: {body}");
        let (s, body) = http_get(&addr, &format!("/api/stats?{q}"));
        if !q.starts_with("verdict") {
            assert_eq!(s, 400, "{q}: {body}");
            assert!(serde_json::from_str::<serde_json::Value>(&body).is_ok());
        }
    }
    // A POST is refused in JSON too.
    let post = format!(
        "POST /api/parts HTTP/1.1\r\nHost: {addr}\r\nContent-Length: 0\r\nConnection: close\r\n\r\n"
    );
    assert_eq!(raw_status(&addr, &post), 405);

    // The Host header must name this dashboard: a rebound name is refused.
    let get = |host: &str| {
        raw_status(
            &addr,
            &format!("GET /api/stats HTTP/1.1\r\nHost: {host}\r\nConnection: close\r\n\r\n"),
        )
    };
    for host in [
        addr.clone(),
        format!("localhost:{port}"),
        "station.test".into(),
        format!("STATION.test:{port}"),
    ] {
        assert_eq!(get(&host), 200, "{host}");
    }
    for host in [
        format!("evil.example:{port}"),
        "attacker.test".into(),
        format!("127.0.0.2:{port}"),
        format!("localhost.evil.example:{port}"),
    ] {
        assert_eq!(get(&host), 421, "{host}");
    }
    assert_eq!(
        raw_status(&addr, "GET /api/stats HTTP/1.0\r\n\r\n"),
        400,
        "no Host"
    );
}

#[test]
fn clients_that_send_nothing_do_not_lock_the_dashboard_out() {
    let d = tempfile::tempdir().unwrap();
    let db = d.path().join("r.sqlite").display().to_string();
    drop(gonio_store::open(&db).unwrap());
    let (_serve, port) = start(&["serve", "--db", &db, "--addr", "127.0.0.1:0"]);
    let addr = format!("127.0.0.1:{port}");
    // 80 clients that connect and send half a request: the dashboard answers at once.
    let mut idle: Vec<TcpStream> = (0..80)
        .map(|_| {
            let mut s = TcpStream::connect(&addr).unwrap();
            s.write_all(b"GET /api/stats HTTP/1.1\r\nHost: ").unwrap();
            s
        })
        .collect();
    let t = Instant::now();
    assert_eq!(http_get(&addr, "/api/stats").0, 200);
    assert!(t.elapsed() < Duration::from_secs(5), "{:?}", t.elapsed());
    // More than the connection limit (256): they are closed after the 10 s header timeout,
    // and the dashboard answers again well before the next 10 s are out.
    idle.extend((0..300).filter_map(|_| TcpStream::connect(&addr).ok()));
    let t = Instant::now();
    assert_eq!(http_get(&addr, "/api/stats").0, 200);
    assert!(t.elapsed() < Duration::from_secs(20), "{:?}", t.elapsed());
    // Each idle client was closed by the server (reads end) within the timeout and a margin.
    let s = &mut idle[0];
    s.set_read_timeout(Some(Duration::from_secs(15))).unwrap();
    let mut rest = Vec::new();
    let r = s.read_to_end(&mut rest);
    assert!(
        r.is_ok() || matches!(&r, Err(e) if e.kind() == std::io::ErrorKind::ConnectionReset),
        "{r:?}"
    );
}
