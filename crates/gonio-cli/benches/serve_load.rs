//! Load on the dashboard while the station runs: 50 concurrent server-sent-event clients plus
//! 200 API requests per second for 30 s, on loopback, against `gonio serve` with the simulated
//! station in real time. Reports the API's latencies, the events each client received, and the
//! station's frame-loop timing (lateness of each frame against its schedule) with the load and,
//! for comparison, in a run of the same length without it.
//!
//! ```text
//! cargo bench -p gonio --bench serve_load            # 2 × (30 s + warm-up)
//! GONIO_LOAD_SECONDS=10 cargo bench -p gonio --bench serve_load
//! ```
//! Every request goes to 127.0.0.1; the request loops are bounded in count and time.

#[path = "../tests/common/mod.rs"]
mod common;

use serde_json::Value;
use std::io::{Read, Write};
use std::net::TcpStream;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::time::{Duration, Instant};

const SSE_CLIENTS: usize = 50;
const RATE_PER_S: u64 = 200;
const API_WORKERS: u64 = 8;
const WARM_UP: Duration = Duration::from_secs(5);

/// What the API clients ask, in turn: table rows, one whole part, counters, live state, a page
/// of whole parts (the heaviest).
const PATHS: [&str; 5] = [
    "/api/parts?view=summary&limit=100",
    "/api/parts/1",
    "/api/stats",
    "/api/live",
    "/api/parts?limit=10",
];

fn seconds() -> u64 {
    std::env::var("GONIO_LOAD_SECONDS")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(30)
}

/// One SSE client: reads the stream until `stop`, counting events.
fn sse_client(addr: String, stop: Arc<AtomicBool>, events: Arc<AtomicU64>) {
    let Ok(mut s) = TcpStream::connect(&addr) else {
        return;
    };
    let _ = s.set_read_timeout(Some(Duration::from_millis(200)));
    let request =
        format!("GET /api/events HTTP/1.1\r\nHost: {addr}\r\nAccept: text/event-stream\r\n\r\n");
    if s.write_all(request.as_bytes()).is_err() {
        return;
    }
    let mut buf = vec![0u8; 64 * 1024];
    let mut tail = Vec::new();
    while !stop.load(Ordering::Relaxed) {
        match s.read(&mut buf) {
            Ok(0) => break,
            Ok(n) => {
                tail.extend_from_slice(&buf[..n]);
                let text = String::from_utf8_lossy(&tail);
                let k =
                    text.matches("\nevent: ").count() + usize::from(text.starts_with("event: "));
                events.fetch_add(k as u64, Ordering::Relaxed);
                // Keep only an unfinished last line for the next read.
                let cut = tail.iter().rposition(|&b| b == b'\n').map_or(0, |i| i + 1);
                tail.drain(..cut);
            }
            Err(e)
                if matches!(
                    e.kind(),
                    std::io::ErrorKind::WouldBlock | std::io::ErrorKind::TimedOut
                ) => {}
            Err(_) => break,
        }
    }
}

/// The station's frame timing from `/api/status`.
fn timing(addr: &str) -> Value {
    let (status, body) = common::http_get(addr, "/api/status");
    assert_eq!(status, 200, "{body}");
    let v: Value = serde_json::from_str(&body).unwrap();
    v["frame_timing"].clone()
}

/// A store with a history (50 parts mounted before), served with the station running a new
/// batch in real time.
fn serve(db: &str) -> (common::Guard, String) {
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_gonio"))
        .args(["mount", "--sim", "--parts", "50", "--seed", "3", "--db", db])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    common::start_serve(
        env!("CARGO_BIN_EXE_gonio"),
        &[
            "serve",
            "--db",
            db,
            "--station",
            "sim",
            "--parts",
            "1000",
            "--seed",
            "9",
            "--speed",
            "1",
            "--addr",
            "127.0.0.1:0",
        ],
    )
}

/// The nearest-rank quantile (gonio_core::quantile); NaN for no samples.
fn percentile(v: &mut [f64], p: f64) -> f64 {
    gonio_core::quantile::quantile(v, p).unwrap_or(f64::NAN)
}

fn show(label: &str, t: &Value) {
    println!(
        "{label}: {} frames, lateness mean {:.3} ms, p50 {:.3} ms, p99 {:.3} ms, max {:.2} ms; {} frames later than one period ({:.1} ms)",
        t["frames"],
        t["mean_late_ms"].as_f64().unwrap_or(f64::NAN),
        t["p50_late_ms"].as_f64().unwrap_or(f64::NAN),
        t["p99_late_ms"].as_f64().unwrap_or(f64::NAN),
        t["max_late_ms"].as_f64().unwrap_or(f64::NAN),
        t["late_frames"],
        t["period_ms"].as_f64().unwrap_or(f64::NAN),
    );
}

fn main() {
    // `cargo bench` passes --bench; `cargo test --benches` runs benches as tests: do nothing then.
    if !std::env::args().any(|a| a == "--bench") {
        return;
    }
    let secs = seconds();
    let window = Duration::from_secs(secs);
    let dir = tempfile::tempdir().unwrap();

    // Without load.
    let db = dir.path().join("quiet.sqlite").display().to_string();
    let (quiet, addr) = serve(&db);
    std::thread::sleep(WARM_UP + window);
    let base = timing(&addr);
    drop(quiet);

    // With load.
    let db = dir.path().join("load.sqlite").display().to_string();
    let (_loaded, addr) = serve(&db);
    std::thread::sleep(WARM_UP);
    let stop = Arc::new(AtomicBool::new(false));
    let mut sse = Vec::new();
    let mut counts = Vec::new();
    for _ in 0..SSE_CLIENTS {
        let events = Arc::new(AtomicU64::new(0));
        counts.push(events.clone());
        let (a, s) = (addr.clone(), stop.clone());
        sse.push(std::thread::spawn(move || sse_client(a, s, events)));
    }
    let t0 = Instant::now();
    let total = RATE_PER_S * secs;
    let mut workers = Vec::new();
    for w in 0..API_WORKERS {
        let a = addr.clone();
        workers.push(std::thread::spawn(move || {
            let mut lat = Vec::new();
            let (mut errors, mut late_starts) = (0u64, 0u64);
            // Request i is due at t0 + i / rate; worker w sends i ≡ w (mod workers).
            let mut i = w;
            while i < total {
                let due = t0 + Duration::from_secs_f64(i as f64 / RATE_PER_S as f64);
                let now = Instant::now();
                if due > now {
                    std::thread::sleep(due - now);
                } else if now - due > Duration::from_millis(50) {
                    late_starts += 1;
                }
                let t = Instant::now();
                let (status, _) = common::http_get(&a, PATHS[(i % PATHS.len() as u64) as usize]);
                lat.push(t.elapsed().as_secs_f64() * 1e3);
                if status != 200 {
                    errors += 1;
                }
                i += API_WORKERS;
            }
            (lat, errors, late_starts)
        }));
    }
    let mut lat = Vec::new();
    let (mut errors, mut late_starts) = (0, 0);
    for w in workers {
        let (l, e, s) = w.join().unwrap();
        lat.extend(l);
        errors += e;
        late_starts += s;
    }
    let took = t0.elapsed().as_secs_f64();
    let loaded = timing(&addr);
    stop.store(true, Ordering::Relaxed);
    for h in sse {
        let _ = h.join();
    }
    let ev: Vec<u64> = counts.iter().map(|c| c.load(Ordering::Relaxed)).collect();

    println!(
        "gonio serve under load: {SSE_CLIENTS} SSE clients + {RATE_PER_S} API requests/s for {secs} s (loopback, station at real time, {API_WORKERS} request threads)"
    );
    println!(
        "API: {} requests in {took:.1} s ({:.0}/s), {errors} errors, {late_starts} sent > 50 ms late; latency p50 {:.2} ms, p99 {:.2} ms, max {:.1} ms",
        lat.len(),
        lat.len() as f64 / took,
        percentile(&mut lat, 0.5),
        percentile(&mut lat, 0.99),
        percentile(&mut lat, 1.0),
    );
    println!(
        "SSE: events per client min {} / max {} (every client connected: {})",
        ev.iter().min().unwrap_or(&0),
        ev.iter().max().unwrap_or(&0),
        ev.iter().all(|&n| n > 0)
    );
    show("frame loop without load", &base);
    show("frame loop with load   ", &loaded);
}
