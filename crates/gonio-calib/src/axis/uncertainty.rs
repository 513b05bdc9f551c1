//! The uncertainty beside the parameters (gonio goes beyond ISO 230-2 here): the reference's
//! GUM budget of one deviation (the instrument's terms and the polygon's calibration at the
//! target's face, through `gonio-uncertainty`), and a first-order propagation of it and of the
//! measured scatter into every parameter.
//!
//! For each parameter the approaches that decide it (the targets of a max and a min) are held
//! fixed and its uncertainty is propagated from
//! - the reference's u at those targets, taken as independent between two targets and
//!   cancelling within one target (B_i and R_i compare approaches read on the same face);
//! - the scatter of a mean, s²/n, and of a standard deviation, s²/(2(n − 1)) (normal
//!   approaches).
//!
//! The expanded uncertainties are U = 2u (k = 2, as ISO 230-2 states its expanded
//! uncertainties). Arcseconds.

use super::data::Direction;
use super::error::AxisError;
use super::parameters::{Cell, Evaluation, Parameters, TargetStats};
use super::polygon::Polygon;
use crate::certificate::Instrument;
use gonio_uncertainty::{Budget, BudgetResult, Contribution};

/// The coverage factor of the parameters' expanded uncertainties.
pub const PARAMETER_K: f64 = 2.0;

/// The reference's uncertainty of one deviation, at every target.
#[derive(Debug, Clone, PartialEq)]
pub struct ReferenceBudget {
    /// Per target (the evaluation's order), the reference's standard uncertainty u, arcsec.
    pub u_arcsec: Vec<f64>,
    /// The budget of the target with the largest u (rows with their shares).
    pub budget: BudgetResult,
    /// That target, degrees.
    pub target_deg: f64,
}

/// The reference's budget at every target: the instrument's terms and, with a polygon, its
/// face's term (`faces`: each target's face, in the evaluation's order). `None` when there is
/// no term at all.
///
/// # Errors
/// [`AxisError::Uncertainty`]: a term the budget refuses.
pub fn reference_budget(
    eval: &Evaluation,
    faces: &[Option<usize>],
    instrument: &Instrument,
    polygon: Option<&Polygon>,
) -> Result<Option<ReferenceBudget>, AxisError> {
    let has_polygon = polygon.is_some() && faces.iter().any(Option::is_some);
    if instrument.terms.contributions.is_empty() && !has_polygon {
        return Ok(None);
    }
    let budget_at = |t: &TargetStats, face: Option<usize>| {
        let mut b = Budget::new(&format!("deviation at {}°", t.target_deg));
        b.unit = Some("arcsec".into());
        b.contributions
            .extend(instrument.terms.contributions.iter().cloned());
        if let (Some(p), Some(f)) = (polygon, face) {
            b.push(
                Contribution::direct(
                    &format!("polygon calibration, face {f} ({})", p.source),
                    p.term(f).1,
                )
                .with_dof(p.dof),
            );
        }
        b.evaluate(instrument.terms.coverage)
            .map_err(|e| AxisError::Uncertainty {
                reason: e.to_string(),
            })
    };
    let mut u_arcsec = Vec::with_capacity(eval.targets.len());
    let mut worst: Option<(usize, BudgetResult)> = None;
    for (i, t) in eval.targets.iter().enumerate() {
        let r = budget_at(t, faces.get(i).copied().flatten())?;
        u_arcsec.push(r.u_c);
        if worst.as_ref().is_none_or(|(_, w)| r.u_c > w.u_c) {
            worst = Some((i, r));
        }
    }
    let (i, budget) = worst.expect("at least two targets");
    Ok(Some(ReferenceBudget {
        u_arcsec,
        budget,
        target_deg: eval.targets[i].target_deg,
    }))
}

/// One approach set: its target's index and direction.
type At = (usize, Direction);

/// The expanded uncertainties U (k = [`PARAMETER_K`]) of the parameters, arcsec, in a
/// [`Parameters`] (`None` where the parameter is); `u_ref` the reference's u per target (none:
/// the scatter alone).
pub fn parameter_uncertainty(eval: &Evaluation, u_ref: Option<&[f64]>) -> Parameters {
    let n = eval.n() as f64;
    let cell = |(i, d): At| eval.targets[i].cell(d).expect("a direction the test has");
    // Variance of a mean and of a standard deviation.
    let vm = |c: &Cell| c.s_arcsec.powi(2) / n;
    let vs = |c: &Cell| c.s_arcsec.powi(2) / (2.0 * (n - 1.0));
    let reference = |i: usize, j: usize| match u_ref {
        Some(u) if i != j => u[i].powi(2) + u[j].powi(2),
        _ => 0.0,
    };
    let cells = |dirs: &[Direction]| -> Vec<At> {
        (0..eval.targets.len())
            .flat_map(|i| dirs.iter().map(move |&d| (i, d)))
            .filter(|&(i, d)| eval.targets[i].cell(d).is_some())
            .collect()
    };
    let pick = |set: &[At], f: &dyn Fn(&Cell) -> f64, largest: bool| -> Option<At> {
        set.iter().copied().reduce(|a, b| {
            let (fa, fb) = (f(cell(a)), f(cell(b)));
            if (largest && fb > fa) || (!largest && fb < fa) {
                b
            } else {
                a
            }
        })
    };
    let expanded = |var: f64| PARAMETER_K * var.sqrt();
    // E over a set of approach sets: the difference of two means.
    let e_of = |set: &[At]| -> Option<f64> {
        let hi = pick(set, &|c| c.mean_arcsec, true)?;
        let lo = pick(set, &|c| c.mean_arcsec, false)?;
        let scatter = if hi == lo {
            0.0
        } else {
            vm(cell(hi)) + vm(cell(lo))
        };
        Some(expanded(reference(hi.0, lo.0) + scatter))
    };
    // A: (x̄ + 2s) at one set less (x̄ − 2s) at another, or 4s of one.
    let a_of = |set: &[At]| -> Option<f64> {
        let hi = pick(set, &Cell::upper_arcsec, true)?;
        let lo = pick(set, &Cell::lower_arcsec, false)?;
        let var = if hi == lo {
            16.0 * vs(cell(hi))
        } else {
            reference(hi.0, lo.0)
                + vm(cell(hi))
                + 4.0 * vs(cell(hi))
                + vm(cell(lo))
                + 4.0 * vs(cell(lo))
        };
        Some(expanded(var))
    };
    let r_of = |set: &[At]| -> Option<f64> {
        let hi = pick(set, &Cell::repeatability_arcsec, true)?;
        Some(expanded(16.0 * vs(cell(hi))))
    };
    let (up, down) = (cells(&[Direction::Up]), cells(&[Direction::Down]));
    let mut p = Parameters {
        a_up: a_of(&up),
        a_down: a_of(&down),
        e_up: e_of(&up),
        e_down: e_of(&down),
        r_up: r_of(&up),
        r_down: r_of(&down),
        ..Parameters::default()
    };
    if eval.directions().len() < 2 {
        return p;
    }
    let both = cells(&Direction::BOTH);
    p.a = a_of(&both);
    p.e = e_of(&both);
    // Per target: the variance of x̄_i and of B_i.
    fn pair<'a>(t: &'a TargetStats, vm: &dyn Fn(&Cell) -> f64) -> (f64, &'a Cell, &'a Cell) {
        let (u, d) = (t.up.as_ref().expect("both"), t.down.as_ref().expect("both"));
        (vm(u) + vm(d), u, d)
    }
    let pair = |t| pair(t, &vm);
    let m = eval.targets.len();
    let argmax = |f: &dyn Fn(&TargetStats) -> f64| {
        (0..m).reduce(|a, b| {
            if f(&eval.targets[b]) > f(&eval.targets[a]) {
                b
            } else {
                a
            }
        })
    };
    let argmin = |f: &dyn Fn(&TargetStats) -> f64| {
        (0..m).reduce(|a, b| {
            if f(&eval.targets[b]) < f(&eval.targets[a]) {
                b
            } else {
                a
            }
        })
    };
    let mean = |t: &TargetStats| t.mean_arcsec().expect("both");
    if let (Some(i), Some(j)) = (argmax(&mean), argmin(&mean)) {
        let scatter = if i == j {
            0.0
        } else {
            (pair(&eval.targets[i]).0 + pair(&eval.targets[j]).0) / 4.0
        };
        p.m = Some(expanded(reference(i, j) + scatter));
    }
    let reversal = |t: &TargetStats| t.reversal_arcsec().expect("both").abs();
    if let Some(i) = argmax(&reversal) {
        p.b = Some(expanded(pair(&eval.targets[i]).0));
    }
    let sum: f64 = eval.targets.iter().map(|t| pair(t).0).sum();
    p.b_mean = Some(expanded(sum / (m * m) as f64));
    let r_i = |t: &TargetStats| t.repeatability_arcsec().expect("both");
    if let Some(i) = argmax(&r_i) {
        let t = &eval.targets[i];
        let (vb, u, d) = pair(t);
        let combined =
            2.0 * u.s_arcsec + 2.0 * d.s_arcsec + t.reversal_arcsec().expect("both").abs();
        let var = if combined >= u.repeatability_arcsec() && combined >= d.repeatability_arcsec() {
            4.0 * vs(u) + 4.0 * vs(d) + vb
        } else if u.repeatability_arcsec() >= d.repeatability_arcsec() {
            16.0 * vs(u)
        } else {
            16.0 * vs(d)
        };
        p.r = Some(expanded(var));
    }
    p
}
