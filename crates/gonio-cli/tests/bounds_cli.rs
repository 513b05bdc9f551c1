//! Inputs without a bound, through the binary: every numeric flag is refused outside its bound
//! with one `error:` line naming the bound and the value as written (never three hundred
//! zeros); the PLC map's numbers likewise, at their line and column; the budget's ν, two inputs
//! on standard input, a point-spread or defocus that blurs a frame flat, a thread count the
//! address space cannot hold, an endless operator line. Every input is generated here.

mod common;

use common::{gonio, stderr};
use std::io::Write;
use std::path::Path;
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

/// A refused run: exit code 2, one line `error: …` containing `want`.
#[track_caller]
fn refused(o: &Output, want: &str) -> String {
    let e = stderr(o);
    assert_eq!(o.status.code(), Some(2), "{e}");
    assert_eq!(e.lines().count(), 1, "{e}");
    assert!(e.starts_with("error: "), "{e}");
    assert!(e.contains(want), "expected {want:?} in {e}");
    e
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

#[test]
fn every_numeric_flag_names_its_bound_and_the_value_as_written() {
    let cases: &[(&[&str], &str)] = &[
        (
            &[
                "serve",
                "--db",
                "x.sqlite",
                "--station",
                "sim",
                "--speed",
                "1e-300",
            ],
            "'1e-300' for '--speed <SPEED>': at least 0.001 simulated s per s",
        ),
        (
            &["detect", "--threads", "4096", "x"],
            "'4096' for '--threads <N>': at most 256",
        ),
        (
            &[
                "acquire",
                "shift-angle",
                "--plan",
                "p",
                "--port",
                "/dev/null",
                "--out",
                "r.csv",
                "--baud",
                "0",
            ],
            "'0' for '--baud <BAUD>': at least 50 baud",
        ),
        (
            &[
                "acquire",
                "shift-angle",
                "--plan",
                "p",
                "--port",
                "/dev/null",
                "--out",
                "r.csv",
                "--timeout-s",
                "1e300",
            ],
            "at most 60 s",
        ),
        (
            &[
                "simulate",
                "frames",
                "--count",
                "1",
                "--seed",
                "1",
                "--out",
                "o",
                "--defocus",
                "1e300",
            ],
            "'1e300' for '--defocus <DEFOCUS>': at most 1000000 µm",
        ),
        (
            &[
                "simulate", "frames", "--count", "1", "--seed", "1", "--out", "o", "--fps", "0",
            ],
            "above 0 frames/s",
        ),
        (
            &[
                "simulate", "frames", "--count", "99999999", "--seed", "1", "--out", "o",
            ],
            "at most 1000000 frames",
        ),
        (
            &[
                "simulate",
                "shift-angle",
                "--seed",
                "1",
                "--out",
                "o",
                "--drop",
                "1e300",
            ],
            "'1e300' for '--drop <DROP>': below 1",
        ),
        (
            &[
                "simulate",
                "shift-angle",
                "--seed",
                "1",
                "--out",
                "o",
                "--sigma",
                "1e300",
            ],
            "at most 3600″",
        ),
        (
            &[
                "simulate",
                "encoder",
                "--out",
                "o",
                "--graduation-sigma",
                "1e300",
            ],
            "at most 3600″",
        ),
        (
            &[
                "simulate", "selfcal", "--seed", "1", "--out", "o", "--start", "1e300",
            ],
            "at most 1000000°",
        ),
        (
            &[
                "simulate",
                "autocollimator",
                "--pty",
                "--resolution",
                "1e-300",
            ],
            "'1e-300' for '--resolution <RESOLUTION>': at least 1e-6″",
        ),
        (
            &[
                "simulate",
                "autocollimator",
                "--pty",
                "--drift-arcsec-per-reading",
                "1e300",
            ],
            "at most 3600″",
        ),
        (
            &[
                "simulate",
                "station",
                "--plc",
                "127.0.0.1:0",
                "--latency-ms",
                "1e300",
            ],
            "at most 1000 ms",
        ),
        (
            &["shift-angle", "r.csv", "--check-order", "4000000000"],
            "at most 1000",
        ),
        (
            &["shift-angle", "r.csv", "--coverage", "1"],
            "'1' for '--coverage <COVERAGE>': below 1",
        ),
        (
            &["shift-angle", "r.csv", "--sigma", "nan"],
            "not a finite number",
        ),
        (&["budget", "b.toml", "--ndig", "0"], "at least 1"),
        (
            &["budget", "b.toml", "--trials", "1000000000"],
            "at most 100000000 trials",
        ),
        (
            &[
                "eccentricity",
                "t.csv",
                "--frames-taken",
                "99999999999999999999999",
            ],
            "at most 100000 frames",
        ),
        (
            &["eccentricity", "t.csv", "--um-per-px", "1e300"],
            "at most 1000 µm/px",
        ),
        (
            &["mount", "--sim", "--seed", "1", "--parts", "0"],
            "at least 1 parts",
        ),
        (&["demo", "--sigma", "0"], "above 0″"),
        (
            &["parts", "--db", "x.sqlite", "--limit", "0"],
            "at least 1 parts",
        ),
    ];
    for (args, want) in cases {
        let e = refused(&gonio(args), want);
        assert!(e.starts_with("error: invalid value '"), "{args:?}: {e}");
        assert!(!e.contains("000000000000000000000"), "{args:?}: {e}");
    }
}

#[test]
fn numbers_in_file_errors_are_written_short() {
    let d = tempfile::tempdir().unwrap();
    // A scene's point spread of 1e300 µm: refused, the value as written, at its key.
    let scene = d.path().join("scene.toml");
    std::fs::write(&scene, "ring_present = true\npsf_sigma_um = 1e300\n").unwrap();
    let out = d.path().join("frames");
    let e = refused(
        &gonio(&[
            "simulate",
            "frames",
            "--count",
            "1",
            "--seed",
            "1",
            "--scene-file",
            s(&scene),
            "--out",
            s(&out),
        ]),
        "psf_sigma_um = 1e300: expected at most 1000 µm",
    );
    assert!(e.contains("scene.toml:2:"), "{e}");
    // A budget's ν of 1e-100 is written so, not as a hundred zeros.
    let b = d.path().join("b.toml");
    std::fs::write(
        &b,
        "[[budget]]\nname = \"x\"\n[[budget.contribution]]\nname = \"a\"\nu = 1.0\ndof = -1e-100\n",
    )
    .unwrap();
    refused(&gonio(&["budget", s(&b)]), "found -1e-100");
}

#[test]
fn a_plc_map_number_beyond_its_bound_is_refused_at_its_line_and_column() {
    let d = tempfile::tempdir().unwrap();
    let map = d.path().join("map.toml");
    for (text, want) in [
        (
            "unit = 1\n[timing]\ncommand_timeout_s = 1e300\n",
            "map.toml:3:21: timing.command_timeout_s = 1e300: at most 3600 s",
        ),
        (
            "[timing]\ncommand_timeout_s = 1e20\n",
            "map.toml:2:21: timing.command_timeout_s = 1e20: at most 3600 s",
        ),
        (
            "[timing]\nreply_timeout_ms = 100000000000\n",
            "map.toml:2:20: timing.reply_timeout_ms = 100000000000: at most 600000 ms",
        ),
        (
            "[rod]\ntravel_limit_um = 1e300\n",
            "map.toml:2:19: rod.travel_limit_um = 1e300: at most 1000000 µm",
        ),
    ] {
        std::fs::write(&map, text).unwrap();
        // The map is read before the camera and the PLC are looked for.
        let o = gonio(&[
            "mount",
            "--plc",
            "modbus://127.0.0.1:9",
            "--camera",
            "none",
            "--plc-map",
            s(&map),
        ]);
        let e = refused(&o, want);
        assert!(!e.contains("panicked"), "{e}");
    }
}

#[test]
fn a_vanishing_nu_gives_no_coverage_factor() {
    let d = tempfile::tempdir().unwrap();
    let b = d.path().join("nu.toml");
    for nu in ["1e-300", "1e-30", "1e-5"] {
        std::fs::write(
            &b,
            format!("[[budget]]\nname = \"x\"\nunit = \"nm\"\n[[budget.contribution]]\nname = \"a\"\nu = 1.0\ndof = {nu}\n"),
        )
        .unwrap();
        let e = refused(&gonio(&["budget", s(&b)]), "the coverage factor k");
        assert!(
            e.contains(&format!("ν_eff = {nu}")) && e.contains("not finite"),
            "{e}"
        );
    }
    // A small ν that f64 resolves still gives its k.
    std::fs::write(
        &b,
        "[[budget]]\nname = \"x\"\nunit = \"nm\"\n[[budget.contribution]]\nname = \"a\"\nu = 1.0\ndof = 2\n",
    )
    .unwrap();
    assert!(gonio(&["budget", s(&b)]).status.success());
}

#[test]
fn import_elcomat_refuses_standard_input_for_both_inputs() {
    let mut child = Command::new(env!("CARGO_BIN_EXE_gonio"))
        .args(["import", "elcomat", "-", "--plan", "-", "--out", "-"])
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let _ = child
        .stdin
        .take()
        .unwrap()
        .write_all(b"faces = 4\nshifts_deg = [0]\n4 003 +1.000 +0.000\n");
    let o = child.wait_with_output().unwrap();
    refused(&o, "both are standard input");
}

#[test]
fn a_frame_blurred_flat_shows_no_ring_contrast() {
    let d = tempfile::tempdir().unwrap();
    let truth = |defocus: &str| -> serde_json::Value {
        let out = d.path().join(format!("f{defocus}"));
        let o = gonio(&[
            "simulate",
            "frames",
            "--count",
            "1",
            "--seed",
            "1",
            "--scene",
            "clean",
            "--defocus",
            defocus,
            "--out",
            s(&out),
        ]);
        assert!(o.status.success(), "{}", stderr(&o));
        let t: serde_json::Value =
            serde_json::from_slice(&std::fs::read(out.join("truth.json")).unwrap()).unwrap();
        t["frames"][0].clone()
    };
    let sharp = truth("0");
    let flat = truth("1000000");
    let (b0, c0) = (
        sharp["blur_sigma_px"].as_f64().unwrap(),
        sharp["ring_contrast_grey"].as_f64().unwrap(),
    );
    let (b1, c1) = (
        flat["blur_sigma_px"].as_f64().unwrap(),
        flat["ring_contrast_grey"].as_f64().unwrap(),
    );
    // In focus: the ring keeps nearly all its depth (an 11 px ring at σ ≈ 0.7 px).
    assert!(b0 < 1.0 && c0 > 100.0, "{sharp}");
    // At a metre of defocus the blur is tens of thousands of pixels: a 11 px ring keeps
    // erf(11 / (2√2 σ)) ≈ 1e-4 of its depth, a tenth of a grey level at most.
    assert!(b1 > 10_000.0 && b1.is_finite(), "{flat}");
    assert!(c1 < 0.1, "{flat}");
}

#[test]
fn a_thread_count_the_address_space_cannot_hold_ends_with_an_error_line() {
    let d = tempfile::tempdir().unwrap();
    // A 2048 × 2048 window with a ring 512 px wide (0.75 µm px: 384 µm).
    let optics = d.path().join("optics.toml");
    std::fs::write(
        &optics,
        "sensor_width_px = 2048\nsensor_height_px = 2048\nwindow_width_px = 2048\nwindow_height_px = 2048\nring_width_um = 384\n",
    )
    .unwrap();
    let frames = d.path().join("zero.raw");
    std::fs::write(&frames, vec![0u8; 2048 * 2048]).unwrap();
    let run = |threads: &str| {
        // 6 GiB of address space, as `ulimit -v 6291456`.
        Command::new("sh")
            .arg("-c")
            .arg(format!(
                "ulimit -v 6291456 && exec \"$0\" detect --raw 2048x2048 --optics \"$1\" --threads {threads} < \"$2\""
            ))
            .arg(env!("CARGO_BIN_EXE_gonio"))
            .arg(&optics)
            .arg(&frames)
            .output()
            .unwrap()
    };
    let e = refused(&run("256"), "--threads 256: 256 workers need");
    assert!(e.contains("at most") && e.contains("fit"), "{e}");
    refused(&run("4096"), "at most 256");
    // What fits runs, and one frame of these optics takes far less than the 2.5 GB it took.
    let o = run("2");
    assert!(o.status.success(), "{}", stderr(&o));
}

#[test]
fn an_endless_operator_line_is_refused_without_collecting_it() {
    let d = tempfile::tempdir().unwrap();
    // The instrument: gonio's simulated autocollimator on a pseudo-terminal, in its own process.
    let mut sim = Command::new(env!("CARGO_BIN_EXE_gonio"))
        .args([
            "simulate",
            "autocollimator",
            "--pty",
            "--faces",
            "4",
            "--duration-s",
            "60",
        ])
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let mut port = String::new();
    std::io::BufRead::read_line(
        &mut std::io::BufReader::new(sim.stdout.take().unwrap()),
        &mut port,
    )
    .unwrap();
    let port = port.trim().to_string();
    assert!(port.starts_with("/dev/"), "{port:?}");
    std::fs::write(
        d.path().join("plan.toml"),
        "faces = 4\nshifts_deg = [0]\nstart_faces = [1]\n",
    )
    .unwrap();
    let mut acq = Command::new(env!("CARGO_BIN_EXE_gonio"))
        .current_dir(d.path())
        .args([
            "acquire",
            "shift-angle",
            "--plan",
            "plan.toml",
            "--port",
            &port,
            "--out",
            "r.csv",
        ])
        .stdin(Stdio::piped())
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut stdin = acq.stdin.take().unwrap();
    // At most 64 MiB without a line end, in 64 KiB writes: a bound reader stops long before.
    let chunk = vec![b'x'; 64 << 10];
    let t0 = Instant::now();
    for _ in 0..1024 {
        if stdin.write_all(&chunk).is_err() {
            break;
        }
    }
    drop(stdin);
    let o = acq.wait_with_output().unwrap();
    let _ = sim.kill();
    let _ = sim.wait();
    let e = stderr(&o);
    assert_eq!(o.status.code(), Some(2), "{e}");
    let last = e.lines().last().unwrap_or_default();
    assert!(last.starts_with("error: "), "{e}");
    assert!(
        e.contains("standard input: a line longer than 4096 bytes"),
        "{e}"
    );
    assert!(t0.elapsed() < Duration::from_secs(60));
}
