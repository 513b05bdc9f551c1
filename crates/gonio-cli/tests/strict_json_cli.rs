//! Strict JSON everywhere: every command's `--json` (and `detect --json-lines`), every
//! `mount` strategy at both fidelities, with and without quality-gate rejections, is read by a
//! strict parser (serde_json: no `NaN`, `Infinity` or out-of-range numbers) and keeps the frozen
//! key lists of tests/data/json-keys-*.txt. A quantity a method does not define is `null` (u(e)
//! of the paper's extreme-point fit, e of a part no trusted turn measured), the terminal tables
//! show `–` for it and never `NaN`, and `gonio replay` reads records that hold such nulls.

mod common;

use common::{example, frozen_keys, gonio, key_paths, ok};
use serde_json::Value;
use std::collections::BTreeSet;
use std::path::{Path, PathBuf};

fn s(p: &Path) -> String {
    p.display().to_string()
}

/// Every number in `v` is finite (serde_json already refuses `NaN`, `Infinity` and 1e999).
fn all_finite(v: &Value, at: &str) {
    match v {
        Value::Number(n) => {
            let x = n.as_f64().unwrap();
            assert!(x.is_finite(), "{at}: {x}");
        }
        Value::Array(a) => a
            .iter()
            .enumerate()
            .for_each(|(i, x)| all_finite(x, &format!("{at}[{i}]"))),
        Value::Object(m) => m
            .iter()
            .for_each(|(k, x)| all_finite(x, &format!("{at}.{k}"))),
        _ => {}
    }
}

/// Reads `text` strictly.
#[track_caller]
fn strict_text(name: &str, text: &str) -> Value {
    let v: Value = serde_json::from_str(text).unwrap_or_else(|e| {
        panic!(
            "{name}: not strict JSON: {e}\n{}",
            &text[..text.len().min(400)]
        )
    });
    all_finite(&v, name);
    v
}

/// Reads a JSON file strictly.
#[track_caller]
fn strict(p: &Path) -> Value {
    strict_text(&s(p), &std::fs::read_to_string(p).unwrap())
}

/// Every key of the frozen list `name` is among `keys`.
#[track_caller]
fn keeps_keys(name: &str, keys: &BTreeSet<String>) {
    let missing: Vec<String> = frozen_keys(name).difference(keys).cloned().collect();
    assert!(
        missing.is_empty(),
        "`gonio {name} --json` no longer writes {missing:?}"
    );
}

fn keys(v: &Value) -> BTreeSet<String> {
    let mut k = BTreeSet::new();
    key_paths(v, "", &mut k);
    k
}

/// A recipe file in `dir`: fewer, faster frames (60 a turn, a 5-step focus sweep) so that the
/// frames fidelity stays quick, and, with `untrusted`, a quality gate no turn passes (every
/// part ends `measurement_untrusted`).
fn recipe(dir: &Path, untrusted: bool) -> PathBuf {
    let p = dir.join(if untrusted {
        "untrusted.toml"
    } else {
        "quick.toml"
    });
    let mut t = String::from(
        "name = \"quick\"\n[measure]\nspeed_deg_per_s = 360.0\nfps = 60.0\n[focus]\nsteps = 5\n",
    );
    if untrusted {
        t.push_str("[quality]\nmax_residual_rms_px = 0.001\n");
    }
    std::fs::write(&p, t).unwrap();
    p
}

const STRATEGIES: [&str; 4] = ["paper", "learned", "live", "least-squares"];

/// Checks one mount batch: strict, its parts' nulls where the method defines nothing, and the
/// terminal table without `NaN`.
#[track_caller]
fn check_batch(v: &Value, strategy: &str, untrusted: bool) {
    let parts = v["parts"].as_array().unwrap();
    assert!(!parts.is_empty());
    for p in parts {
        let result = p["result"].as_str().unwrap();
        if untrusted {
            assert_eq!(result, "measurement_untrusted", "{p}");
            assert!(
                p["initial_e_um"].is_null() && p["final_e_um"].is_null(),
                "{p}"
            );
            assert_eq!(p["pushes"], 0);
        }
        for t in p["turns"].as_array().unwrap() {
            if strategy == "paper" {
                // The extreme-point fit defines no u(e): null, never a number.
                assert!(t["u_e_um"].is_null(), "{t}");
            } else if t["e_um"].is_number() {
                assert!(t["u_e_um"].is_number(), "{t}");
            }
            if t["e_um"].is_null() {
                assert!(t["c0_px"].is_null() && t["theta_max_deg"].is_null(), "{t}");
            }
        }
        for q in p["push_log"].as_array().unwrap() {
            // e after the push is null exactly when no trusted verify turn measured it.
            assert_eq!(q["e_after_um"].is_null(), q["consistent"].is_null(), "{q}");
        }
    }
    if untrusted {
        assert!(
            v["summary"]["mean_final_e_um"].is_null(),
            "{}",
            v["summary"]
        );
    }
}

#[test]
fn every_mount_strategy_and_fidelity_writes_strict_json() {
    let d = tempfile::tempdir().unwrap();
    let (quick, untrusted) = (recipe(d.path(), false), recipe(d.path(), true));
    let mut all = BTreeSet::new();
    let mut n = 0;
    for strategy in STRATEGIES {
        for (fidelity, parts) in [("fast", "6"), ("frames", "1")] {
            for (bad, r) in [(false, &quick), (true, &untrusted)] {
                // The frames fidelity once per strategy with the gate rejecting, once without.
                let out = d.path().join(format!("{strategy}-{fidelity}-{bad}.json"));
                let o = gonio(&[
                    "mount",
                    "--sim",
                    "--strategy",
                    strategy,
                    "--fidelity",
                    fidelity,
                    "--parts",
                    parts,
                    "--seed",
                    "11",
                    "--recipe",
                    &s(r),
                    "--json",
                    &s(&out),
                ]);
                let err = common::stderr(&o);
                assert!(o.status.success(), "{strategy} {fidelity} {bad}: {err}");
                let v = strict(&out);
                check_batch(&v, strategy, bad);
                all.extend(keys(&v));
                n += 1;
            }
        }
    }
    assert_eq!(n, 16);
    // The issue's own example: 200 parts of the paper's strategy, the default recipe.
    let out = d.path().join("paper200.json");
    ok(&[
        "mount",
        "--sim",
        "--parts",
        "200",
        "--seed",
        "11",
        "--strategy",
        "paper",
        "--json",
        &s(&out),
    ]);
    let v = strict(&out);
    check_batch(&v, "paper", false);
    all.extend(keys(&v));
    keeps_keys("mount", &all);
}

#[test]
fn terminal_tables_show_a_dash_never_nan() {
    let d = tempfile::tempdir().unwrap();
    let untrusted = recipe(d.path(), true);
    let db = d.path().join("r.sqlite");
    let (out, _) = ok(&[
        "mount",
        "--sim",
        "--parts",
        "3",
        "--seed",
        "2",
        "--recipe",
        &s(&untrusted),
        "--db",
        &s(&db),
    ]);
    assert!(!out.contains("NaN"), "{out}");
    assert!(out.contains("measurement_untrusted"), "{out}");
    assert!(out.contains(" – "), "{out}");
    let (out, _) = ok(&["parts", "--db", &s(&db)]);
    assert!(!out.contains("NaN"), "{out}");
    assert!(out.contains("–"), "{out}");
    // The store's JSON holds the same nulls.
    let (json, _) = ok(&["parts", "--db", &s(&db), "--json"]);
    let v = strict_text("parts --json", &json);
    let p = &v.as_array().unwrap()[0];
    assert!(p["initial_e_um"].is_null(), "{p}");
}

#[test]
fn replay_reads_paper_and_untrusted_records() {
    let d = tempfile::tempdir().unwrap();
    let (quick, untrusted) = (recipe(d.path(), false), recipe(d.path(), true));
    let mut all = BTreeSet::new();
    for (name, strategy, r) in [
        ("paper", "paper", &quick),
        ("untrusted", "learned", &untrusted),
    ] {
        let rec = d.path().join(name);
        let batch = d.path().join(format!("{name}.json"));
        ok(&[
            "mount",
            "--sim",
            "--fidelity",
            "frames",
            "--strategy",
            strategy,
            "--parts",
            "1",
            "--seed",
            "4",
            "--recipe",
            &s(r),
            "--record",
            &s(&rec),
            "--json",
            &s(&batch),
        ]);
        let b = strict(&batch);
        check_batch(&b, strategy, name == "untrusted");
        strict(&rec.join("part-0001/part.json"));
        let out = d.path().join(format!("{name}-replay.json"));
        let (text, _) = ok(&["replay", &s(&rec), "--json", &s(&out)]);
        assert!(text.contains("bit-identical to the record"), "{text}");
        let v = strict(&out);
        let turns = v[0]["turns"].as_array().unwrap();
        assert!(!turns.is_empty());
        for t in turns {
            assert_eq!(t["differences"], Value::Array(vec![]), "{t}");
            if strategy == "paper" {
                assert!(t["turn"]["u_e_um"].is_null(), "{t}");
            }
        }
        all.extend(keys(&v));
    }
    keeps_keys("replay", &all);
}

#[test]
fn every_other_command_writes_strict_json() {
    let d = tempfile::tempdir().unwrap();
    let p = |n: &str| d.path().join(n);
    let (sa, sc) = common::simulated_lab(
        d.path(),
        "7",
        &["--repeats", "2", "--sigma", "0.05", "--seed", "1"],
        &["--sigma", "0.01", "--seed", "2"],
    );
    // Budgets.
    for b in [
        "hsieh2022-shift-angle.toml",
        "jcgm100-h1.toml",
        "hsieh2022-selfcal.toml",
    ] {
        let out = p(&format!("{b}.json"));
        ok(&[
            "budget",
            &example(&format!("budgets/{b}")),
            "--json",
            &s(&out),
        ]);
        strict(&out);
    }
    // Calibrations, with the frozen key lists of their certificates.
    // The same runs as the key lists were taken from (certificate_cli.rs): with the instrument
    // terms, with a stated σ, and the paper's method.
    let inst_sa = example("instrument-shift-angle.toml");
    let inst_sc = example("instrument-selfcal.toml");
    let mut sa_keys = BTreeSet::new();
    for (name, method, extra) in [
        (
            "sa-ls.json",
            "least-squares",
            ["--instrument", inst_sa.as_str()],
        ),
        ("sa-sigma.json", "least-squares", ["--sigma", "0.05"]),
        ("sa-paper.json", "paper", ["--sigma", "0.05"]),
    ] {
        let out = p(name);
        let (o, m) = (s(&out), s(&sa));
        let args = [
            "shift-angle",
            m.as_str(),
            "--method",
            method,
            "--json",
            o.as_str(),
            extra[0],
            extra[1],
        ];
        ok(&args);
        sa_keys.extend(keys(&strict(&out)));
    }
    keeps_keys("shift-angle", &sa_keys);
    let sc_out = p("sc.json");
    let sc_plain = p("sc-plain.json");
    let mut sc_keys = BTreeSet::new();
    for (out, extra) in [
        (&sc_out, vec!["--instrument", inst_sc.as_str()]),
        (&sc_plain, vec![]),
    ] {
        let (o, m) = (s(out), s(&sc));
        let args = [
            &[
                "selfcal",
                m.as_str(),
                "--heads",
                "selfa12",
                "--json",
                o.as_str(),
            ][..],
            &extra[..],
        ]
        .concat();
        ok(&args);
        sc_keys.extend(keys(&strict(out)));
    }
    keeps_keys("selfcal", &sc_keys);
    let cmp = p("cmp.json");
    ok(&[
        "compare",
        &s(&p("sa-ls.json")),
        &s(&sc_out),
        "--json",
        &s(&cmp),
    ]);
    keeps_keys("compare", &keys(&strict(&cmp)));
    // The certificate with its metadata attached.
    let cert = p("cert.json");
    ok(&[
        "certificate",
        &s(&sc_out),
        "--meta",
        &example("certificate-meta.toml"),
        "--json",
        &s(&cert),
    ]);
    strict(&cert);
    // Eccentricity of one turn by the paper's method: u(e) is null.
    let turn = p("turn.csv");
    let mut t = String::from("theta_deg,c_px\n");
    for i in 0..200 {
        let th = 1.8 * i as f64;
        t.push_str(&format!(
            "{th},{}\n",
            720.0 + 40.0 * th.to_radians().cos() + 0.05 * (7.0 * th).to_radians().sin()
        ));
    }
    std::fs::write(&turn, t).unwrap();
    for method in ["paper", "least-squares"] {
        let out = p(&format!("ecc-{method}.json"));
        ok(&[
            "eccentricity",
            &s(&turn),
            "--method",
            method,
            "--json",
            &s(&out),
        ]);
        let v = strict(&out);
        assert_eq!(v["u_e_um"].is_null(), method == "paper", "{v}");
    }
    // Detector lines, of a frame with a ring and one without (as detect_cli.rs took its list).
    let mut dk = BTreeSet::new();
    for (name, extra) in [("ring", None), ("none", Some("--no-ring"))] {
        let frames = p(name);
        let f = s(&frames);
        let mut args = vec![
            "simulate", "frames", "--count", "1", "--seed", "3", "--out", &f,
        ];
        args.extend(extra);
        ok(&args);
        let (lines, _) = ok(&["detect", &f]);
        for l in lines.lines() {
            dk.extend(keys(&strict_text("detect", l)));
        }
    }
    keeps_keys("detect", &dk);
}
