//! Per-calibration records: `shift-angle --db` and `selfcal --db` store the certificate whole
//! (the same JSON `--json` writes) with its indexed fields (item, procedure, method, date,
//! largest |α|, largest U), and the store gives them back.

mod common;

use common::{example, gonio, ok};
use serde_json::Value;
use std::path::Path;

fn s(p: &Path) -> String {
    p.display().to_string()
}

fn json(p: &Path) -> Value {
    serde_json::from_str(&std::fs::read_to_string(p).unwrap()).unwrap()
}

/// Largest |α| and largest U (if any point has one) over a certificate's points, read off its
/// JSON.
fn extremes(c: &Value) -> (f64, Option<f64>) {
    // The shift-angle certificate names its points `encoder_errors` (beside the polygon's pitch
    // deviations); self-calibration names them `errors`.
    let pts = c
        .get("encoder_errors")
        .or_else(|| c.get("errors"))
        .and_then(Value::as_array)
        .expect("the certificate's points");
    let a = pts
        .iter()
        .map(|p| p["value_arcsec"].as_f64().unwrap().abs())
        .fold(0.0, f64::max);
    let u = pts
        .iter()
        .filter_map(|p| p["U_arcsec"].as_f64())
        .reduce(f64::max);
    (a, u)
}

#[test]
fn certificates_are_stored_whole_with_their_index_fields() {
    let d = tempfile::tempdir().unwrap();
    let d = d.path();
    let (lab, heads) = common::simulated_lab(d, "7", &["--seed", "1"], &["--seed", "2"]);
    let db = s(&d.join("results.sqlite"));
    let (sa, sc) = (d.join("sa.json"), d.join("sc.json"));
    let sa_readings = s(&lab);
    let (_, msg) = ok(&[
        "shift-angle",
        &sa_readings,
        "--meta",
        &example("certificate-meta.toml"),
        "--instrument",
        &example("instrument-shift-angle.toml"),
        "--json",
        &s(&sa),
        "--db",
        &db,
    ]);
    assert!(msg.contains("stored as calibration 1 in "), "{msg}");
    ok(&[
        "selfcal",
        &s(&heads),
        "--heads",
        "selfa12",
        "--instrument",
        &example("instrument-selfcal.toml"),
        "--json",
        &s(&sc),
        "--db",
        &db,
    ]);

    let mut store = gonio_store::open(&db).unwrap();
    let list = store.calibrations().unwrap();
    assert_eq!(list.len(), 2);
    let (a, b) = (&list[0], &list[1]);
    // Listings carry the index, not the certificate.
    assert!(a.certificate.is_none() && b.certificate.is_none());

    let cert_a = json(&sa);
    assert_eq!(a.item.as_deref(), Some("SN 2025-000123"));
    assert_eq!(a.calibration_date.as_deref(), Some("2025-03-10"));
    assert_eq!(a.procedure, "shift-angle");
    assert_eq!(a.method, cert_a["method"].as_str().unwrap());
    assert_eq!(a.source, sa_readings);
    let (max_a, max_u) = extremes(&cert_a);
    assert_eq!(a.max_abs_error_arcsec, max_a);
    assert_eq!(a.max_expanded_arcsec, max_u);
    assert!(max_a > 0.0 && max_u.is_some_and(|u| u > 0.0));

    let cert_b = json(&sc);
    assert_eq!(b.item, None, "no metadata: no item");
    assert_eq!(b.procedure, "self-calibration");
    assert_eq!(b.method, cert_b["method"].as_str().unwrap());
    assert_eq!(
        (b.max_abs_error_arcsec, b.max_expanded_arcsec),
        extremes(&cert_b)
    );

    // The whole certificate comes back as --json wrote it.
    let whole = store.calibration(a.calibration).unwrap().unwrap();
    assert_eq!(whole.certificate.as_ref(), Some(&cert_a));
    let whole = store.calibration(b.calibration).unwrap().unwrap();
    assert_eq!(whole.certificate.as_ref(), Some(&cert_b));
    assert!(store.calibration(99).unwrap().is_none());

    // A store that cannot be opened is a one-line error, exit code 2.
    let o = gonio(&[
        "shift-angle",
        &sa_readings,
        "--db",
        &s(&d.join("no/such/dir/r.sqlite")),
    ]);
    assert_eq!(o.status.code(), Some(2));
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(err.lines().count(), 1, "{err}");
    assert!(err.contains("results store"), "{err}");
}
