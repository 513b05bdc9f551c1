//! Invariants checked on every input of the gonio-uncertainty fuzz targets, and replayed on the
//! kept corpora and crashes by `crates/gonio-uncertainty/tests/fuzz_regressions.rs`.
//!
//! Whatever the bytes: no panic, no abort, no hang; an error is one short line with a line and
//! column inside the file; a result is made of finite numbers (JSON without `null`).
#![allow(dead_code)]

use gonio_uncertainty::instrument::InstrumentFile;
use gonio_uncertainty::limits::MAX_MESSAGE_CHARS;
use gonio_uncertainty::{BudgetFile, BudgetFileError, McConfig, McTrials, UncertaintyError};

/// Longest message of an evaluation error (names are shortened to 60 characters; a message quotes
/// at most a few of them and some numbers).
const MAX_EVALUATION_MESSAGE: usize = 1000;

/// Most Monte Carlo inputs run per fuzz input (a short run, so that each input takes milliseconds).
const MAX_MC_INPUTS: usize = 64;

fn check_file_error(data: &[u8], e: &BudgetFileError) {
    let lines = data.iter().filter(|&&b| b == b'\n').count() + 1;
    assert!(
        e.line >= 1 && e.line <= lines,
        "line {} of {lines}: {e}",
        e.line
    );
    assert!(e.column >= 1, "{e}");
    assert!(!e.message.is_empty());
    assert!(e.message.chars().count() <= MAX_MESSAGE_CHARS, "{e}");
    assert!(!e.message.chars().any(char::is_control), "{e:?}");
}

fn check_error(e: &UncertaintyError) {
    let m = e.to_string();
    assert!(
        m.chars().count() <= MAX_EVALUATION_MESSAGE,
        "{} chars",
        m.len()
    );
    assert!(!m.chars().any(char::is_control), "{m:?}");
}

fn check_finite(what: &str, x: f64) {
    assert!(x.is_finite(), "{what} = {x}");
}

/// JSON of a result: no `null` (serde writes NaN and ∞ as null).
fn check_json<T: serde::Serialize>(value: &T) {
    fn walk(v: &serde_json::Value) {
        match v {
            serde_json::Value::Null => panic!("null in the JSON"),
            serde_json::Value::Array(a) => a.iter().for_each(walk),
            serde_json::Value::Object(o) => o.values().for_each(walk),
            _ => {}
        }
    }
    walk(&serde_json::to_value(value).expect("serialisable"));
}

/// A budget file: parse (with the `from =` graph and correlations checked), evaluate every budget
/// at the file's coverage and at 99 %, flatten the last one and run 1,000 Monte Carlo trials of it
/// when it has at most 64 inputs.
pub fn budget_toml(data: &[u8]) {
    let file = match BudgetFile::parse_bytes(data) {
        Ok(f) => f,
        Err(e) => return check_file_error(data, &e),
    };
    let located = |e: &UncertaintyError| {
        check_error(e);
        if let Some((line, column)) = file.locate(e) {
            assert!(line >= 1 && column >= 1);
        }
    };
    for coverage in [None, Some(0.99)] {
        match file.set.evaluate_all(coverage) {
            Ok(all) => {
                assert_eq!(all.len(), file.set.budgets.len());
                for r in &all {
                    for (what, x) in [
                        ("value", r.value),
                        ("u_c", r.u_c),
                        ("k", r.k),
                        ("U", r.expanded),
                    ] {
                        check_finite(what, x);
                    }
                    assert!(r.u_c >= 0.0 && r.k > 0.0 && !r.nu_eff_raw.is_nan());
                    for row in &r.contributions {
                        for x in [row.value, row.u, row.c, row.cu, row.share] {
                            check_finite(&row.name, x);
                        }
                    }
                }
                check_json(&all);
            }
            Err(e) => located(&e),
        }
    }
    let Ok(names) = file.set.dependencies(None) else {
        return;
    };
    assert!(!names.is_empty());
    match file.set.linear_model(None) {
        Ok(m) if !m.inputs.is_empty() && m.inputs.len() <= MAX_MC_INPUTS => {
            let cfg = McConfig {
                coverage: file.set.coverage.min(0.99),
                trials: McTrials::Fixed(1000),
                ..McConfig::default()
            };
            match m.monte_carlo(&cfg) {
                Ok(r) => {
                    check_finite("estimate", r.estimate);
                    check_finite("u(y)", r.std_uncertainty);
                    assert!(r.symmetric.low <= r.symmetric.high);
                    assert!(r.shortest.high - r.shortest.low <= r.symmetric.high - r.symmetric.low);
                    check_json(&r);
                }
                Err(e) => located(&e),
            }
        }
        Ok(_) => {}
        Err(e) => located(&e),
    }
}

/// An instrument file: parse, then combine with a random part of 0.01 (ν = 5) and as a budget
/// table.
pub fn instrument_toml(data: &[u8]) {
    let inst = match InstrumentFile::parse_bytes(data) {
        Ok(i) => i,
        Err(e) => return check_file_error(data, &e),
    };
    match inst.combine(0.01, 5.0) {
        Ok(c) => {
            for (what, x) in [("u_c", c.u_c), ("k", c.k), ("U", c.expanded)] {
                check_finite(what, x);
            }
            check_json(&c);
        }
        Err(e) => check_error(&e),
    }
    match inst
        .budget("angle", "random part", 0.01, 5.0)
        .evaluate(inst.coverage)
    {
        Ok(r) => {
            check_finite("U", r.expanded);
            check_json(&r);
        }
        Err(e) => check_error(&e),
    }
}
