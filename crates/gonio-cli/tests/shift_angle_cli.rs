//! `gonio simulate shift-angle` and `gonio shift-angle` end to end, and their bad-input errors.

mod common;

use common::{gonio, stderr};
use std::path::Path;

/// Runs `gonio shift-angle` on CSV text; returns (exit code, stderr).
fn on_csv(dir: &Path, text: &str, extra: &[&str]) -> (i32, String) {
    let p = dir.join("r.csv");
    std::fs::write(&p, text).unwrap();
    let mut args = vec!["shift-angle", p.to_str().unwrap()];
    args.extend_from_slice(extra);
    let o = gonio(&args);
    (o.status.code().unwrap_or(-1), stderr(&o))
}

#[test]
fn simulate_then_calibrate_matches_truth_within_reported_u() {
    let d = tempfile::tempdir().unwrap();
    let out = d.path().join("lab");
    let o = gonio(&[
        "simulate",
        "shift-angle",
        "--shifts",
        "0:1:14",
        "--seed",
        "4",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let json = d.path().join("cal.json");
    let comp = d.path().join("comp.csv");
    let o = gonio(&[
        "shift-angle",
        out.join("readings.csv").to_str().unwrap(),
        "--json",
        json.to_str().unwrap(),
        "--compensation",
        comp.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let cal: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    let truth: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("truth.json")).unwrap()).unwrap();
    assert_eq!(cal["method"], "least-squares");
    assert_eq!(cal["faces"], 24);
    let alpha = cal["encoder_errors"].as_array().unwrap();
    assert_eq!(alpha.len(), 360);
    // Sorted by angle over all shifts.
    assert!(
        alpha
            .windows(2)
            .all(|w| w[0]["angle_deg"].as_f64() < w[1]["angle_deg"].as_f64())
    );
    for t in truth["encoder_errors"].as_array().unwrap() {
        let a = alpha
            .iter()
            .find(|a| a["angle_deg"] == t["angle_deg"])
            .unwrap();
        let err = a["value_arcsec"].as_f64().unwrap() - t["value_arcsec"].as_f64().unwrap();
        let u = a["u_arcsec"].as_f64().unwrap();
        // 360 draws: |z| > 5 has probability 2e-4 for the lot.
        assert!(
            err.abs() < 5.0 * u,
            "angle {}: error {err}, u {u}",
            t["angle_deg"]
        );
    }
    for key in ["rms_arcsec", "max_abs_arcsec", "dof"] {
        assert!(cal["residuals"][key].is_number());
    }
    assert_eq!(cal["undetectable_harmonics"][0], 24);
    assert_eq!(cal["pitch_deviations"].as_array().unwrap().len(), 24);
    assert_eq!(cal["setup_errors"][0]["start_face"], 1);
    let comp = std::fs::read_to_string(comp).unwrap();
    assert!(comp.starts_with("angle_deg,correction_arcsec\n"));
    assert_eq!(comp.lines().count(), 361);
}

#[test]
fn same_seed_same_bytes() {
    let d = tempfile::tempdir().unwrap();
    let run = |name: &str| {
        let out = d.path().join(name);
        let o = gonio(&[
            "simulate",
            "shift-angle",
            "--seed",
            "9",
            "--rows",
            "full",
            "--out",
            out.to_str().unwrap(),
        ]);
        assert!(o.status.success());
        (
            std::fs::read(out.join("readings.csv")).unwrap(),
            std::fs::read(out.join("truth.json")).unwrap(),
        )
    };
    assert_eq!(run("a"), run("b"));
}

#[test]
fn bad_input_is_one_line_with_file_line_and_exit_2() {
    let d = tempfile::tempdir().unwrap();
    let cases: &[(&str, &[&str], &str)] = &[
        ("0,1,1,0.5\n", &[], "r.csv:1: missing column 'shift_deg'"),
        (
            "shift,face,step,value\n0,1,1,0.5\n",
            &[],
            "r.csv:1: missing column 'shift_deg'",
        ),
        (
            "# c\nshift_deg,start_face,step,reading_arcsec\n0,1,1,abc\n",
            &[],
            "r.csv:3:4: column 'reading_arcsec': expected a number, found \"abc\"",
        ),
        (
            "shift_deg,start_face,step,reading_arcsec\n0,1,x,0.1\n",
            &[],
            "r.csv:2:3: column 'step': expected a whole number",
        ),
        (
            "shift_deg,start_face,step,reading_arcsec\n0,7,1,0.1\n",
            &["--faces", "6"],
            "r.csv:2:2: column 'start_face': 7 is out of range: expected 1..=6",
        ),
        (
            "shift_deg,start_face,step,reading_arcsec\n0,1,0,0.1\n",
            &[],
            "r.csv:2:3: column 'step': 0 is out of range",
        ),
        (
            "shift_deg,start_face,step,reading_arcsec\n0,1,1,0.1\n0,2,2,0.2\n0,3,3,0.3\n0,1,1,0.4\n",
            &[],
            "r.csv:5: conflicting duplicate",
        ),
        (
            "shift_deg,start_face,step,reading_arcsec\n0,1,1,0.1,9\n",
            &[],
            "r.csv:2: expected 4 fields",
        ),
        (
            "shift_deg,start_face,step,reading_arcsec\n",
            &[],
            "no readings",
        ),
        ("", &[], "r.csv:1: empty file"),
        (
            "shift_deg,start_face,step,reading_arcsec\n0,1,1,NaN\n",
            &[],
            "r.csv:2:4: column 'reading_arcsec': expected a finite number",
        ),
    ];
    for (text, extra, expected) in cases {
        let mut args = extra.to_vec();
        let json = d.path().join("out.json");
        args.extend_from_slice(&["--json", json.to_str().unwrap()]);
        let (code, err) = on_csv(d.path(), text, &args);
        assert_eq!(code, 2, "{text:?}: {err}");
        assert!(
            err.contains(expected),
            "{text:?}: expected {expected:?} in {err:?}"
        );
        assert_eq!(err.trim_end().lines().count(), 1, "one line: {err:?}");
        assert!(!err.contains("panicked"));
        assert!(!json.exists(), "no output on error");
    }
}

#[test]
fn too_sparse_names_the_undetermined_unknowns() {
    let d = tempfile::tempdir().unwrap();
    let mut text = String::from("shift_deg,start_face,step,reading_arcsec\n");
    // One row only: α and β cannot be separated.
    for i in 1..=6 {
        text.push_str(&format!("0,1,{i},0.{i}\n"));
    }
    let (code, err) = on_csv(d.path(), &text, &[]);
    assert_eq!(code, 2);
    assert!(
        err.contains("r.csv: the readings do not determine"),
        "{err}"
    );
    assert!(err.contains("β_2"), "{err}");
    // The paper's method says what it needs instead.
    let (code, err) = on_csv(d.path(), &text, &["--method", "paper"]);
    assert_eq!(code, 2);
    assert!(err.contains("needs a full 6×6 matrix"), "{err}");
}

#[test]
fn help_has_an_example() {
    for cmd in [
        &["shift-angle", "--help"][..],
        &["simulate", "shift-angle", "--help"],
        &["simulate", "encoder", "--help"],
        &["demo", "--help"],
    ] {
        let o = gonio(cmd);
        assert!(o.status.success());
        assert!(
            String::from_utf8_lossy(&o.stdout).contains("Example"),
            "{cmd:?}"
        );
    }
}

#[test]
fn instrument_terms_widen_every_u_and_give_k_and_nu_eff() {
    let d = tempfile::tempdir().unwrap();
    let out = d.path().join("lab");
    let o = gonio(&[
        "simulate",
        "shift-angle",
        "--seed",
        "2",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success());
    let inst = d.path().join("inst.toml");
    // u = 0.03/√3 and 0.01/2: two terms with ν = ∞.
    std::fs::write(
        &inst,
        "[autocollimator_linearity]\ndistribution = \"rectangular\"\nhalf_width = 0.03\n\
         [autocollimator_certificate]\ndistribution = \"normal\"\nexpanded = 0.01\nk = 2\n",
    )
    .unwrap();
    let json = d.path().join("cal.json");
    let o = gonio(&[
        "shift-angle",
        out.join("readings.csv").to_str().unwrap(),
        "--sigma",
        "0.05",
        "--instrument",
        inst.to_str().unwrap(),
        "--json",
        json.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let cal: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    let extra = (0.03f64 / 3f64.sqrt()).powi(2) + 0.005f64.powi(2);
    for a in cal["encoder_errors"].as_array().unwrap() {
        let ur = a["u_random_arcsec"].as_f64().unwrap();
        let uc = a["u_arcsec"].as_f64().unwrap();
        assert!((uc - (ur * ur + extra).sqrt()).abs() < 1e-12);
        // σ stated and instrument terms exact: ν_eff = ∞, k = z(0.975).
        assert_eq!(a["nu_eff"], "inf");
        assert!((a["k"].as_f64().unwrap() - 1.959963984540054).abs() < 1e-9);
        assert!((a["U_arcsec"].as_f64().unwrap() - 1.959963984540054 * uc).abs() < 1e-9);
    }
    // A malformed instrument file names its line.
    std::fs::write(&inst, "[encoder_resolution]\ndistribution = \"triangle\"\n").unwrap();
    let o = gonio(&[
        "shift-angle",
        out.join("readings.csv").to_str().unwrap(),
        "--instrument",
        inst.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("inst.toml:2"), "{}", stderr(&o));
}
