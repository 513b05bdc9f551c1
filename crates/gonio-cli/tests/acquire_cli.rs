//! `gonio acquire shift-angle` against an autocollimator emulated on a pseudo-terminal by an
//! independent Python script (tests/lab/elcomat_emulator.py), through the line protocol; and
//! end to end with gonio's own simulator (`gonio simulate autocollimator --pty`).
//!
//! Needs python3 (the emulator) and tmux (the operator's full-screen view); a test without
//! them fails naming the missing tool (`.ci/run` installs both).

mod common;

use common::gonio;
use std::io::{BufRead, BufReader, Write};
use std::path::{Path, PathBuf};
use std::process::{Child, ChildStdin, Command, Stdio};
use std::sync::mpsc::{Receiver, channel};
use std::time::{Duration, Instant};

const EMULATOR: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/lab/elcomat_emulator.py");

/// A plan of 10 positions: 4 faces, shifts 0° and 10°, start face 1, with closure readings.
const PLAN: &str = "faces = 4\nshifts_deg = [0, 10]\nstart_faces = [1]\nclosure = true\n";

/// The planned positions of [`PLAN`]: (shift, start face, step, repeat).
fn positions() -> Vec<(u32, u32, u32, u32)> {
    let mut v = Vec::new();
    for s in [0, 10] {
        for step in 1..=4 {
            v.push((s, 1, step, 1));
        }
        v.push((s, 1, 1, 2));
    }
    v
}

/// Fails the test, naming python3, when it is not installed (the emulated instrument is a
/// Python script).
fn need_python3() {
    let ok = Command::new("python3")
        .arg("--version")
        .output()
        .is_ok_and(|o| o.status.success());
    assert!(
        ok,
        "python3 is not installed: the emulated instrument (tests/lab/elcomat_emulator.py) needs it (.ci/run installs it)"
    );
}

/// A child process killed when dropped, its stdout lines on a channel.
struct Proc {
    child: Child,
    stdin: Option<ChildStdin>,
    lines: Receiver<String>,
}

impl Proc {
    fn spawn(cmd: &mut Command) -> Proc {
        let mut child = cmd
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .expect("spawns");
        let out = child.stdout.take().unwrap();
        let (tx, lines) = channel();
        std::thread::spawn(move || {
            for l in BufReader::new(out).lines() {
                let Ok(l) = l else { break };
                if tx.send(l).is_err() {
                    break;
                }
            }
        });
        let stdin = child.stdin.take();
        Proc {
            child,
            stdin,
            lines,
        }
    }

    /// The next stdout line, within 10 s.
    fn line(&self) -> String {
        self.lines
            .recv_timeout(Duration::from_secs(10))
            .expect("a line within 10 s")
    }

    /// The next stdout line starting with `prefix` (others skipped).
    fn expect(&self, prefix: &str) -> String {
        loop {
            let l = self.line();
            if l.starts_with(prefix) {
                return l;
            }
        }
    }

    fn send(&mut self, line: &str) {
        let i = self.stdin.as_mut().unwrap();
        i.write_all(format!("{line}\n").as_bytes()).unwrap();
        i.flush().unwrap();
    }

    /// Waits for the exit (at most `limit`): (code, stderr, time taken).
    fn wait(mut self, limit: Duration) -> (i32, String, Duration) {
        let t0 = Instant::now();
        loop {
            if let Some(s) = self.child.try_wait().unwrap() {
                let mut err = String::new();
                use std::io::Read;
                self.child
                    .stderr
                    .take()
                    .unwrap()
                    .read_to_string(&mut err)
                    .unwrap();
                return (s.code().unwrap_or(-1), err, t0.elapsed());
            }
            assert!(t0.elapsed() < limit, "no exit within {limit:?}");
            std::thread::sleep(Duration::from_millis(20));
        }
    }
}

impl Drop for Proc {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// The emulated instrument answering `answers` (from answer `skip` on); its port.
fn emulator(dir: &Path, answers: &[String], skip: usize) -> (Proc, String) {
    let file = dir.join(format!("answers-{skip}.txt"));
    std::fs::write(&file, answers.join("\n") + "\n").unwrap();
    let p = Proc::spawn(
        Command::new("python3")
            .arg(EMULATOR)
            .arg("--answers")
            .arg(&file)
            .arg("--skip")
            .arg(skip.to_string())
            .arg("--max-s")
            .arg("120"),
    );
    let port = p.line();
    assert!(port.starts_with("/dev/"), "{port}");
    (p, port)
}

fn acquire(dir: &Path, port: &str, extra: &[&str]) -> Proc {
    std::fs::write(dir.join("plan.toml"), PLAN).unwrap();
    Proc::spawn(
        Command::new(env!("CARGO_BIN_EXE_gonio"))
            .current_dir(dir)
            .args([
                "acquire",
                "shift-angle",
                "--plan",
                "plan.toml",
                "--port",
                port,
                "--out",
                "readings.csv",
            ])
            .args(extra),
    )
}

/// Position k's three samples: X = 1 + k/10 + s/1000 arcsec.
fn samples(k: usize) -> Vec<String> {
    (0..3)
        .map(|s| {
            format!(
                "4 003 {:+.3} -0.210",
                1.0 + k as f64 * 0.1 + s as f64 * 0.001
            )
        })
        .collect()
}

/// The answers of the whole plan, with a flagged answer at position 2 and garbage at 6; and
/// where each position's answers start.
fn answers() -> (Vec<String>, Vec<usize>) {
    let mut a = Vec::new();
    let mut starts = Vec::new();
    for k in 0..positions().len() {
        starts.push(a.len());
        let mut s = samples(k);
        if k == 2 {
            s.insert(1, "4 013 +99.999 +0.000".into());
        }
        if k == 6 {
            s.insert(0, "RAW:ff0034203030332078".into());
        }
        a.extend(s);
    }
    starts.push(a.len());
    (a, starts)
}

/// The CSV the answers make: the mean of each position's samples, one decimal more.
fn expected_rows() -> Vec<String> {
    positions()
        .iter()
        .enumerate()
        .map(|(k, (s, f, i, r))| {
            let mean = 1.0 + k as f64 * 0.1 + 0.001;
            format!("{s},{f},{i},{r},{mean:.4}")
        })
        .collect()
}

fn data_lines(csv: &str) -> Vec<String> {
    csv.lines()
        .filter(|l| !l.starts_with('#'))
        .map(str::to_string)
        .collect()
}

/// Reads positions `from..to` through the line protocol, checking each NEXT and READ line.
fn read_positions(a: &mut Proc, from: usize, to: usize) {
    let pos = positions();
    let rows = expected_rows();
    for k in from..to {
        let (s, f, i, r) = pos[k];
        let next = a.expect("NEXT ");
        assert_eq!(
            next,
            format!("NEXT shift_deg={s} start_face={f} step={i} repeat={r}")
        );
        a.send("");
        let read = a.expect("READ ");
        let x = rows[k].rsplit(',').next().unwrap();
        assert_eq!(
            read,
            format!(
                "READ shift_deg={s} start_face={f} step={i} repeat={r} x_arcsec={x} spread_arcsec=0.002"
            )
        );
    }
}

#[test]
fn a_plan_is_acquired_with_what_the_instrument_said_and_its_log_imports_back() {
    need_python3();
    let d = tempfile::tempdir().unwrap();
    let (answers, _) = answers();
    let (_inst, port) = emulator(d.path(), &answers, 0);
    let mut a = acquire(d.path(), &port, &["--log", "raw.log"]);
    read_positions(&mut a, 0, 10);
    let (code, err, _) = a.wait(Duration::from_secs(10));
    assert_eq!(code, 0, "{err}");
    let csv = std::fs::read_to_string(d.path().join("readings.csv")).unwrap();
    let mut want = vec!["shift_deg,start_face,step,repeat,reading_arcsec".to_string()];
    want.extend(expected_rows());
    assert_eq!(data_lines(&csv), want);
    // The flagged reading and the garbage never reach the readings.
    assert!(!csv.contains("99.99"), "{csv}");
    // The log keeps what was sent, and imports to the same CSV.
    let log = std::fs::read_to_string(d.path().join("raw.log")).unwrap();
    assert!(log.contains("#! 4 013 +99.999 +0.000\r\n"), "{log}");
    assert!(log.contains("#! \\xff\\x004 003 x\r\n"), "{log}");
    assert!(log.contains("#> 4 003 +1.200 -0.210\r\n"), "{log}");
    let o = gonio(&[
        "import",
        "elcomat",
        d.path().join("raw.log").to_str().unwrap(),
        "--plan",
        d.path().join("plan.toml").to_str().unwrap(),
        "--out",
        d.path().join("imported.csv").to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let imported = std::fs::read_to_string(d.path().join("imported.csv")).unwrap();
    assert_eq!(data_lines(&imported), data_lines(&csv));
}

#[test]
fn quit_half_way_then_resume_gives_the_csv_of_one_uninterrupted_run() {
    need_python3();
    let (answers, starts) = answers();
    // One uninterrupted run.
    let whole = tempfile::tempdir().unwrap();
    let (_i1, port) = emulator(whole.path(), &answers, 0);
    let mut a = acquire(whole.path(), &port, &[]);
    read_positions(&mut a, 0, 10);
    assert_eq!(a.wait(Duration::from_secs(10)).0, 0);
    let want = std::fs::read(whole.path().join("readings.csv")).unwrap();
    // Quit after 4 positions, resume with the instrument where it was.
    let d = tempfile::tempdir().unwrap();
    let (_i2, port) = emulator(d.path(), &answers, 0);
    let mut a = acquire(d.path(), &port, &[]);
    read_positions(&mut a, 0, 4);
    a.expect("NEXT ");
    a.send("quit");
    let (code, err, _) = a.wait(Duration::from_secs(10));
    assert_eq!(code, 0, "{err}");
    assert!(err.contains("--resume"), "{err}");
    assert!(!d.path().join("readings.csv").exists());
    // Without --resume the journal is not overwritten.
    let b = acquire(d.path(), &port, &[]);
    let (code, err, _) = b.wait(Duration::from_secs(10));
    assert_eq!(code, 2);
    assert!(
        err.contains("--resume") && err.lines().count() == 1,
        "{err}"
    );
    drop(_i2);
    let (_i3, port) = emulator(d.path(), &answers, starts[4]);
    let mut a = acquire(d.path(), &port, &["--resume"]);
    read_positions(&mut a, 4, 10);
    let (code, err, _) = a.wait(Duration::from_secs(10));
    assert_eq!(code, 0, "{err}");
    assert_eq!(
        String::from_utf8(std::fs::read(d.path().join("readings.csv")).unwrap()).unwrap(),
        String::from_utf8(want).unwrap()
    );
}

#[test]
fn a_silent_instrument_ends_with_exit_2_within_5_s_naming_the_port_and_nothing_is_lost() {
    need_python3();
    let (answers, starts) = answers();
    let d = tempfile::tempdir().unwrap();
    // Three positions answered, then silence.
    let (_i, port) = emulator(d.path(), &answers[..starts[3]], 0);
    let mut a = acquire(d.path(), &port, &[]);
    read_positions(&mut a, 0, 3);
    a.expect("NEXT ");
    let t0 = Instant::now();
    a.send("");
    let (code, err, _) = a.wait(Duration::from_secs(10));
    let took = t0.elapsed();
    assert_eq!(code, 2, "{err}");
    assert!(took < Duration::from_secs(5), "{took:?}");
    assert_eq!(err.lines().count(), 1, "{err}");
    assert!(
        err.contains(&port) && err.contains("did not answer") && err.contains("--resume"),
        "{err}"
    );
    // Nothing acquired is lost: resumed with an instrument that answers, the CSV is whole.
    let (_i2, port) = emulator(d.path(), &answers, starts[3]);
    let mut a = acquire(d.path(), &port, &["--resume"]);
    read_positions(&mut a, 3, 10);
    assert_eq!(a.wait(Duration::from_secs(10)).0, 0);
    let csv = std::fs::read_to_string(d.path().join("readings.csv")).unwrap();
    assert_eq!(data_lines(&csv)[1..], expected_rows()[..]);
}

#[test]
fn a_pulled_adapter_ends_with_exit_2_and_the_readings_are_kept() {
    need_python3();
    let (answers, starts) = answers();
    let d = tempfile::tempdir().unwrap();
    let mut cut: Vec<String> = answers[..starts[2] + 1].to_vec();
    cut.push("HANGUP".into());
    let (_i, port) = emulator(d.path(), &cut, 0);
    let mut a = acquire(d.path(), &port, &[]);
    read_positions(&mut a, 0, 2);
    a.expect("NEXT ");
    a.send("");
    let (code, err, took) = a.wait(Duration::from_secs(10));
    assert_eq!(code, 2, "{err}");
    assert!(took < Duration::from_secs(5));
    assert_eq!(err.lines().count(), 1, "{err}");
    assert!(err.contains(&port) && err.contains("lost"), "{err}");
    let journal = std::fs::read_to_string(d.path().join("readings.csv.journal")).unwrap();
    assert_eq!(journal.lines().filter(|l| l.starts_with("R\t")).count(), 2);
    let (_i2, port) = emulator(d.path(), &answers, starts[2]);
    let mut a = acquire(d.path(), &port, &["--resume"]);
    read_positions(&mut a, 2, 10);
    assert_eq!(a.wait(Duration::from_secs(10)).0, 0);
    let csv = std::fs::read_to_string(d.path().join("readings.csv")).unwrap();
    assert_eq!(data_lines(&csv)[1..], expected_rows()[..]);
}

#[test]
fn flagged_readings_are_asked_about_and_a_skip_is_a_missing_reading() {
    need_python3();
    let d = tempfile::tempdir().unwrap();
    let mut answers: Vec<String> = samples(0);
    // Position 1: four flagged answers in a row (more than 3): the operator is asked.
    answers.extend((0..4).map(|k| format!("4 013 +5{k}.000 +0.000")));
    // Position 2: a set spread 0.5″ (over the default 0.25″), then a good set.
    answers.extend(["4 003 +1.000 0", "4 003 +1.500 0", "4 003 +1.200 0"].map(String::from));
    answers.extend(samples(2));
    for k in 3..10 {
        answers.extend(samples(k));
    }
    let (_i, port) = emulator(d.path(), &answers, 0);
    let mut a = acquire(d.path(), &port, &["--log", "raw.log"]);
    read_positions(&mut a, 0, 1);
    a.expect("NEXT ");
    a.send("");
    let ask = a.expect("ASK ");
    assert!(ask.contains("4 013 +53.000"), "{ask}");
    a.send("skip");
    assert_eq!(
        a.expect("SKIPPED "),
        "SKIPPED shift_deg=0 start_face=1 step=2 repeat=1"
    );
    read_positions(&mut a, 2, 10);
    let (code, err, _) = a.wait(Duration::from_secs(10));
    assert_eq!(code, 0, "{err}");
    let csv = std::fs::read_to_string(d.path().join("readings.csv")).unwrap();
    let mut want = expected_rows();
    want.remove(1);
    assert_eq!(data_lines(&csv)[1..], want[..]);
    assert!(
        csv.starts_with("# gonio acquire shift-angle --plan plan.toml (9 readings, 1 missing)\n")
    );
    assert!(!csv.contains(",5") && !csv.contains(",1.2333"), "{csv}");
    let log = std::fs::read_to_string(d.path().join("raw.log")).unwrap();
    assert!(log.contains("step 2: skipped"), "{log}");
    assert!(log.contains("#- 4 003 +1.500 0\r\n"), "{log}");
}

#[test]
fn a_missing_or_busy_port_is_one_line_and_exit_2() {
    let d = tempfile::tempdir().unwrap();
    let a = acquire(d.path(), "/dev/gonio-no-such-port", &[]);
    let (code, err, _) = a.wait(Duration::from_secs(10));
    assert_eq!(code, 2);
    assert_eq!(err.lines().count(), 1, "{err}");
    assert!(err.contains("/dev/gonio-no-such-port"), "{err}");
    assert!(!d.path().join("readings.csv.journal").exists());
    need_python3();
    let (answers, _) = answers();
    let (_i, port) = emulator(d.path(), &answers, 0);
    let a = acquire(d.path(), &port, &[]);
    a.expect("NEXT ");
    // A second program on the same port, another output.
    let other = d.path().join("other");
    std::fs::create_dir(&other).unwrap();
    let b = acquire(&other, &port, &[]);
    let (code, err, _) = b.wait(Duration::from_secs(10));
    assert_eq!(code, 2);
    assert_eq!(err.lines().count(), 1, "{err}");
    assert!(err.contains(&port) && err.contains("busy"), "{err}");
    drop(a);
}

#[test]
fn gonio_simulator_end_to_end_acquire_then_shift_angle_recovers_alpha() {
    let d = tempfile::tempdir().unwrap();
    let plan = "faces = 12\nshifts_deg = [0, 5, 10]\nstart_faces = [1]\n\n[[shift]]\nshift_deg = 0\nstart_faces = \"all\"\n";
    std::fs::write(d.path().join("plan.toml"), plan).unwrap();
    let truth = d.path().join("truth.json");
    let mut sim = Proc::spawn(Command::new(env!("CARGO_BIN_EXE_gonio")).args([
        "simulate",
        "autocollimator",
        "--pty",
        "--faces",
        "12",
        "--seed",
        "7",
        "--sigma",
        "0.03",
        "--flagged",
        "0.05",
        "--duration-s",
        "300",
        "--plan",
        d.path().join("plan.toml").to_str().unwrap(),
        "--truth",
        truth.to_str().unwrap(),
    ]));
    let port = sim.line();
    let mut a = Proc::spawn(
        Command::new(env!("CARGO_BIN_EXE_gonio"))
            .current_dir(d.path())
            .args(["acquire", "shift-angle", "--plan", "plan.toml", "--port"])
            .arg(&port)
            .args(["--out", "readings.csv", "--sigma-arcsec", "0.03"]),
    );
    let mut n = 0;
    loop {
        let l = a.line();
        if l.starts_with("NEXT ") {
            // The operator turns the polygon, then asks for the reading.
            sim.send(&l);
            sim.expect("SET ");
            a.send("");
            n += 1;
        } else if l.starts_with("ASK ") {
            a.send("");
        }
        if n == 144 + 2 * 12 {
            break;
        }
    }
    a.expect("READ ");
    let (code, err, _) = a.wait(Duration::from_secs(20));
    assert_eq!(code, 0, "{err}");
    let json = d.path().join("cal.json");
    let o = gonio(&[
        "shift-angle",
        d.path().join("readings.csv").to_str().unwrap(),
        "--json",
        json.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let cal: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    let truth: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&truth).unwrap()).unwrap();
    let alpha = cal["encoder_errors"].as_array().unwrap();
    assert_eq!(alpha.len(), 36);
    let mut worst: f64 = 0.0;
    for t in truth["encoder_errors"].as_array().unwrap() {
        let a = alpha
            .iter()
            .find(|a| {
                (a["angle_deg"].as_f64().unwrap() - t["angle_deg"].as_f64().unwrap()).abs() < 1e-9
            })
            .unwrap();
        let err = a["value_arcsec"].as_f64().unwrap() - t["value_arcsec"].as_f64().unwrap();
        let u = a["u_arcsec"].as_f64().unwrap();
        worst = worst.max((err / u).abs());
        // 36 angles: |z| > 5 has probability 2e-5 for the lot.
        assert!(
            err.abs() < 5.0 * u,
            "angle {}: error {err}, u {u}",
            t["angle_deg"]
        );
    }
    eprintln!("end to end: worst |α − truth|/u = {worst:.2} over 36 angles");
}

/// A path for tmux's socket, private to the test.
fn tmux_socket(d: &Path) -> PathBuf {
    d.join("tmux.sock")
}

#[test]
fn the_operator_view_under_tmux_reads_and_quits() {
    assert!(
        Command::new("tmux").arg("-V").output().is_ok(),
        "tmux is not installed: the operator's full-screen view is tested under it (.ci/run installs it)"
    );
    let d = tempfile::tempdir().unwrap();
    let plan = "faces = 6\nshifts_deg = [0]\nstart_faces = [1]\n";
    std::fs::write(d.path().join("plan.toml"), plan).unwrap();
    let sim = Proc::spawn(Command::new(env!("CARGO_BIN_EXE_gonio")).args([
        "simulate",
        "autocollimator",
        "--pty",
        "--faces",
        "6",
        "--flagged",
        "0",
        "--duration-s",
        "120",
    ]));
    let port = sim.line();
    let sock = tmux_socket(d.path());
    let tmux = |args: &[&str]| {
        Command::new("tmux")
            .arg("-S")
            .arg(&sock)
            .args(args)
            .output()
            .expect("tmux runs")
    };
    /// Kills the tmux server when the test ends.
    struct Server(PathBuf);
    impl Drop for Server {
        fn drop(&mut self) {
            let _ = Command::new("tmux")
                .arg("-S")
                .arg(&self.0)
                .arg("kill-server")
                .output();
        }
    }
    let cmd = format!(
        "cd {} && {} acquire shift-angle --plan plan.toml --port {port} --out readings.csv; echo EXIT=$?; sleep 30",
        d.path().display(),
        env!("CARGO_BIN_EXE_gonio")
    );
    let o = tmux(&["new-session", "-d", "-x", "120", "-y", "30", &cmd]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let _server = Server(sock.clone());
    let screen = || String::from_utf8_lossy(&tmux(&["capture-pane", "-p"]).stdout).into_owned();
    let wait_for = |what: &str| {
        let t0 = Instant::now();
        loop {
            let s = screen();
            if s.contains(what) {
                return s;
            }
            assert!(
                t0.elapsed() < Duration::from_secs(15),
                "no {what:?} on the screen:\n{s}"
            );
            std::thread::sleep(Duration::from_millis(100));
        }
    };
    let s = wait_for("turn the polygon to face 1");
    assert!(s.contains("position 1 of 6"), "{s}");
    // The live X: a number of arcseconds, read while the operator sets the polygon.
    let t0 = Instant::now();
    while !screen()
        .lines()
        .any(|l| l.contains("live X") && l.contains('″'))
    {
        assert!(t0.elapsed() < Duration::from_secs(15), "{}", screen());
        std::thread::sleep(Duration::from_millis(100));
    }
    tmux(&["send-keys", "Enter"]);
    let s = wait_for("turn the polygon to face 2");
    assert!(
        s.contains("READ shift_deg=0 start_face=1 step=1 repeat=1 x_arcsec="),
        "{s}"
    );
    tmux(&["send-keys", "s"]);
    wait_for("turn the polygon to face 3");
    tmux(&["send-keys", "q"]);
    wait_for("EXIT=0");
    let journal = std::fs::read_to_string(d.path().join("readings.csv.journal")).unwrap();
    assert_eq!(
        journal.lines().filter(|l| l.starts_with("R\t0\t")).count(),
        1
    );
    assert_eq!(journal.lines().filter(|l| l.starts_with("K\t1")).count(), 1);
    drop(sim);
}
