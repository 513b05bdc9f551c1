//! `gonio joint` end to end on simulated polygon and head readings, and its bad-input errors.

mod common;

use common::{gonio, stderr};
use std::process::Command;

#[test]
fn joint_result_matches_the_truth_and_lists_the_blind_orders() {
    let d = tempfile::tempdir().unwrap();
    let p = |s: &str| d.path().join(s).to_str().unwrap().to_string();
    let enc = p("enc.json");
    // 3600 graduation lines read at 3600 positions: the heads' model (linear between
    // positions) is then the encoder's (linear between lines).
    let o = gonio(&[
        "simulate", "encoder", "--seed", "2", "--lines", "3600", "--out", &enc,
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let o = gonio(&[
        "simulate",
        "shift-angle",
        "--encoder",
        &enc,
        "--rows",
        "full",
        "--shifts",
        "0:1:14",
        "--seed",
        "2",
        "--out",
        &p("poly"),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let o = gonio(&[
        "simulate",
        "selfcal",
        "--encoder",
        &enc,
        "--heads",
        "selfa12",
        "--positions",
        "3600",
        "--seed",
        "3",
        "--out",
        &p("heads"),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let json = p("joint.json");
    let o = gonio(&[
        "joint",
        &p("poly/readings.csv"),
        &p("heads/readings.csv"),
        "--faces",
        "24",
        "--heads",
        "selfa12",
        "--json",
        &json,
        "--compensation",
        &p("comp.csv"),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(out.contains("still invisible: [168, 252, 336]"), "{out}");
    let r: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    assert_eq!(r["format"], "gonio.certificate/1");
    assert_eq!(r["procedure"], "joint");
    assert_eq!(r["method"], "joint-least-squares");
    let j = &r["joint"];
    assert_eq!(j["faces"], 24);
    assert_eq!(j["pitch_deviations"].as_array().unwrap().len(), 24);
    assert_eq!(j["setup_errors"].as_array().unwrap().len(), 15 * 24);
    assert_eq!(
        r["undetectable_harmonics"],
        serde_json::json!([168, 252, 336])
    );
    assert_eq!(j["blind_orders"]["from_polygon"], serde_json::json!([84]));
    assert_eq!(j["covariance_alpha_arcsec2"].as_array().unwrap().len(), 360);
    // The spectrum marks each instrument's blind orders and the joint estimate's.
    let by: Vec<&str> = r["spectrum"]["invisible"]
        .as_array()
        .unwrap()
        .iter()
        .map(|i| i["by"].as_str().unwrap())
        .collect();
    assert_eq!(by.len(), 3, "{by:?}");
    let truth: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(p("heads/truth.json")).unwrap()).unwrap();
    let truth = truth["errors"].as_array().unwrap();
    let alpha = r["encoder_errors"].as_array().unwrap();
    assert_eq!(alpha.len(), 360);
    let split = j["random_part"].as_array().unwrap();
    for (a, s) in alpha.iter().zip(split) {
        for key in ["u_arcsec", "u_random_arcsec", "U_arcsec", "k"] {
            assert!(a[key].is_number(), "{key}: {a}");
        }
        // u² = heads² + polygon² (the split of the random part between the instruments).
        let uh = s["u_heads_arcsec"].as_f64().unwrap();
        let up = s["u_polygon_arcsec"].as_f64().unwrap();
        assert!((uh.hypot(up) - a["u_random_arcsec"].as_f64().unwrap()).abs() < 1e-12);
        let angle = a["angle_deg"].as_f64().unwrap();
        let t = &truth[(angle * 10.0).round() as usize];
        assert!((t["position_deg"].as_f64().unwrap() - angle).abs() < 1e-9);
        let err = a["value_arcsec"].as_f64().unwrap() - t["value_arcsec"].as_f64().unwrap();
        let u = a["u_arcsec"].as_f64().unwrap();
        // 360 angles, |z| > 5 has probability 2e-4 for the lot; the truth here still holds the
        // invisible orders' content (168, 252, 336 … of the 0.01″ graduation error, ~1e-4″ each).
        assert!(err.abs() < 5.0 * u + 0.001, "{angle}°: error {err}, u {u}");
    }
    let comp = std::fs::read_to_string(p("comp.csv")).unwrap();
    assert_eq!(comp.lines().count(), 361);
    // `gonio report` draws the joint spectrum with each method's blind orders marked.
    let html = p("report.html");
    let o = gonio(&["report", &json, "--out", &html]);
    assert!(o.status.success(), "{}", stderr(&o));
    let html = std::fs::read_to_string(&html).unwrap();
    for mark in [
        "invisible to the 24-face polygon",
        "invisible to the 12 read heads",
        "invisible to the joint estimate (both instruments)",
        "the instruments agree",
    ] {
        assert!(html.contains(mark), "{mark}");
    }
    // The joint certificate exports as a Digital Calibration Certificate that validates.
    let repo = |f: &str| format!("{}/../../{f}", env!("CARGO_MANIFEST_DIR"));
    let xml = p("joint.xml");
    let meta = repo("examples/certificate-meta.toml");
    let o = gonio(&["certificate", &json, "--meta", &meta, "--dcc", &xml]);
    assert!(o.status.success(), "{}", stderr(&o));
    let v = Command::new("xmllint")
        .args([
            "--noout",
            "--schema",
            &repo("schemas/dcc/dcc-3.1.2.xsd"),
            &xml,
        ])
        .output()
        .expect("xmllint runs (Debian package libxml2-utils; .ci/run installs it)");
    assert!(v.status.success(), "{}", String::from_utf8_lossy(&v.stderr));
}

#[test]
fn polygon_angles_off_the_heads_grid_and_bad_options_are_errors() {
    let d = tempfile::tempdir().unwrap();
    let p = |s: &str| d.path().join(s).to_str().unwrap().to_string();
    let o = gonio(&[
        "simulate",
        "shift-angle",
        "--faces",
        "12",
        "--rows",
        "full",
        "--shifts",
        "0,0.5",
        "--out",
        &p("poly"),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let o = gonio(&[
        "simulate",
        "selfcal",
        "--heads",
        "eda:4",
        "--positions",
        "360",
        "--out",
        &p("heads"),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let run = |extra: &[&str]| {
        let mut a = vec![
            "joint".to_string(),
            p("poly/readings.csv"),
            p("heads/readings.csv"),
            "--heads".into(),
            "eda:4".into(),
        ];
        a.extend(extra.iter().map(|s| s.to_string()));
        let refs: Vec<&str> = a.iter().map(|s| s.as_str()).collect();
        gonio(&refs)
    };
    let o = run(&["--faces", "12"]);
    assert_eq!(o.status.code(), Some(2));
    let e = stderr(&o);
    assert!(
        e.contains("polygon angle 0.5° (shift 0.5°, step 1) is not on the encoder grid"),
        "{e}"
    );
    let o = run(&["--faces", "8"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(
        stderr(&o).contains("expected 1..=8 (--faces 8)"),
        "{}",
        stderr(&o)
    );
    // The vocabulary is a type (`gonio_calib::joint::Interpolation`): clap refuses the value
    // and lists the names.
    let o = run(&["--faces", "12", "--interpolation", "cubic"]);
    assert_eq!(o.status.code(), Some(2));
    let e = stderr(&o);
    assert!(
        e.contains("invalid value 'cubic' for '--interpolation")
            && e.contains("[possible values: linear, trigonometric]"),
        "{e}"
    );
    let o = run(&["--faces", "12", "--sigma-heads", "-1"]);
    assert_eq!(o.status.code(), Some(2));
}

#[test]
fn help_has_examples_and_the_demo_shows_the_joint_section() {
    for cmd in [&["joint", "--help"][..], &["import", "elcomat", "--help"]] {
        let o = gonio(cmd);
        assert!(o.status.success());
        assert!(
            String::from_utf8_lossy(&o.stdout).contains("Example"),
            "{cmd:?}"
        );
    }
    let d = tempfile::tempdir().unwrap();
    let o = gonio(&["demo", "--seed", "2", "--out", d.path().to_str().unwrap()]);
    assert!(o.status.success(), "{}", stderr(&o));
    let out = String::from_utf8_lossy(&o.stdout);
    let joint = &out[out.find("Joint calibration").expect("joint section")..];
    // Order 24: the polygon alone is blind to it, the joint estimate has it.
    let row = joint
        .lines()
        .find(|l| l.trim_start().starts_with("24 "))
        .unwrap();
    assert!(row.contains("(blind)") && row.contains('±'), "{row}");
    assert!(joint.contains("– (blind to both)"), "{joint}");
}
