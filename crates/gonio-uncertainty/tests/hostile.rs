//! Hostile inputs, generated here (no large files in the repository), one test per class of
//! sizes and super-linear work (a diamond of nested budgets, a 1,000-row correlation
//! chain, the envelope and Monte Carlo limits), long names, overflow (finite in, finite out), and
//! encodings (BOM, non-UTF-8, UTF-16). Speed is measured by the `budget` criterion bench; these
//! tests assert correctness only.

#[path = "support/hostile_inputs.rs"]
mod hostile_inputs;

use gonio_uncertainty::instrument::InstrumentFile;
use gonio_uncertainty::limits::{MAX_BUDGETS, MAX_CORRELATION_ENVELOPE, MAX_MESSAGE_CHARS};
use gonio_uncertainty::{
    BudgetFile, InputDistribution, McConfig, McTrials, UncertaintyError, decode_text,
    monte_carlo_with_progress, parse_budget_file,
};
use hostile_inputs::{chain, diamond, rows};

/// Each level of the diamond is one quantity referred to twice: b_k = b_{k−1} + 0.5·b_{k−1}
/// = 1.5·b_{k−1}, so u(b_k) = 1.5^k · 0.1 exactly (the two references are fully correlated). The
/// evaluation and the Monte Carlo model visit each of the 61 budgets once (2⁶⁰ paths).
#[test]
fn diamond_of_sixty_nested_budgets_is_evaluated_once_per_budget() {
    let set = parse_budget_file(&diamond(60)).unwrap();
    let all = set.evaluate_all(None).unwrap();
    for (k, r) in all.iter().enumerate() {
        let expect = 0.1 * 1.5f64.powi(k as i32);
        // Rounding: one product and one square root per level, ~1e-16 relative each.
        assert!(
            (r.u_c - expect).abs() <= 1e-13 * expect,
            "level {k}: {} vs {expect}",
            r.u_c
        );
    }
    let model = set.linear_model(None).unwrap();
    assert_eq!(model.inputs.len(), 1);
    assert_eq!(model.names, ["b0/leaf"]);
    assert!((model.coefficients[0] - 1.5f64.powi(60)).abs() <= 1e-13 * 1.5f64.powi(60));
    // Monte Carlo of the same model agrees with the GUM within its tolerance (normal leaf,
    // linear model: the GUM interval is exact).
    let mc = model
        .monte_carlo(&McConfig {
            trials: McTrials::Fixed(200_000),
            ..McConfig::default()
        })
        .unwrap();
    let top = all.last().unwrap();
    // u(y) of 2·10⁵ normal draws: relative standard error 1/√(2M) = 0.16 %; allow 4 of them.
    assert!((mc.std_uncertainty / top.u_c - 1.0).abs() < 4.0 * (1.0 / 400_000f64).sqrt());
}

/// Sharing through different intermediate budgets (a → b, a → c, b → d, c → d) is combined from
/// the leaves too: y_a = 2·y_b + 3·y_c with y_b = d + e, y_c = d + f gives
/// u_a² = (5 u_d)² + (2 u_e)² + (3 u_f)².
#[test]
fn shared_budget_through_two_paths_is_one_quantity() {
    let text = r#"
[[budget]]
name = "d"
[[budget.contribution]]
name = "x"
u = 0.3
[[budget]]
name = "b"
[[budget.contribution]]
name = "d"
from = "d"
[[budget.contribution]]
name = "e"
u = 0.2
[[budget]]
name = "c"
[[budget.contribution]]
name = "d"
from = "d"
[[budget.contribution]]
name = "f"
u = 0.1
[[budget]]
name = "a"
[[budget.contribution]]
name = "b"
from = "b"
sensitivity = 2
[[budget.contribution]]
name = "c"
from = "c"
sensitivity = 3
"#;
    let set = parse_budget_file(text).unwrap();
    let r = set.evaluate(None, None).unwrap();
    let expect = ((5.0f64 * 0.3).powi(2) + 0.4f64.powi(2) + 0.3f64.powi(2)).sqrt();
    assert!((r.u_c - expect).abs() < 1e-15, "{} vs {expect}", r.u_c);
    let m = set.linear_model(None).unwrap();
    assert_eq!(m.coefficients, [5.0, 2.0, 3.0]);
}

/// A cycle deep inside a large graph is a located error naming the cycle (shortened).
#[test]
fn cycle_in_a_long_chain_is_located() {
    let mut text = diamond(40);
    text += "[[budget.contribution]]\nname = \"back\"\nfrom = \"b40\"\n";
    let e = parse_budget_file(&text).unwrap_err();
    assert!(
        e.message
            .starts_with("budgets refer to themselves in a cycle: b40 -> b40"),
        "{e}"
    );
    let last_line = text.lines().count();
    assert_eq!((e.line, e.column), (last_line, 8), "{e}");
    // A long cycle is shown with its first budgets and a count.
    let mut text = String::new();
    for k in 0..50 {
        text += &format!(
            "[[budget]]\nname = \"n{k}\"\n[[budget.contribution]]\nname = \"r\"\nfrom = \"n{}\"\n",
            (k + 1) % 50
        );
    }
    let e = parse_budget_file(&text).unwrap_err();
    assert_eq!(
        e.message,
        "budgets refer to themselves in a cycle: n0 -> n1 -> n2 -> n3 -> n4 -> n5 -> … (44 more) -> n0"
    );
    assert_eq!((e.line, e.column), (5, 8));
}

/// 1,000 rows with 999 neighbour correlations (the probe that took > 120 s): u_c² = Σu² +
/// 2Σ r u u exactly, and a chain with r beyond 1/(2 cos(π/1001)) ≈ 0.5 is not a correlation
/// matrix, located at the first correlation.
#[test]
fn thousand_row_correlation_chain() {
    let f = BudgetFile::parse(&chain(1000, 0.3)).unwrap();
    let r = f.set.evaluate(None, None).unwrap();
    let expect = (1000.0 * 0.01 + 2.0 * 999.0 * 0.3 * 0.01f64).sqrt();
    assert!(
        (r.u_c - expect).abs() < 1e-12 * expect,
        "{} vs {expect}",
        r.u_c
    );
    assert_eq!(r.correlations.len(), 999);
    let m = f.set.linear_model(None).unwrap();
    assert_eq!(m.correlations.len(), 999);
    let text = chain(1000, 0.6);
    let e = parse_budget_file(&text).unwrap_err();
    assert!(e.message.contains("not a valid correlation matrix"), "{e}");
    assert_eq!(e.line, 3 * 1000 + 3, "{e}");
}

/// A correlation envelope beyond the limit is refused before the matrix is allocated: 2,100 rows
/// each correlated with the first one need Σ i ≈ 2.2 million entries.
#[test]
fn correlation_envelope_limit() {
    let n = 2100;
    let mut s = rows("wide", n);
    for i in 1..n {
        s += &format!("[[budget.correlation]]\nbetween = [\"r0\", \"r{i}\"]\nr = 0.001\n");
    }
    let e = parse_budget_file(&s).unwrap_err();
    assert!(
        e.message.contains(&format!(
            "is more than the limit of {MAX_CORRELATION_ENVELOPE}"
        )),
        "{e}"
    );
    assert_eq!(e.line, 3 * n + 3);
}

#[test]
fn budget_count_limit() {
    let mut s = String::new();
    for k in 0..=MAX_BUDGETS {
        s +=
            &format!("[[budget]]\nname = \"b{k}\"\n[[budget.contribution]]\nname = \"r\"\nu = 1\n");
    }
    let e = parse_budget_file(&s).unwrap_err();
    assert_eq!(
        e.message,
        format!(
            "{} budgets, more than the limit of {MAX_BUDGETS}",
            MAX_BUDGETS + 1
        )
    );
    assert_eq!(e.line, 5 * MAX_BUDGETS + 1);
}

/// Names of any length are kept whole in the results and cut in messages.
#[test]
fn long_names_stay_whole_in_results_and_short_in_messages() {
    let long = "n".repeat(65_536);
    let text = format!(
        "[[budget]]\nname = \"b\"\n[[budget.contribution]]\nname = \"{long}\"\nu = 1\n\
         [[budget.contribution]]\nname = \"{long}\"\nu = 2\n"
    );
    let e = parse_budget_file(&text).unwrap_err();
    assert!(
        e.message.chars().count() <= MAX_MESSAGE_CHARS,
        "{}",
        e.message.len()
    );
    assert!(
        e.message.starts_with("duplicate contribution name 'nnnn"),
        "{e}"
    );
    assert!(e.message.contains("… (65536 characters)"), "{e}");
    let ok =
        format!("[[budget]]\nname = \"b\"\n[[budget.contribution]]\nname = \"{long}\"\nu = 1\n");
    let r = parse_budget_file(&ok)
        .unwrap()
        .evaluate(None, None)
        .unwrap();
    assert_eq!(r.contributions[0].name, long);
    // A megabyte-long value echoed by the TOML layer is cut too.
    let huge = format!(
        "[[budget]]\nname = \"b\"\n[[budget.contribution]]\nname = \"r\"\nu = \"{}\"\n",
        "y".repeat(1 << 20)
    );
    let e = parse_budget_file(&huge).unwrap_err();
    assert!(e.message.chars().count() <= MAX_MESSAGE_CHARS);
    assert_eq!((e.line, e.column), (5, 5));
}

/// Finite in, finite out: each row is finite but U = k·u_c, |c·u|, y = Σ c·x or the Monte Carlo
/// draws overflow. Every case is a typed error naming the quantity, at its line.
#[test]
fn overflow_is_a_located_error_naming_the_quantity() {
    let row =
        |name: &str, extra: &str| format!("[[budget.contribution]]\nname = \"{name}\"\n{extra}\n");
    let head = "[[budget]]\nname = \"b\"\n";
    // U = 1.96 × 1.41e308.
    let f = BudgetFile::parse(&format!(
        "{head}{}{}",
        row("a", "u = 1e308"),
        row("c", "u = 1e308")
    ))
    .unwrap();
    let e = f.set.evaluate_all(None).unwrap_err();
    assert!(
        matches!(
            &e,
            UncertaintyError::NonFinite {
                contribution: None,
                ..
            }
        ),
        "{e:?}"
    );
    assert!(
        e.to_string()
            .starts_with("budget 'b': U = k·u_c = 1.9600 × 1.414"),
        "{e}"
    );
    assert_eq!(f.locate(&e), Some((2, 8)));
    // One row's c·u.
    let f = BudgetFile::parse(&format!(
        "{head}{}{}",
        row("ok", "u = 1"),
        row("big", "u = 1e300\nsensitivity = 1e10")
    ))
    .unwrap();
    let e = f.set.evaluate(None, None).unwrap_err();
    assert_eq!(
        e.to_string(),
        "budget 'b', contribution 'big': |c·u| = |1e10 × 1e300| is not finite: the numbers overflow the floating-point range (about 1.8e308)"
    );
    assert_eq!(f.locate(&e), Some((7, 8)));
    // The estimate y = Σ c·x, at the row where the sum leaves the range.
    let f = BudgetFile::parse(&format!(
        "{head}{}{}{}",
        row("x1", "u = 1\nvalue = 1e308"),
        row("x2", "u = 1\nvalue = 1e308"),
        row("x3", "u = 1")
    ))
    .unwrap();
    let e = f.set.evaluate(None, None).unwrap_err();
    assert!(
        matches!(&e, UncertaintyError::NonFinite { contribution: Some(c), .. } if c == "x2"),
        "{e:?}"
    );
    // u = expanded/k at the key k.
    let e = parse_budget_file(&format!(
        "{head}{}",
        row(
            "cert",
            "distribution = \"normal\"\nexpanded = 1e300\nk = 1e-10"
        )
    ))
    .unwrap_err();
    assert_eq!((e.line, e.column), (7, 5), "{e}");
    assert!(
        e.message
            .contains("u = expanded/k = 1e300/1e-10 is not finite"),
        "{e}"
    );
    // Monte Carlo: each draw finite, the sum of two not.
    let f = BudgetFile::parse(&format!(
        "{head}{}{}",
        row("a", "distribution = \"rectangular\"\nhalf_width = 1e308"),
        row("c", "distribution = \"rectangular\"\nhalf_width = 1e308")
    ))
    .unwrap();
    let e = f.set.linear_model(None).unwrap_err();
    assert!(
        matches!(&e, UncertaintyError::NonFinite { contribution: Some(c), .. } if c == "c"),
        "{e:?}"
    );
    assert_eq!(f.locate(&e), Some((8, 8)));
}

/// Instrument values are range-checked with the key named, and their combination must stay
/// finite (the largest term named).
#[test]
fn instrument_overflow_names_the_term() {
    let e = InstrumentFile::parse("[head_noise]\nu = 1e308\n[encoder_resolution]\nu = 1e308\n")
        .unwrap_err();
    assert!(e.message.contains("U = k·u_c = 1.9600 × 1.414"), "{e}");
    // The largest term (the last of equals): the head-noise section.
    assert_eq!((e.line, e.column), (1, 1), "{e}");
    let e = InstrumentFile::parse("[head_noise]\nu = 0.1\nsensitivity = inf\n").unwrap_err();
    assert_eq!((e.line, e.column), (3, 15), "{e}");
    assert!(e.message.contains("sensitivity must be finite"), "{e}");
    let e = InstrumentFile::parse("[[contribution]]\nname = \"drift\"\nu = -1\n").unwrap_err();
    assert_eq!((e.line, e.column), (3, 5), "{e}");
    assert!(e.message.contains("u must be a finite number ≥ 0"), "{e}");
}

/// A byte-order mark is skipped (line and column count from after it); invalid UTF-8 is located
/// at its byte; UTF-16 is named.
#[test]
fn encodings() {
    let text = b"\xEF\xBB\xBF# budget\n[[budget]]\nname = \"b\"\n[[budget.contribution]]\nname = \"a\"\nu = 1\n";
    let f = BudgetFile::parse_bytes(text).unwrap();
    assert_eq!(f.set.budgets[0].name, "b");
    let bad =
        b"\xEF\xBB\xBF[[budget]]\nname = \"b\"\n[[budget.contribution]]\nname = \"a\"\nu = -1\n";
    let e = BudgetFile::parse_bytes(bad).unwrap_err();
    assert_eq!((e.line, e.column), (5, 5), "{e}");
    let latin1 =
        b"[[budget]]\nname = \"b\"\n[[budget.contribution]]\nname = \"temp\xE9rature\"\nu = 1\n";
    let e = BudgetFile::parse_bytes(latin1).unwrap_err();
    assert_eq!((e.line, e.column), (4, 13));
    assert!(e.message.starts_with("invalid UTF-8 (byte 0xE9)"), "{e}");
    let e = InstrumentFile::parse_bytes(b"[head_noise]\r\nu = 0.0\xFF1\r\n").unwrap_err();
    assert_eq!((e.line, e.column), (2, 8), "{e}");
    let e = decode_text(b"\xFF\xFEc\0o\0").unwrap_err();
    assert!(e.message.starts_with("the file is UTF-16"), "{e}");
}

/// Monte Carlo on 10,000 inputs: the work limit (trials × inputs) is stated and checked before
/// drawing, the adaptive run is capped to it, and progress is reported as the trials are drawn.
#[test]
fn monte_carlo_limits_and_progress() {
    let inputs = vec![InputDistribution::Normal { mean: 0.0, sd: 1.0 }; 10_000];
    let e = monte_carlo_with_progress(
        &inputs,
        &[],
        |x: &[f64]| x[0],
        &McConfig {
            trials: McTrials::Fixed(1_000_000),
            ..McConfig::default()
        },
        |_| {},
    )
    .unwrap_err();
    assert!(matches!(e, UncertaintyError::TooLarge { .. }));
    assert!(e.to_string().contains("use at most 200000 trials"), "{e}");
    let inputs = vec![InputDistribution::Normal { mean: 0.0, sd: 1.0 }; 1000];
    let mut seen = Vec::new();
    let r = monte_carlo_with_progress(
        &inputs,
        &[],
        |x: &[f64]| x[0] + x[999],
        &McConfig {
            trials: McTrials::Fixed(20_000),
            ..McConfig::default()
        },
        |t| seen.push(t),
    )
    .unwrap();
    assert_eq!(r.trials, 20_000);
    // 1,000 inputs: chunks of 4 Mi / 1,000 = 4,194 trials, so progress comes 5 times.
    assert_eq!(seen, [4194, 8388, 12582, 16384, 20000]);
}
