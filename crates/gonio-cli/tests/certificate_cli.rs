//! The certificate from the command line: `shift-angle --json` and `selfcal --json` write a
//! gonio.certificate/1 that keeps every JSON field the commands wrote before (the key lists in
//! tests/data were taken from the commands at main 8062237), and `compare` reads two of them.

mod common;

use common::{example, gonio};
use serde_json::Value;
use std::collections::BTreeSet;
use std::path::{Path, PathBuf};

/// Runs `gonio`, asserting success.
fn ok(args: &[&str]) {
    common::ok(args);
}

fn keys_of(files: &[PathBuf]) -> BTreeSet<String> {
    let mut s = BTreeSet::new();
    for f in files {
        let v: Value = serde_json::from_str(&std::fs::read_to_string(f).unwrap()).unwrap();
        common::key_paths(&v, "", &mut s);
    }
    s
}

fn old_keys(name: &str) -> BTreeSet<String> {
    common::frozen_keys(name)
}

/// Simulated readings for both methods in `d`: (shift-angle readings, selfcal readings).
fn lab(d: &Path) -> (String, String) {
    let (sa, sc) = common::simulated_lab(
        d,
        "7",
        &["--repeats", "2", "--sigma", "0.05", "--seed", "1"],
        &["--sigma", "0.01", "--seed", "2"],
    );
    (sa.display().to_string(), sc.display().to_string())
}

#[test]
fn every_json_field_written_before_is_still_written() {
    let d = tempfile::tempdir().unwrap();
    let (sa, sc) = lab(d.path());
    let out = |n: &str| d.path().join(n);
    let p = |b: &PathBuf| b.display().to_string();
    let (sa1, sa2, sa3) = (out("sa1.json"), out("sa2.json"), out("sa3.json"));
    let inst_sa = example("instrument-shift-angle.toml");
    ok(&[
        "shift-angle",
        &sa,
        "--json",
        &p(&sa1),
        "--instrument",
        &inst_sa,
    ]);
    ok(&["shift-angle", &sa, "--json", &p(&sa2), "--sigma", "0.05"]);
    ok(&["shift-angle", &sa, "--json", &p(&sa3), "--method", "paper"]);
    let (sc1, sc2) = (out("sc1.json"), out("sc2.json"));
    let inst_sc = example("instrument-selfcal.toml");
    ok(&[
        "selfcal",
        &sc,
        "--heads",
        "selfa12",
        "--json",
        &p(&sc1),
        "--instrument",
        &inst_sc,
    ]);
    ok(&["selfcal", &sc, "--heads", "selfa12", "--json", &p(&sc2)]);
    let cmp = out("cmp.json");
    ok(&["compare", &p(&sa1), &p(&sc1), "--json", &p(&cmp)]);
    for (name, files) in [
        ("shift-angle", vec![sa1.clone(), sa2, sa3]),
        ("selfcal", vec![sc1.clone(), sc2]),
        ("compare", vec![cmp]),
    ] {
        let new = keys_of(&files);
        let old = old_keys(name);
        let lost: Vec<&String> = old.difference(&new).collect();
        assert!(lost.is_empty(), "gonio {name} no longer writes {lost:?}");
    }
    for f in [&sa1, &sc1] {
        let v: Value = serde_json::from_str(&std::fs::read_to_string(f).unwrap()).unwrap();
        assert_eq!(v["format"], "gonio.certificate/1");
    }
}

#[test]
fn selfcal_coverage_and_meta_reach_the_certificate() {
    let d = tempfile::tempdir().unwrap();
    let (_, sc) = lab(d.path());
    let j = d.path().join("sc.json").display().to_string();
    let meta = example("certificate-meta.toml");
    ok(&[
        "selfcal",
        &sc,
        "--heads",
        "selfa12",
        "--coverage",
        "0.99",
        "--meta",
        &meta,
        "--json",
        &j,
    ]);
    let v: Value = serde_json::from_str(&std::fs::read_to_string(&j).unwrap()).unwrap();
    let e = &v["errors"][0];
    assert_eq!(e["p"], 0.99);
    // One turn: ν = residual dof (large), so k = t_0.995(ν) ≈ z_0.995 = 2.576.
    assert!((e["k"].as_f64().unwrap() - 2.576).abs() < 2e-3, "{e}");
    let u = e["u_arcsec"].as_f64().unwrap();
    assert!((e["U_arcsec"].as_f64().unwrap() - e["k"].as_f64().unwrap() * u).abs() < 1e-12);
    assert_eq!(v["meta"]["item"]["identification"], "SN 2025-000123");
    assert_eq!(v["meta"]["dates"]["calibration"], "2025-03-10");
    // A bad metadata file: one line with the file, line and column, exit code 2.
    let bad = d.path().join("bad.toml");
    std::fs::write(&bad, "title = \"x\"\n[dates]\nissue = 2025-13-01\n").unwrap();
    let o = gonio(&[
        "selfcal",
        &sc,
        "--heads",
        "selfa12",
        "--meta",
        &bad.display().to_string(),
    ]);
    assert_eq!(o.status.code(), Some(2));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("bad.toml:3:"), "{err}");
    assert_eq!(err.lines().count(), 1, "{err}");
}
