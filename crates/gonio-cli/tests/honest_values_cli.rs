//! Numbers that are wrong but finite, and DCCs that are valid or not written, one
//! test per class, through the binary: En with U = 0 does not pass; a coverage
//! factor beyond f64 is an error; shift angles are range-checked and shifts a pitch apart are
//! refused; a 3-face polygon and all-zero readings are valid; metadata with a NaN temperature or
//! a control character is refused; a hand-edited certificate (negative U, p > 1, no angles) is
//! refused when read, and no DCC is written from it. Every refusal: one line, exit code 2.

mod common;

use common::{example, gonio, ok, stderr};
use serde_json::Value;
use std::path::{Path, PathBuf};
use std::process::Output;

fn s(p: &Path) -> String {
    p.display().to_string()
}

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

/// A readings file of an N-face polygon, full matrices at the given shifts, every reading
/// `value(shift, face, step)`.
fn readings(dir: &Path, name: &str, faces: usize, shifts: &[&str], value: f64) -> PathBuf {
    let mut t = String::from("shift_deg,start_face,step,reading_arcsec,repeat\n");
    for (k, sh) in shifts.iter().enumerate() {
        for j in 1..=faces {
            for i in 1..=faces {
                for r in 1..=2 {
                    let v = if value == 0.0 {
                        0.0
                    } else {
                        value * ((i * 7 + j * 3 + k) % 5) as f64 + 0.001 * r as f64
                    };
                    t.push_str(&format!("{sh},{j},{i},{v},{r}\n"));
                }
            }
        }
    }
    let p = dir.join(name);
    std::fs::write(&p, t).unwrap();
    p
}

#[test]
fn a_comparison_with_no_uncertainty_does_not_pass() {
    let d = tempfile::tempdir().unwrap();
    let f = readings(d.path(), "r.csv", 6, &["0", "10"], 0.1);
    let cert = d.path().join("c.json");
    ok(&["shift-angle", &s(&f), "--json", &s(&cert)]);
    // The same certificate with U = 0 everywhere (as a self-calibration of two identical turns
    // gives), against a copy whose α differs by 0.13″: no En is defined.
    let mut v: Value = serde_json::from_str(&std::fs::read_to_string(&cert).unwrap()).unwrap();
    for p in v["encoder_errors"].as_array_mut().unwrap() {
        p["u_arcsec"] = 0.0.into();
        p["U_arcsec"] = 0.0.into();
    }
    let a = d.path().join("a.json");
    std::fs::write(&a, v.to_string()).unwrap();
    for p in v["encoder_errors"].as_array_mut().unwrap() {
        p["value_arcsec"] = (p["value_arcsec"].as_f64().unwrap() + 0.13).into();
    }
    let b = d.path().join("b.json");
    std::fs::write(&b, v.to_string()).unwrap();
    let out = d.path().join("cmp.json");
    let (text, _) = ok(&["compare", &s(&a), &s(&b), "--json", &s(&out)]);
    assert!(!text.contains("every En ≤ 1"), "{text}");
    assert!(
        text.contains("NOT PASSED: En undefined at 12 of 12 angles"),
        "{text}"
    );
    let c: Value = serde_json::from_str(&std::fs::read_to_string(&out).unwrap()).unwrap();
    assert_eq!(c["all_en_pass"], false);
    assert_eq!(c["en_undefined"], 12);
    assert!(
        c["max_en"].is_null() && c["points"][0]["en"].is_null(),
        "{c}"
    );
    assert!((c["max_abs_difference_arcsec"].as_f64().unwrap() - 0.13).abs() < 1e-9);
}

#[test]
fn a_coverage_factor_beyond_f64_is_an_error() {
    let d = tempfile::tempdir().unwrap();
    let b = d.path().join("b.toml");
    std::fs::write(
        &b,
        "coverage = 0.95\n[[budget]]\nname = \"x\"\n[[budget.contribution]]\nname = \"tiny dof\"\nu = 0.1\ndof = 1e-5\n",
    )
    .unwrap();
    let o = gonio(&["budget", &s(&b)]);
    refused(&o, "coverage factor");
    // A small but resolvable ν still works.
    std::fs::write(
        &b,
        "coverage = 0.95\n[[budget]]\nname = \"x\"\n[[budget.contribution]]\nname = \"few dof\"\nu = 0.1\ndof = 1.5\n",
    )
    .unwrap();
    ok(&["budget", &s(&b)]);
}

#[test]
fn shift_angles_are_range_checked_and_shifts_a_pitch_apart_refused() {
    let d = tempfile::tempdir().unwrap();
    let f = readings(d.path(), "big.csv", 6, &["0", "1e300"], 0.1);
    let e = refused(&gonio(&["shift-angle", &s(&f)]), "out of range");
    assert!(e.contains("big.csv:"), "{e}");
    assert!(e.contains("shift 1e300°"), "{e}");
    let f = readings(d.path(), "neg.csv", 6, &["-5", "0"], 0.1);
    refused(&gonio(&["shift-angle", &s(&f)]), "out of range");
    // N = 6: pitch 60°; shifts 5° and 65° give every angle twice.
    let f = readings(d.path(), "twice.csv", 6, &["5", "65"], 0.1);
    let comp = d.path().join("comp.csv");
    let e = refused(
        &gonio(&["shift-angle", &s(&f), "--compensation", &s(&comp)]),
        "differ by a multiple of the pitch 60°",
    );
    assert!(e.contains("twice.csv"), "{e}");
    assert!(!comp.exists(), "nothing written");
    // The joint calibration reads the same polygon readings.
    let (_, sc) = common::simulated_lab(d.path(), "3", &["--seed", "1"], &["--seed", "2"]);
    refused(
        &gonio(&[
            "joint",
            &s(&f),
            &s(&sc),
            "--faces",
            "6",
            "--heads",
            "selfa12",
        ]),
        "differ by a multiple of the pitch",
    );
}

#[test]
fn a_three_face_polygon_and_all_zero_readings_are_valid() {
    let d = tempfile::tempdir().unwrap();
    for (name, faces, value) in [
        ("three.csv", 3, 0.1),
        ("zero3.csv", 3, 0.0),
        ("zero6.csv", 6, 0.0),
    ] {
        let f = readings(d.path(), name, faces, &["0", "10"], value);
        for method in ["least-squares", "paper"] {
            let out = d.path().join(format!("{name}-{method}.json"));
            let o = gonio(&[
                "shift-angle",
                &s(&f),
                "--method",
                method,
                "--json",
                &s(&out),
            ]);
            assert!(o.status.success(), "{name} {method}: {}", stderr(&o));
            let v: Value = serde_json::from_str(&std::fs::read_to_string(&out).unwrap()).unwrap();
            let pts = v["encoder_errors"].as_array().unwrap();
            assert_eq!(pts.len(), 2 * faces, "{name}");
            if value == 0.0 {
                // An error-free encoder: α = 0 everywhere.
                assert!(
                    pts.iter()
                        .all(|p| p["value_arcsec"].as_f64().unwrap().abs() < 1e-12),
                    "{name}"
                );
            }
            let text = common::stdout(&o);
            assert!(!text.contains("NaN"), "{text}");
        }
    }
}

#[test]
fn metadata_with_a_nan_temperature_or_a_control_character_is_refused() {
    let d = tempfile::tempdir().unwrap();
    let f = readings(d.path(), "r.csv", 6, &["0", "10"], 0.1);
    let base = std::fs::read_to_string(example("certificate-meta.toml")).unwrap();
    let cases = [
        (
            "nan.toml",
            base.replace("temperature_c = 20.1", "temperature_c = nan"),
            "environment.temperature_c: NaN",
        ),
        (
            "soh.toml",
            base.replace("remarks = \"Cal", "remarks = \"A\\u0001Cal"),
            "remarks: control character U+0001",
        ),
        (
            "esc.toml",
            base.replace("remarks = \"Cal", "remarks = \"\\u001b[31mCal"),
            "remarks: control character U+001B",
        ),
        (
            "ff.toml",
            base.replace("remarks = \"Cal", "remarks = \"\\fCal"),
            "remarks: control character U+000C",
        ),
    ];
    let cert = d.path().join("c.json");
    ok(&["shift-angle", &s(&f), "--json", &s(&cert)]);
    for (name, text, want) in cases {
        assert_ne!(text, base, "{name}: the example changed");
        let m = d.path().join(name);
        std::fs::write(&m, &text).unwrap();
        let json = d.path().join(format!("{name}.json"));
        let e = refused(
            &gonio(&["shift-angle", &s(&f), "--meta", &s(&m), "--json", &s(&json)]),
            want,
        );
        assert!(e.contains(name), "{e}");
        assert!(!json.exists(), "{name}: nothing written");
        let dcc = d.path().join(format!("{name}.xml"));
        refused(
            &gonio(&[
                "certificate",
                &s(&cert),
                "--meta",
                &s(&m),
                "--dcc",
                &s(&dcc),
            ]),
            want,
        );
        assert!(!dcc.exists(), "{name}: no DCC");
    }
}

#[test]
fn a_hand_edited_certificate_is_refused_when_read() {
    let d = tempfile::tempdir().unwrap();
    let f = readings(d.path(), "r.csv", 6, &["0", "10"], 0.1);
    let cert = d.path().join("c.json");
    ok(&["shift-angle", &s(&f), "--json", &s(&cert)]);
    let good: Value = serde_json::from_str(&std::fs::read_to_string(&cert).unwrap()).unwrap();
    type Edit = fn(&mut Value);
    let edits: [(&str, Edit, &str); 7] = [
        (
            "negative U",
            |v| v["encoder_errors"][3]["U_arcsec"] = (-0.1).into(),
            "encoder_errors[3].U_arcsec: -0.1",
        ),
        (
            "p above 1",
            |v| v["encoder_errors"][0]["p"] = 1.5.into(),
            "encoder_errors[0].p: 1.5",
        ),
        (
            "no angles",
            |v| v["encoder_errors"] = Value::Array(vec![]),
            "no calibrated angle",
        ),
        (
            "angle 1e300",
            |v| v["encoder_errors"][2]["angle_deg"] = 1e300.into(),
            "encoder_errors[2].angle_deg",
        ),
        (
            "negative u",
            |v| v["encoder_errors"][1]["u_arcsec"] = (-1.0).into(),
            "encoder_errors[1].u_arcsec",
        ),
        (
            "coverage 1",
            |v| v["uncertainty"]["coverage"] = 1.0.into(),
            "uncertainty.coverage",
        ),
        (
            "control character",
            |v| v["method"] = "least\u{7}squares".into(),
            "method: control character U+0007",
        ),
    ];
    for (what, edit, want) in edits {
        let mut v = good.clone();
        edit(&mut v);
        let bad = d.path().join("bad.json");
        std::fs::write(&bad, serde_json::to_string_pretty(&v).unwrap()).unwrap();
        let dcc = d.path().join("bad.xml");
        let e = refused(
            &gonio(&[
                "certificate",
                &s(&bad),
                "--meta",
                &example("certificate-meta.toml"),
                "--dcc",
                &s(&dcc),
            ]),
            want,
        );
        // Located: the file and the field.
        assert!(
            e.starts_with(&format!("error: {}: ", s(&bad))),
            "{what}: {e}"
        );
        assert!(!dcc.exists(), "{what}: no DCC");
        // The other readers refuse it the same way.
        refused(&gonio(&["compare", &s(&bad), &s(&cert)]), want);
    }
}
