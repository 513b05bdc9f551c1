//! A GUM budget as a table: text (the terminal), Markdown or CSV, each budget's rows with their
//! shares and a summary line (u_c, ν_eff, k, U, p), and the Monte Carlo run's summary (JCGM
//! 101) beside the GUM result. Names longer than [`NAME_WIDTH`](super::NAME_WIDTH) are cut in the text and
//! Markdown tables (the CSV keeps every name whole).
//!
//! ```
//! use gonio_io::results::budget::{Request, evaluate};
//! let toml = b"[[budget]]\nname = \"y\"\n[[budget.contribution]]\nname = \"a\"\nu = 0.1\n";
//! let e = evaluate(toml, "b.toml", &Request::default(), |_| {}).unwrap();
//! let mut t = String::new();
//! gonio_io::table::budget::csv(&mut t, e.result());
//! assert!(t.starts_with("budget,name,u,c,cu,nu,share\ny,a,0.1,1,0.1,inf,1\n"), "{t}");
//! ```

use super::{display_name, dof_text, sig};
use crate::results::budget::McJson;
use gonio_uncertainty::BudgetResult;
use std::fmt::Write as _;

/// The budget's unit with a leading space (empty without one).
pub fn unit(r: &BudgetResult) -> String {
    r.unit.as_deref().map_or(String::new(), |u| format!(" {u}"))
}

/// u_c, ν_eff, k, U and p on one line.
pub fn summary_line(r: &BudgetResult) -> String {
    format!(
        "u_c = {}{u}   nu_eff = {} (raw {:.2})   k = {:.3}   U = {}{u}   (p = {} %)",
        sig(r.u_c, 4),
        dof_text(r.nu_eff),
        r.nu_eff_raw,
        r.k,
        sig(r.expanded, 4),
        gonio_core::bound::Num(r.coverage * 100.0),
        u = unit(r),
    )
}

/// The budget as a text table (rows with shares, then the summary line); names longer than
/// [`NAME_WIDTH`](super::NAME_WIDTH) are cut.
pub fn text(out: &mut String, r: &BudgetResult) {
    let names: Vec<String> = r
        .contributions
        .iter()
        .map(|c| display_name(&c.name))
        .collect();
    let w = names
        .iter()
        .map(|n| n.chars().count())
        .max()
        .unwrap_or(12)
        .max(12);
    let _ = writeln!(
        out,
        "Budget \"{}\"{}",
        display_name(&r.name),
        unit(r).replace(' ', " in ")
    );
    let _ = writeln!(
        out,
        "  {:<w$}  {:>11}  {:>10}  {:>11}  {:>6}  {:>7}",
        "contribution", "u", "c", "|c·u|", "ν", "share"
    );
    for (c, name) in r.contributions.iter().zip(&names) {
        let _ = writeln!(
            out,
            "  {:<w$}  {:>11}  {:>10}  {:>11}  {:>6}  {:>6.1}%",
            name,
            sig(c.u, 4),
            sig(c.c, 4),
            sig(c.cu, 4),
            dof_text(c.nu),
            c.share * 100.0
        );
    }
    for (a, b, rho) in &r.correlations {
        let _ = writeln!(
            out,
            "  correlation r({}, {}) = {rho}",
            display_name(a),
            display_name(b)
        );
    }
    let _ = writeln!(out, "  {}\n", summary_line(r));
}

/// The budget as a Markdown table (rows with shares, then the summary line).
pub fn markdown(out: &mut String, r: &BudgetResult) {
    let _ = writeln!(
        out,
        "### {}{}\n",
        display_name(&r.name),
        unit(r).replace(' ', " in ")
    );
    let _ = writeln!(out, "| contribution | u | c | \\|c·u\\| | ν | share |");
    let _ = writeln!(out, "|---|---:|---:|---:|---:|---:|");
    for c in &r.contributions {
        let _ = writeln!(
            out,
            "| {} | {} | {} | {} | {} | {:.1} % |",
            display_name(&c.name).replace('|', "\\|"),
            sig(c.u, 4),
            sig(c.c, 4),
            sig(c.cu, 4),
            dof_text(c.nu),
            c.share * 100.0
        );
    }
    let _ = writeln!(out, "\n{}\n", summary_line(r));
}

/// A CSV field, quoted when it needs to be.
fn csv_field(s: &str) -> String {
    if s.contains([',', '"', '\n']) {
        format!("\"{}\"", s.replace('"', "\"\""))
    } else {
        s.to_string()
    }
}

/// The budget as CSV rows (`budget,name,u,c,cu,nu,share`, the header once, before the first
/// budget written into `out`), then its summary as a `#` line.
pub fn csv(out: &mut String, r: &BudgetResult) {
    if out.is_empty() {
        out.push_str("budget,name,u,c,cu,nu,share\n");
    }
    for c in &r.contributions {
        let _ = writeln!(
            out,
            "{},{},{},{},{},{},{}",
            csv_field(&r.name),
            csv_field(&c.name),
            c.u,
            c.c,
            c.cu,
            dof_text(c.nu),
            c.share
        );
    }
    let _ = writeln!(
        out,
        "# {}: u_c={} nu_eff={} nu_eff_raw={} coverage={} k={} U={}",
        r.name,
        r.u_c,
        dof_text(r.nu_eff),
        r.nu_eff_raw,
        r.coverage,
        r.k,
        r.expanded
    );
}

/// The Monte Carlo summary (`#` lines beside a CSV table: `csv`); `capped`: the adaptive run's
/// trial limit when the model's size lowered it below the default 10⁷.
pub fn monte_carlo(
    out: &mut String,
    m: &McJson,
    capped: Option<usize>,
    gum: &BudgetResult,
    csv: bool,
) {
    let r = &m.result;
    let v = &m.validation;
    let p = if csv { "# " } else { "" };
    let u = unit(gum);
    let _ = writeln!(
        out,
        "{p}Monte Carlo (JCGM 101): {} trials in {} batches ({}), seed {}, tolerance δ = {}{u}",
        r.trials,
        r.batches,
        if r.batches > 1 || r.converged {
            if r.converged {
                "adaptive, converged".to_string()
            } else {
                match capped {
                    Some(limit) => format!(
                        "adaptive, NOT converged at the trial limit of {limit} (for this many inputs)"
                    ),
                    None => "adaptive, NOT converged at the trial limit".to_string(),
                }
            }
        } else {
            "fixed".to_string()
        },
        r.seed,
        sig(r.tolerance, 1),
    );
    let _ = writeln!(
        out,
        "{p}  y = {}{u}   u(y) = {}{u}   {} % interval: symmetric [{}, {}]   shortest [{}, {}]",
        sig(r.estimate, 4),
        sig(r.std_uncertainty, 4),
        r.coverage * 100.0,
        sig(r.symmetric.low, 4),
        sig(r.symmetric.high, 4),
        sig(r.shortest.low, 4),
        sig(r.shortest.high, 4),
    );
    let _ = writeln!(
        out,
        "{p}  GUM [{}, {}]: d_low = {}, d_high = {} {} δ = {} → {}; reported: {}",
        sig(v.gum.low, 4),
        sig(v.gum.high, 4),
        sig(v.d_low, 2),
        sig(v.d_high, 2),
        if v.passed { "≤" } else { "vs" },
        sig(v.tolerance, 1),
        if v.passed {
            "GUM validated"
        } else {
            "GUM not validated"
        },
        m.reported
    );
}
