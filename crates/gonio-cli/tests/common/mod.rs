//! Helpers shared by the CLI tests (and the `serve_load` bench): running `gonio`, the
//! examples' paths, JSON key paths, and for the dashboard a child process killed when dropped,
//! a line awaited on its standard error, plain HTTP GETs on loopback; for the PLC tests the
//! pymodbus virtualenv and a hostile PLC on it.
#![allow(dead_code)] // each test uses some of them

use serde_json::Value;
use std::collections::BTreeSet;
use std::io::{BufRead, BufReader, Read, Write};
use std::net::TcpStream;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Output};
use std::sync::mpsc;
use std::time::Duration;

/// Runs the `gonio` binary under test.
pub fn gonio(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_gonio"))
        .args(args)
        .output()
        .expect("gonio runs")
}

/// Runs `gonio`, asserting success; its standard output and standard error.
pub fn ok(args: &[&str]) -> (String, String) {
    let o = gonio(args);
    let (out, err) = (
        String::from_utf8_lossy(&o.stdout).into_owned(),
        String::from_utf8_lossy(&o.stderr).into_owned(),
    );
    assert!(o.status.success(), "gonio {args:?}: {err}");
    (out, err)
}

/// A run's standard error as text.
pub fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// A run's standard output as text.
pub fn stdout(o: &Output) -> String {
    String::from_utf8_lossy(&o.stdout).into_owned()
}

/// A file of the repository, by its path from the repository's root.
pub fn repo(path: &str) -> String {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../..")
        .join(path)
        .display()
        .to_string()
}

/// A file of the repository's `examples/`.
pub fn example(name: &str) -> String {
    repo(&format!("examples/{name}"))
}

/// A simulated lab in `dir`: an encoder (`--seed encoder_seed`), then shift-angle readings
/// (shifts 0…14°) and SelfA head readings (3600 positions) of it, each simulation with its
/// `extra` arguments (seed, σ, repeats); the two readings files (shift-angle, selfcal).
pub fn simulated_lab(
    dir: &Path,
    encoder_seed: &str,
    shift_angle: &[&str],
    selfcal: &[&str],
) -> (PathBuf, PathBuf) {
    let (enc, lab, heads) = (dir.join("enc.json"), dir.join("lab"), dir.join("heads"));
    let [enc_s, lab_s, heads_s] = [&enc, &lab, &heads].map(|p| p.display().to_string());
    ok(&[
        "simulate",
        "encoder",
        "--seed",
        encoder_seed,
        "--out",
        &enc_s,
    ]);
    let sa = [
        "simulate",
        "shift-angle",
        "--encoder",
        &enc_s,
        "--shifts",
        "0:1:14",
    ];
    ok(&[&sa[..], shift_angle, &["--out", &lab_s]].concat());
    let sc = [
        "simulate",
        "selfcal",
        "--encoder",
        &enc_s,
        "--heads",
        "selfa12",
    ];
    ok(&[
        &sc[..],
        &["--positions", "3600"],
        selfcal,
        &["--out", &heads_s],
    ]
    .concat());
    (lab.join("readings.csv"), heads.join("readings.csv"))
}

/// The frozen key list `tests/data/json-keys-NAME.txt`: every key path a command's JSON wrote
/// before (a contract; `#` lines are comments).
pub fn frozen_keys(name: &str) -> BTreeSet<String> {
    let p = Path::new(env!("CARGO_MANIFEST_DIR")).join(format!("tests/data/json-keys-{name}.txt"));
    std::fs::read_to_string(&p)
        .unwrap_or_else(|e| panic!("{}: {e}", p.display()))
        .lines()
        .filter(|l| !l.starts_with('#') && !l.is_empty())
        .map(String::from)
        .collect()
}

/// Every key path of a JSON value into `out` (`edges[].slope` for the members of an array's
/// objects): the shape of an output, for contract tests.
pub fn key_paths(v: &Value, prefix: &str, out: &mut BTreeSet<String>) {
    match v {
        Value::Object(m) => {
            for (k, x) in m {
                let p = if prefix.is_empty() {
                    k.clone()
                } else {
                    format!("{prefix}.{k}")
                };
                out.insert(p.clone());
                key_paths(x, &p, out);
            }
        }
        Value::Array(a) => {
            for x in a {
                key_paths(x, &format!("{prefix}[]"), out);
            }
        }
        _ => {}
    }
}

/// Kills a child process when dropped (the test never leaves one running).
pub struct Guard(pub Child);

impl Drop for Guard {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

/// The rest of `child`'s standard error (piped and not taken yet), once it has exited.
pub fn read_stderr(child: &mut Child) -> String {
    let mut err = String::new();
    if let Some(mut e) = child.stderr.take() {
        let _ = e.read_to_string(&mut err);
    }
    err
}

/// The first line of `child`'s standard error that contains `marker`, within `limit`; the
/// rest of its standard error is drained in the background (and kept for messages).
pub fn wait_for_line(child: &mut Child, marker: &'static str, limit: Duration) -> String {
    let err = child.stderr.take().expect("stderr piped");
    let (tx, rx) = mpsc::channel();
    std::thread::spawn(move || {
        let mut sent = false;
        for line in BufReader::new(err).lines().map_while(Result::ok) {
            if !sent && line.contains(marker) {
                let _ = tx.send(line);
                sent = true;
            }
        }
    });
    rx.recv_timeout(limit)
        .unwrap_or_else(|_| panic!("no line with {marker:?} within {limit:?}"))
}

/// A test virtualenv under target/ (`target/NAME`) whose Python passes `check` (a `-c`
/// program), made here with `pip install PACKAGES` when it does not. Tests of one binary run in
/// parallel and test binaries may run side by side: the making is serialised by a lock within the
/// process and a file lock (`target/NAME.lock`) between processes, so two tests never run
/// `python3 -m venv` on the same directory at once.
pub fn venv_python(name: &str, check: &str, packages: &[&str]) -> PathBuf {
    static MAKING: std::sync::Mutex<()> = std::sync::Mutex::new(());
    let dir = PathBuf::from(repo(&format!("target/{name}")));
    let py = dir.join("bin/python");
    let has = |py: &PathBuf| {
        Command::new(py)
            .args(["-c", check])
            .stderr(std::process::Stdio::null())
            .status()
            .is_ok_and(|s| s.success())
    };
    let _in_process = MAKING.lock().unwrap_or_else(|e| e.into_inner());
    let lock_path = PathBuf::from(repo(&format!("target/{name}.lock")));
    if let Some(parent) = lock_path.parent() {
        std::fs::create_dir_all(parent).expect("target/ can be made");
    }
    let lock = std::fs::File::create(&lock_path)
        .unwrap_or_else(|e| panic!("cannot open the lock {}: {e}", lock_path.display()));
    lock.lock()
        .unwrap_or_else(|e| panic!("cannot lock {}: {e}", lock_path.display()));
    if !has(&py) {
        let ok = Command::new("python3")
            .args(["-m", "venv"])
            .arg(&dir)
            .status()
            .is_ok_and(|s| s.success())
            && Command::new(&py)
                .args(["-m", "pip", "install", "--quiet"])
                .args(packages)
                .status()
                .is_ok_and(|s| s.success());
        assert!(
            ok,
            "cannot make the virtualenv with {} in {}",
            packages.join(", "),
            dir.display()
        );
    }
    assert!(
        has(&py),
        "{} not importable from {} (check: {check})",
        packages.join(", "),
        py.display()
    );
    py
}

/// The PLC tests' virtualenv with pymodbus (target/plc-venv, made here when missing): the
/// client of `examples/plc/pymodbus_check.py` and the server of `tests/plc/hostile_plc.py`.
pub fn plc_venv_python() -> PathBuf {
    // The hostile PLC's server needs pymodbus's SimDevice with its `action` (3.16 on).
    venv_python(
        "plc-venv",
        "import pymodbus.client; from pymodbus.simulator import SimDevice; \
         assert 'action' in SimDevice.__dataclass_fields__",
        &["pymodbus>=3.16,<4"],
    )
}

/// A hostile PLC (`tests/plc/hostile_plc.py` on pymodbus) in its own process, on 127.0.0.1
/// with a free port, killed when dropped; its log of the commands it took.
pub struct HostilePlc {
    /// The process.
    pub child: Guard,
    /// `127.0.0.1:PORT`.
    pub addr: String,
    lines: std::sync::Arc<std::sync::Mutex<Vec<String>>>,
}

/// A command the hostile PLC took: its word, sequence number, first argument, and its time
/// (s since the PLC started).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Taken {
    /// The command word.
    pub cmd: u16,
    /// The sequence number.
    pub seq: u16,
    /// The first argument.
    pub arg0: i64,
    /// When, s since the PLC started.
    pub t_s: f64,
}

impl HostilePlc {
    /// Starts the hostile PLC with `args` (`--stuck-on 4`, `--slow 4=30`, `--simulated`).
    pub fn start(args: &[&str]) -> HostilePlc {
        let py = plc_venv_python();
        let mut child = std::process::Command::new(py)
            .arg(repo("crates/gonio-cli/tests/plc/hostile_plc.py"))
            .args(args)
            .stdin(std::process::Stdio::null())
            .stdout(std::process::Stdio::piped())
            .stderr(std::process::Stdio::null())
            .spawn()
            .expect("python runs");
        let out = child.stdout.take().expect("stdout piped");
        let lines = std::sync::Arc::new(std::sync::Mutex::new(Vec::new()));
        let (tx, rx) = mpsc::channel();
        let keep = lines.clone();
        std::thread::spawn(move || {
            for line in BufReader::new(out).lines().map_while(Result::ok) {
                if let Some(addr) = line.strip_prefix("hostile PLC on ") {
                    let _ = tx.send(addr.to_string());
                } else {
                    keep.lock().unwrap().push(line);
                }
            }
        });
        let child = Guard(child);
        let addr = rx
            .recv_timeout(Duration::from_secs(30))
            .expect("the hostile PLC listens within 30 s");
        HostilePlc { child, addr, lines }
    }

    /// The commands taken so far, in order.
    pub fn taken(&self) -> Vec<Taken> {
        self.lines
            .lock()
            .unwrap()
            .iter()
            .map(|l| {
                let w: Vec<&str> = l.split_whitespace().collect();
                assert!(w.len() == 8 && w[0] == "command", "hostile PLC: {l:?}");
                Taken {
                    cmd: w[1].parse().unwrap(),
                    seq: w[3].parse().unwrap(),
                    arg0: w[5].parse().unwrap(),
                    t_s: w[7].parse().unwrap(),
                }
            })
            .collect()
    }

    /// Sends the process `signal` (`-STOP`, `-KILL`).
    pub fn signal(&self, signal: &str) {
        let ok = std::process::Command::new("kill")
            .args([signal, &self.child.0.id().to_string()])
            .status()
            .is_ok_and(|s| s.success());
        assert!(ok, "kill {signal} the hostile PLC");
    }
}

/// Sends `GET path` to `addr` (`host:port`) over plain HTTP/1.1 and reads the response's head:
/// the reader, at the body; the status; the headers (names lower-cased, values trimmed). A read
/// waits at most `timeout`.
pub fn http_head(
    addr: &str,
    path: &str,
    timeout: Duration,
) -> (BufReader<TcpStream>, u16, Vec<(String, String)>) {
    let s = TcpStream::connect(addr).unwrap_or_else(|e| panic!("connect {addr}: {e}"));
    s.set_read_timeout(Some(timeout)).unwrap();
    (&s).write_all(
        format!("GET {path} HTTP/1.1\r\nHost: {addr}\r\nConnection: close\r\n\r\n").as_bytes(),
    )
    .unwrap();
    let mut r = BufReader::new(s);
    let mut status_line = String::new();
    r.read_line(&mut status_line)
        .unwrap_or_else(|e| panic!("GET {path}: {e}"));
    let status = status_line
        .split_whitespace()
        .nth(1)
        .and_then(|c| c.parse().ok())
        .unwrap_or_else(|| panic!("GET {path}: {status_line:?}"));
    let mut headers = Vec::new();
    loop {
        let mut h = String::new();
        r.read_line(&mut h).unwrap();
        if h.trim().is_empty() {
            break;
        }
        if let Some((k, v)) = h.split_once(':') {
            headers.push((k.trim().to_ascii_lowercase(), v.trim().to_string()));
        }
    }
    (r, status, headers)
}

/// `GET path` on `host:port` over plain HTTP/1.1: (status, body). Reads the body by its
/// `Content-Length`, or its chunks when it is streamed.
pub fn http_get(addr: &str, path: &str) -> (u16, String) {
    let (mut r, status, headers) = http_head(addr, path, Duration::from_secs(20));
    let header = |k: &str| {
        headers
            .iter()
            .find(|(n, _)| n == k)
            .map(|(_, v)| v.as_str())
    };
    let length: usize = header("content-length").map_or(0, |v| v.parse().unwrap());
    let chunked = header("transfer-encoding") == Some("chunked");
    let mut body = Vec::new();
    if chunked {
        // A streamed body (`/api/parts`): chunks of a hexadecimal size line, data, CRLF.
        loop {
            let mut size = String::new();
            r.read_line(&mut size).unwrap();
            let n = usize::from_str_radix(size.trim(), 16)
                .unwrap_or_else(|_| panic!("GET {path}: chunk size {size:?}"));
            let mut chunk = vec![0; n + 2];
            r.read_exact(&mut chunk)
                .unwrap_or_else(|e| panic!("GET {path}: chunk of {n} bytes: {e}"));
            if n == 0 {
                break;
            }
            body.extend_from_slice(&chunk[..n]);
        }
    } else {
        body.resize(length, 0);
        r.read_exact(&mut body)
            .unwrap_or_else(|e| panic!("GET {path}: body of {length} bytes: {e}"));
    }
    (status, String::from_utf8_lossy(&body).into_owned())
}

/// Starts `gonio` (the binary at `exe`) with `args` ending in `--addr 127.0.0.1:0`; the child
/// and the dashboard's address (`127.0.0.1:PORT`) once it listens.
pub fn start_serve(exe: &str, args: &[&str]) -> (Guard, String) {
    let mut child = std::process::Command::new(exe)
        .args(args)
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .expect("gonio serve starts");
    let line = wait_for_line(
        &mut child,
        "gonio dashboard on http://",
        Duration::from_secs(30),
    );
    let addr = line
        .split("http://")
        .nth(1)
        .and_then(|r| r.split('/').next())
        .expect("the address")
        .to_string();
    (Guard(child), addr)
}
