//! `gonio budget` against hostile inputs, through the binary: each input is generated
//! here. A 65,536-character row name, U overflowing to infinity, a BOM, Latin-1 bytes, an error
//! that would echo a megabyte, a diamond of 60 nested budgets, a 1,000-row correlation chain and a
//! Monte Carlo run beyond the work limit. Correctness only: speed is in the criterion benches.

mod common;

use common::{gonio, stderr, stdout};
#[path = "../../gonio-uncertainty/tests/support/hostile_inputs.rs"]
mod hostile_inputs;

use hostile_inputs::{chain, diamond, rows};
use std::path::Path;
use std::process::Output;

/// Writes `bytes` to `dir/name` and runs `gonio budget` on it with `extra` arguments.
fn budget(dir: &Path, name: &str, bytes: &[u8], extra: &[&str]) -> Output {
    let p = dir.join(name);
    std::fs::write(&p, bytes).unwrap();
    let mut args = vec!["budget", p.to_str().unwrap()];
    args.extend_from_slice(extra);
    gonio(&args)
}

/// The one-line error of a failed run: exit code 2, `error: FILE:LINE:COL: …`, short.
fn one_line_error(o: &Output, file: &str, at: &str) -> String {
    let e = stderr(o);
    assert_eq!(o.status.code(), Some(2), "{e}");
    assert_eq!(e.lines().count(), 1, "{e}");
    assert!(e.len() < 600, "{} bytes", e.len());
    let prefix = format!("error: {file}:{at}: ");
    assert!(e.contains(&prefix), "{e}");
    e
}

#[test]
fn long_row_name_is_cut_for_display_and_kept_in_json() {
    let d = tempfile::tempdir().unwrap();
    let long = "é".repeat(65_536);
    let text = format!(
        "[[budget]]\nname = \"b\"\n[[budget.contribution]]\nname = \"{long}\"\nu = 1\n\
         [[budget.contribution]]\nname = \"short\"\nu = 2\n"
    );
    let json = d.path().join("out.json");
    let o = budget(
        d.path(),
        "long.toml",
        text.as_bytes(),
        &["--json", json.to_str().unwrap()],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let out = stdout(&o);
    // Every table line is short; the long name shows as its first 47 characters and an ellipsis.
    assert!(out.lines().all(|l| l.chars().count() < 120), "{out}");
    assert!(out.contains(&format!("{}…", "é".repeat(47))), "{out}");
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    assert_eq!(v["contributions"][0]["name"].as_str().unwrap(), long);
    // u_c = √(1 + 4).
    assert!((v["u_c"].as_f64().unwrap() - 5f64.sqrt()).abs() < 1e-15);
    for format in ["markdown", "csv"] {
        let o = budget(
            d.path(),
            "long.toml",
            text.as_bytes(),
            &["--format", format],
        );
        assert!(o.status.success(), "{format}: {}", stderr(&o));
    }
}

#[test]
fn overflow_is_an_error_not_a_null() {
    let d = tempfile::tempdir().unwrap();
    let json = d.path().join("out.json");
    let text = "[[budget]]\nname = \"b\"\n[[budget.contribution]]\nname = \"a\"\nu = 1e308\n\
                [[budget.contribution]]\nname = \"c\"\nu = 1e308\n";
    let o = budget(
        d.path(),
        "big.toml",
        text.as_bytes(),
        &["--json", json.to_str().unwrap()],
    );
    let file = d.path().join("big.toml").display().to_string();
    let e = one_line_error(&o, &file, "2:8");
    assert!(e.contains("budget 'b': U = k·u_c = 1.9600 × 1.414"), "{e}");
    assert!(!json.exists(), "no JSON is written");
    assert!(stdout(&o).is_empty());
}

#[test]
fn bom_is_skipped_and_latin1_is_located() {
    let d = tempfile::tempdir().unwrap();
    let ok = b"\xEF\xBB\xBF# a comment first\n[[budget]]\nname = \"b\"\n[[budget.contribution]]\nname = \"a\"\nu = 0.5\n";
    let o = budget(d.path(), "bom.toml", ok, &[]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stdout(&o).contains("u_c = 0.5000"), "{}", stdout(&o));
    let bad =
        b"[[budget]]\nname = \"b\"\n[[budget.contribution]]\nname = \"temp\xE9rature\"\nu = 1\n";
    let o = budget(d.path(), "latin1.toml", bad, &[]);
    let file = d.path().join("latin1.toml").display().to_string();
    let e = one_line_error(&o, &file, "4:13");
    assert!(e.contains("invalid UTF-8 (byte 0xE9)"), "{e}");
}

#[test]
fn error_lines_stay_short() {
    let d = tempfile::tempdir().unwrap();
    // The TOML layer would echo the megabyte-long string.
    let text = format!(
        "[[budget]]\nname = \"b\"\n[[budget.contribution]]\nname = \"r\"\nu = \"{}\"\n",
        "y".repeat(1 << 20)
    );
    let o = budget(d.path(), "echo.toml", text.as_bytes(), &[]);
    let file = d.path().join("echo.toml").display().to_string();
    one_line_error(&o, &file, "5:5");
    // An unknown --budget among many long names.
    let mut text = String::new();
    for k in 0..100 {
        text += &format!(
            "[[budget]]\nname = \"{}{k}\"\n[[budget.contribution]]\nname = \"r\"\nu = 1\n",
            "n".repeat(10_000)
        );
    }
    let o = budget(
        d.path(),
        "many.toml",
        text.as_bytes(),
        &["--budget", "none"],
    );
    let e = stderr(&o);
    assert_eq!(o.status.code(), Some(2));
    assert!(e.len() < 1200, "{} bytes", e.len());
    assert!(e.contains("… (100 budgets)"), "{e}");
}

/// A diamond of 60 levels (2⁶⁰ paths): evaluated and drawn once per budget. Each level is
/// 1.5 × the one below, so u_c = 0.1 × 1.5⁶⁰, and Monte Carlo (one normal leaf) agrees.
#[test]
fn diamond_of_sixty_budgets() {
    let d = tempfile::tempdir().unwrap();
    let text = diamond(60);
    let json = d.path().join("out.json");
    let o = budget(
        d.path(),
        "diamond.toml",
        text.as_bytes(),
        &[
            "--monte-carlo",
            "--trials",
            "100000",
            "--json",
            json.to_str().unwrap(),
        ],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    let expect = 0.1 * 1.5f64.powi(60);
    let u_c = v["u_c"].as_f64().unwrap();
    assert!((u_c - expect).abs() < 1e-12 * expect, "{u_c}");
    assert_eq!(v["budgets"].as_array().unwrap().len(), 61);
    // u(y) of 10⁵ normal draws: relative standard error 1/√(2·10⁵) = 0.22 %; allow 4 of them.
    let u_mc = v["monte_carlo"]["std_uncertainty"].as_f64().unwrap();
    assert!(
        (u_mc / expect - 1.0).abs() < 4.0 / 200_000f64.sqrt(),
        "{u_mc}"
    );
    // The text output lists every budget once.
    assert_eq!(stdout(&o).matches("Budget \"").count(), 61);
}

/// 1,000 rows with 999 neighbour correlations: u_c² = Σu² + 2Σ r u u.
#[test]
fn thousand_row_correlation_chain() {
    let d = tempfile::tempdir().unwrap();
    let text = chain(1000, 0.3);
    let json = d.path().join("out.json");
    let o = budget(
        d.path(),
        "chain.toml",
        text.as_bytes(),
        &["--json", json.to_str().unwrap()],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    let expect = (10.0 + 2.0 * 999.0 * 0.3 * 0.01f64).sqrt();
    assert!((v["u_c"].as_f64().unwrap() - expect).abs() < 1e-12 * expect);
}

/// Monte Carlo on 10,000 rows: --trials beyond the work limit is refused before drawing, with the
/// largest number allowed.
#[test]
fn monte_carlo_work_limit() {
    let d = tempfile::tempdir().unwrap();
    let text = rows("b", 10_000);
    let o = budget(
        d.path(),
        "rows.toml",
        text.as_bytes(),
        &["--monte-carlo", "--trials", "1000000"],
    );
    let e = stderr(&o);
    assert_eq!(o.status.code(), Some(2), "{e}");
    assert_eq!(e.lines().count(), 1, "{e}");
    assert!(e.contains("is more than the limit of 2000000000"), "{e}");
    assert!(e.contains("use at most 200000 trials"), "{e}");
}
