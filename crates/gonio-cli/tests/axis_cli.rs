//! `gonio acquire axis` against `gonio simulate autocollimator --pty --axis` (a polygon on a
//! simulated rotary axis, its own process), the polygon calibrated first on the same bench by
//! `gonio acquire shift-angle`; `gonio axis` evaluates the readings to the simulated axis's known
//! parameters within their uncertainty. And `gonio axis`'s files: the compensation table, a
//! unidirectional test, the errors.

mod common;

use common::{example, gonio, ok};
use serde_json::Value;
use std::io::{BufRead, BufReader, Write};
use std::path::Path;
use std::process::{Child, ChildStdin, Command, Stdio};
use std::sync::mpsc::{Receiver, channel};
use std::time::Duration;

/// A child process with its standard output as lines; killed when dropped.
struct Proc {
    child: Child,
    stdin: ChildStdin,
    lines: Receiver<String>,
}

impl Proc {
    fn spawn(dir: &Path, args: &[&str]) -> Proc {
        let mut child = Command::new(env!("CARGO_BIN_EXE_gonio"))
            .current_dir(dir)
            .args(args)
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .expect("gonio runs");
        let out = child.stdout.take().expect("piped");
        let (tx, lines) = channel();
        std::thread::spawn(move || {
            for l in BufReader::new(out).lines().map_while(Result::ok) {
                if tx.send(l).is_err() {
                    break;
                }
            }
        });
        let stdin = child.stdin.take().expect("piped");
        Proc {
            child,
            stdin,
            lines,
        }
    }

    /// The next line, within 10 s; `None` at the end of the output.
    fn line(&self) -> Option<String> {
        match self.lines.recv_timeout(Duration::from_secs(10)) {
            Ok(l) => Some(l),
            Err(std::sync::mpsc::RecvTimeoutError::Disconnected) => None,
            Err(e) => panic!("no line within 10 s: {e}"),
        }
    }

    fn send(&mut self, line: &str) {
        writeln!(self.stdin, "{line}").expect("the child reads");
        self.stdin.flush().expect("the child reads");
    }

    /// The exit code, within 20 s.
    fn wait(mut self) -> i32 {
        for _ in 0..1000 {
            if let Some(s) = self.child.try_wait().expect("waits") {
                return s.code().unwrap_or(-1);
            }
            std::thread::sleep(Duration::from_millis(20));
        }
        panic!("no exit within 20 s");
    }
}

impl Drop for Proc {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// Runs an acquisition through the line protocol, the simulated bench set at every NEXT, until
/// it ends or `quit_after` positions are read; its exit code.
fn acquire(dir: &Path, sim: &mut Proc, args: &[&str], quit_after: Option<usize>) -> i32 {
    let mut a = Proc::spawn(dir, args);
    let mut read = 0;
    while let Some(l) = a.line() {
        if l.starts_with("NEXT ") {
            if Some(read) == quit_after {
                a.send("quit");
                continue;
            }
            // The operator (or the controller) moves the bench, then asks for the reading.
            sim.send(&l);
            while !sim.line().expect("the simulator runs").starts_with("SET ") {}
            a.send("");
            read += 1;
        } else if l.starts_with("ASK ") {
            a.send("");
        }
    }
    a.wait()
}

fn json(path: &Path) -> Value {
    serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap()
}

#[test]
fn an_axis_acquired_on_the_simulated_bench_evaluates_to_its_known_parameters() {
    let d = tempfile::tempdir().unwrap();
    let dir = d.path();
    std::fs::write(dir.join("polygon.toml"), "faces = 8\nshifts_deg = [0]\n").unwrap();
    // 8 faces and 360°: 9 targets, 5 runs each way.
    std::fs::write(
        dir.join("axis.toml"),
        "faces = 8\nruns = 5\nrepeatability_arcsec = 0.5\n",
    )
    .unwrap();
    let mut sim = Proc::spawn(
        dir,
        &[
            "simulate",
            "autocollimator",
            "--pty",
            "--faces",
            "8",
            "--seed",
            "5",
            "--sigma",
            "0.03",
            "--flagged",
            "0.02",
            "--pitch-sigma",
            "1",
            "--axis",
            "--backlash-arcsec",
            "2",
            "--repeatability-arcsec",
            "0.5",
            "--duration-s",
            "300",
            "--plan",
            "axis.toml",
            "--truth",
            "truth.json",
        ],
    );
    let port = sim.line().expect("the port");
    let bench = ["--port", &port, "--sigma-arcsec", "0.03"];
    // The polygon's calibration on the same bench: the full 8 × 8 matrix at shift 0.
    let mut args = vec!["acquire", "shift-angle", "--plan", "polygon.toml"];
    args.extend(bench);
    args.extend(["--out", "polygon.csv"]);
    assert_eq!(acquire(dir, &mut sim, &args, None), 0);
    ok(&[
        "shift-angle",
        &dir.join("polygon.csv").display().to_string(),
        "--sigma",
        "0.0174",
        "--json",
        &dir.join("cal.json").display().to_string(),
    ]);
    // The axis: quit after 37 approaches, then resume to the end.
    let mut args = vec!["acquire", "axis", "--plan", "axis.toml"];
    args.extend(bench);
    args.extend(["--out", "axis.csv"]);
    assert_eq!(acquire(dir, &mut sim, &args, Some(37)), 0);
    assert!(!dir.join("axis.csv").exists());
    args.push("--resume");
    assert_eq!(acquire(dir, &mut sim, &args, None), 0);
    let csv = std::fs::read_to_string(dir.join("axis.csv")).unwrap();
    let rows: Vec<&str> = csv.lines().filter(|l| !l.starts_with('#')).collect();
    assert_eq!(rows[0], "target_deg,direction,run,face,reading_arcsec");
    assert_eq!(rows.len(), 1 + 9 * 5 * 2);
    // The standard's cycle: run 1 up from 0°, down from 360°; 360° is face 1 again.
    assert!(rows[1].starts_with("0,+,1,1,") && rows[9].starts_with("360,+,1,1,"));
    assert!(rows[10].starts_with("360,-,1,1,") && rows[20].starts_with("45,+,2,2,"));
    let (out, _) = ok(&[
        "axis",
        &dir.join("axis.csv").display().to_string(),
        "--polygon",
        &dir.join("cal.json").display().to_string(),
        "--instrument",
        &example("instrument-axis.toml"),
        "--json",
        &dir.join("axis.json").display().to_string(),
    ]);
    assert!(
        out.starts_with("ISO 230-2:2014, rotary axis: bidirectional test"),
        "{out}"
    );
    let got = json(&dir.join("axis.json"));
    let truth = json(&dir.join("truth.json"));
    assert_eq!(got["standard"], "ISO 230-2:2014");
    assert!(
        got["polygon"]["note"]
            .as_str()
            .unwrap()
            .contains("beyond ISO 230-2")
    );
    let budget = got["uncertainty"]["reference"]["budget"]["contributions"]
        .as_array()
        .unwrap();
    assert!(budget.iter().any(|r| {
        r["name"]
            .as_str()
            .unwrap()
            .starts_with("polygon calibration, face")
    }));
    // Every parameter within 3u (1.5 U at k = 2) of the axis's own: B_mean is one estimate
    // (|z| > 3 with probability 0.3 %); the others pick the most deviant of 9 targets' values,
    // whose excess is the largest of 9 to 18 scatters (beyond 3u with probability ≈ 1–2.5 %).
    let mut worst: (f64, String) = (0.0, String::new());
    for (name, t) in truth["parameters"].as_object().unwrap() {
        let (v, u) = (
            got[name].as_f64().unwrap(),
            got["uncertainty"]["parameters"][name].as_f64().unwrap() / 2.0,
        );
        let z = (v - t.as_f64().unwrap()) / u;
        assert!(
            z.abs() <= 3.0,
            "{name}: {v} vs the axis's {t}, u {u}, z {z:.2}"
        );
        if z.abs() > worst.0 {
            worst = (z.abs(), name.clone());
        }
    }
    eprintln!("worst parameter: {} at |z| = {:.2}", worst.1, worst.0);
    // Every target's x̄↑ and x̄↓ against the axis's, the readings' constant (the autocollimator's
    // zero, the set-up) taken out: within 3u, u² = σ²/n + the reference's u², σ the scatter of
    // one approach. The polygon's face terms (pitch deviations of σ 1″) are corrected: left in,
    // they would show.
    let targets = got["targets"].as_array().unwrap();
    let true_targets = truth["targets"].as_array().unwrap();
    for dir_key in ["up", "down"] {
        let diff: Vec<f64> = targets
            .iter()
            .zip(true_targets)
            .map(|(g, t)| {
                g[format!("mean_{dir_key}_arcsec")].as_f64().unwrap()
                    - t[format!("mean_{dir_key}_arcsec")].as_f64().unwrap()
            })
            .collect();
        let offset = diff.iter().sum::<f64>() / diff.len() as f64;
        let term = |g: &Value| g["polygon_term_arcsec"].as_f64().unwrap();
        let raw: Vec<f64> = targets
            .iter()
            .zip(&diff)
            .map(|(g, d)| d + term(g))
            .collect();
        let raw_offset = raw.iter().sum::<f64>() / raw.len() as f64;
        let mut uncorrected_over = 0;
        for ((g, t), dv) in targets.iter().zip(true_targets).zip(&diff) {
            // The axis's σ and the autocollimator's (0.03″ over 3 samples) per approach.
            let sigma = t["s_arcsec"].as_f64().unwrap().hypot(0.03 / 3f64.sqrt());
            let u_ref = g["u_reference_arcsec"].as_f64().unwrap();
            let u = (sigma * sigma / 5.0 + u_ref * u_ref).sqrt();
            assert!(
                (dv - offset).abs() <= 3.0 * u,
                "x̄ {dir_key} at {}°: {} from the axis's, u {u}",
                g["target_deg"],
                dv - offset
            );
            if (dv + term(g) - raw_offset).abs() > 3.0 * u {
                uncorrected_over += 1;
            }
        }
        assert!(
            uncorrected_over > 0,
            "the check cannot see a polygon left uncorrected"
        );
    }
    sim.send("quit");
}

#[test]
fn compensation_a_unidirectional_test_and_errors() {
    let d = tempfile::tempdir().unwrap();
    let dir = d.path();
    let s = |p: &str| dir.join(p).display().to_string();
    ok(&[
        "simulate",
        "axis",
        "--seed",
        "2",
        "--targets",
        "0,90,180,270",
        "--out",
        &s("ax"),
    ]);
    ok(&[
        "axis",
        &s("ax/readings.csv"),
        "--json",
        &s("axis.json"),
        "--compensation",
        &s("comp.csv"),
    ]);
    let doc = json(&dir.join("axis.json"));
    let comp = std::fs::read_to_string(dir.join("comp.csv")).unwrap();
    let lines: Vec<&str> = comp.lines().collect();
    assert_eq!(
        lines[0],
        "target_deg,correction_up_arcsec,correction_down_arcsec,correction_mean_arcsec"
    );
    // The corrections are −x̄↑, −x̄↓ and their mean, per target.
    for (l, t) in lines[1..].iter().zip(doc["targets"].as_array().unwrap()) {
        let f: Vec<f64> = l.split(',').map(|x| x.parse().unwrap()).collect();
        let (up, down) = (
            t["mean_up_arcsec"].as_f64().unwrap(),
            t["mean_down_arcsec"].as_f64().unwrap(),
        );
        assert_eq!(f[0], t["target_deg"].as_f64().unwrap());
        assert!((f[1] + up).abs() < 1e-6 && (f[2] + down).abs() < 1e-6);
        assert!((f[3] + (up + down) / 2.0).abs() < 1e-6);
    }
    // A unidirectional test: the bidirectional parameters are null and say why.
    ok(&[
        "simulate",
        "axis",
        "--seed",
        "2",
        "--directions",
        "-",
        "--out",
        &s("down"),
    ]);
    let (out, _) = ok(&[
        "axis",
        &s("down/readings.csv"),
        "--json",
        &s("down.json"),
        "--compensation",
        &s("down.csv"),
    ]);
    assert!(
        out.contains("9 targets (0° … 360°), 5 runs, negative direction only"),
        "{out}"
    );
    let doc = json(&dir.join("down.json"));
    assert!(doc["A_arcsec"].is_null() && doc["M_arcsec"].is_null());
    assert!(
        doc["compensation_note"]
            .as_str()
            .unwrap()
            .starts_with("correction = −x̄ (arcsec): added to the commanded position it cancels")
    );
    assert!(doc["A_down_arcsec"].as_f64().unwrap() > 0.0);
    assert!(
        doc["bidirectional_note"]
            .as_str()
            .unwrap()
            .contains("unidirectional")
    );
    let down = std::fs::read_to_string(dir.join("down.csv")).unwrap();
    assert!(down.lines().nth(1).unwrap().starts_with("0,,-"), "{down}");
    // Errors: one line naming the file, exit 2, nothing written.
    let readings = std::fs::read_to_string(dir.join("ax/readings.csv")).unwrap();
    let cut: String = readings
        .lines()
        .filter(|l| {
            *l != readings
                .lines()
                .find(|l| l.starts_with("180,-,3,"))
                .unwrap()
        })
        .map(|l| format!("{l}\n"))
        .collect();
    std::fs::write(dir.join("cut.csv"), cut).unwrap();
    let huge: String = readings
        .lines()
        .map(|l| match l.starts_with("180,-,3,") {
            true => "180,-,3,1e300\n".to_string(),
            false => format!("{l}\n"),
        })
        .collect();
    std::fs::write(dir.join("huge.csv"), huge).unwrap();
    let (cut, axis_json, bad) = (s("cut.csv"), s("axis.json"), s("bad.json"));
    let (huge, sim_bad, good) = (s("huge.csv"), s("sim-bad"), s("ax/readings.csv"));
    for (args, want) in [
        // The first reading at that target and direction (run 1 down: line 8), the run column.
        (
            vec!["axis", &cut, "--json", &bad],
            "cut.csv:8:3: target 180°, negative direction: run 3 is missing (the test has runs 1–5)",
        ),
        // A huge number is named the short way.
        (
            vec!["axis", &huge, "--json", &bad],
            ":4: column 'deviation_arcsec': 1e300 is out of range",
        ),
        // An input named as the output: refused, and no summary printed before the error.
        (
            vec!["axis", &good, "--json", &good],
            "is also an input of this command",
        ),
        // The simulator's flags name their bounds.
        (
            vec![
                "simulate",
                "axis",
                "--backlash-arcsec",
                "1e300",
                "--out",
                &sim_bad,
            ],
            "--backlash-arcsec 1e300: expected -3600 to 3600 arcsec",
        ),
        (
            vec![
                "simulate",
                "axis",
                "--reference-sigma-arcsec",
                "-1",
                "--out",
                &sim_bad,
            ],
            "--reference-sigma-arcsec -1: expected 0 to 3600 arcsec",
        ),
        // Not a certificate: its place named.
        (
            vec!["axis", &cut, "--polygon", &axis_json, "--json", &bad],
            "axis.json:",
        ),
    ] {
        let o = gonio(&args);
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{err}");
        assert!(
            o.stdout.is_empty(),
            "{}",
            String::from_utf8_lossy(&o.stdout)
        );
        assert_eq!(err.lines().count(), 1, "{err}");
        assert!(err.contains(want), "{err}");
        assert!(!dir.join("bad.json").exists());
        assert!(!dir.join("sim-bad").exists());
    }
}
