//! The result of a shift-angle calibration.

use super::{Method, ReadingSet};
use nalgebra::DMatrix;
use serde::{Deserialize, Serialize};

/// The encoder errors found at one shift angle.
#[derive(Debug, Clone, PartialEq)]
pub struct ShiftResult {
    /// Shift angle S, degrees.
    pub shift_deg: f64,
    /// Table angle of each step, degrees in [0, 360).
    pub angles_deg: Vec<f64>,
    /// α at each step, arcsec, closed (zero mean over the shift's N angles).
    pub alpha_arcsec: Vec<f64>,
    /// Standard uncertainty of each α, arcsec.
    pub u_alpha_arcsec: Vec<f64>,
}

/// The setup error of one run (shift, start face).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct SetupError {
    /// Shift angle S, degrees.
    pub shift_deg: f64,
    /// Start face j (1-based).
    pub start_face: usize,
    /// U, arcsec (including the run's share of α's mean, which the closure moves into U).
    pub value_arcsec: f64,
    /// Standard uncertainty, arcsec.
    pub u_arcsec: f64,
}

/// The χ² check of the residuals against a stated σ.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Chi2Check {
    /// The stated standard deviation of one reading, arcsec.
    pub sigma_arcsec: f64,
    /// χ² = RSS/σ².
    pub chi2: f64,
    /// Degrees of freedom.
    pub dof: usize,
    /// P(χ²_dof ≥ chi2).
    pub p_upper: f64,
    /// Whether χ² lies inside the central 95 % of its distribution.
    pub consistent: bool,
}

/// Residual statistics of the fit.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Residuals {
    /// Readings compared with the model.
    pub count: usize,
    /// Root-mean-square residual, arcsec.
    pub rms_arcsec: f64,
    /// Largest absolute residual, arcsec.
    pub max_abs_arcsec: f64,
    /// Residual degrees of freedom (readings − free unknowns).
    pub dof: usize,
    /// σ̂ = √(RSS/dof), arcsec (NaN when dof = 0).
    pub sigma_hat_arcsec: f64,
    /// χ² check, when a σ was stated.
    pub chi2: Option<Chi2Check>,
}

/// Full covariance matrices (least squares with [`super::CovarianceLevel::Full`]).
#[derive(Debug, Clone, PartialEq)]
pub struct FullCovariance {
    /// Covariance of α over all shifts, arcsec²; index `s·N + (i−1)` for shift index s, step i.
    pub alpha: DMatrix<f64>,
    /// Covariance of β, arcsec²; index `k−1`.
    pub beta: DMatrix<f64>,
}

/// A shift-angle calibration: encoder errors, pitch deviations, setup errors, with uncertainties.
#[derive(Debug, Clone, PartialEq)]
pub struct Calibration {
    /// The estimator used.
    pub method: Method,
    /// Number of polygon faces N.
    pub faces: usize,
    /// Per shift, ascending.
    pub shifts: Vec<ShiftResult>,
    /// Pitch deviation β_k of face k (index k−1), arcsec; Σβ = 0.
    pub beta_arcsec: Vec<f64>,
    /// Standard uncertainty of each β, arcsec.
    pub u_beta_arcsec: Vec<f64>,
    /// Setup error of every run that was estimated.
    pub setup: Vec<SetupError>,
    /// Residual statistics.
    pub residuals: Residuals,
    /// The σ of one reading that scales the uncertainties (stated, or σ̂ of the least-squares fit).
    pub sigma_used_arcsec: f64,
    /// Full covariance, when asked for.
    pub covariance: Option<FullCovariance>,
    /// Harmonic orders of α no polygon run can see (multiples of N), up to the merged grid's
    /// Nyquist order.
    pub undetectable_harmonics: Vec<u32>,
    /// Identical duplicate readings that were kept once.
    pub duplicates_ignored: usize,
}

/// One encoder error of the merged table.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MergedError {
    /// Table angle, degrees in [0, 360).
    pub angle_deg: f64,
    /// The shift it was measured at, degrees.
    pub shift_deg: f64,
    /// The step (1-based).
    pub step: usize,
    /// α, arcsec.
    pub value_arcsec: f64,
    /// Standard uncertainty, arcsec.
    pub u_arcsec: f64,
}

impl Calibration {
    /// The encoder errors of all shifts merged into one table sorted by angle (ties by shift).
    pub fn merged(&self) -> Vec<MergedError> {
        let mut v: Vec<MergedError> = self
            .shifts
            .iter()
            .flat_map(|s| {
                (0..s.alpha_arcsec.len()).map(move |i| MergedError {
                    angle_deg: s.angles_deg[i],
                    shift_deg: s.shift_deg,
                    step: i + 1,
                    value_arcsec: s.alpha_arcsec[i],
                    u_arcsec: s.u_alpha_arcsec[i],
                })
            })
            .collect();
        v.sort_by(|a, b| {
            a.angle_deg
                .total_cmp(&b.angle_deg)
                .then(a.shift_deg.total_cmp(&b.shift_deg))
        });
        v
    }

    /// The residual (reading − model, arcsec) of every reading whose run has an estimated setup
    /// error, in the order of the readings (identical duplicates kept once).
    pub fn reading_residuals(&self, set: &ReadingSet) -> Vec<f64> {
        let sums = PitchSums::new(&self.beta_arcsec);
        let setup: Vec<Vec<Option<f64>>> = (0..self.shifts.len())
            .map(|s| {
                (1..=self.faces)
                    .map(|j| self.setup_error(s, j).map(|u| u.value_arcsec))
                    .collect()
            })
            .collect();
        set.obs
            .iter()
            .filter_map(|o| {
                let u = setup.get(o.s)?.get(o.j).copied().flatten()?;
                let alpha = self.shifts.get(o.s)?.alpha_arcsec.get(o.i)?;
                Some(o.value - (alpha + sums.c(o.j, o.i + 1) + u))
            })
            .collect()
    }

    /// The setup error of a run, if it was estimated.
    pub fn setup_error(&self, shift_index: usize, start_face: usize) -> Option<&SetupError> {
        let s = self.shifts.get(shift_index)?.shift_deg;
        self.setup
            .iter()
            .find(|u| u.shift_deg == s && u.start_face == start_face)
    }
}

/// Harmonic orders that are multiples of `faces`, up to `max_order` (at least `faces`).
///
/// ```
/// use gonio_calib::shift_angle::undetectable_orders;
/// assert_eq!(undetectable_orders(24, 180), vec![24, 48, 72, 96, 120, 144, 168]);
/// ```
pub fn undetectable_orders(faces: usize, max_order: usize) -> Vec<u32> {
    (1..)
        .map(|m| m * faces)
        .take_while(|&k| k <= max_order.max(faces))
        .map(|k| k as u32)
        .collect()
}

/// The default maximum order listed: the merged grid's Nyquist order, at least N.
pub(crate) fn max_listed_order(set: &ReadingSet) -> usize {
    (set.shifts_deg().len() * set.faces() / 2).max(set.faces())
}

/// Residual statistics of given estimates over the readings whose run has a setup error.
pub(crate) fn residual_stats(
    set: &ReadingSet,
    alpha: &[Vec<f64>],
    beta: &[f64],
    setup: &[Vec<Option<f64>>],
    free_unknowns: usize,
    sigma: Option<f64>,
) -> Residuals {
    let sums = PitchSums::new(beta);
    let mut rss = 0.0;
    let mut max_abs: f64 = 0.0;
    let mut count = 0usize;
    for o in &set.obs {
        let Some(u) = setup[o.s][o.j] else { continue };
        let pred = alpha[o.s][o.i] + sums.c(o.j, o.i + 1) + u;
        let r = o.value - pred;
        rss += r * r;
        max_abs = max_abs.max(r.abs());
        count += 1;
    }
    let dof = count.saturating_sub(free_unknowns);
    let sigma_hat = if dof > 0 {
        (rss / dof as f64).sqrt()
    } else {
        f64::NAN
    };
    let chi2 = sigma.filter(|_| dof > 0).map(|s| {
        let chi2 = rss / (s * s);
        let p_upper = gonio_core::special::chi2_sf(chi2, dof as f64);
        Chi2Check {
            sigma_arcsec: s,
            chi2,
            dof,
            p_upper,
            consistent: (0.025..=0.975).contains(&p_upper),
        }
    });
    Residuals {
        count,
        rms_arcsec: if count > 0 {
            (rss / count as f64).sqrt()
        } else {
            0.0
        },
        max_abs_arcsec: max_abs,
        dof,
        sigma_hat_arcsec: sigma_hat,
        chi2,
    }
}

/// Prefix sums of β for O(1) evaluation of C(j, i) = β_j + … + β_(j+i−1).
pub(crate) struct PitchSums {
    cum: Vec<f64>,
}

impl PitchSums {
    pub(crate) fn new(beta: &[f64]) -> Self {
        let mut cum = Vec::with_capacity(beta.len() + 1);
        cum.push(0.0);
        let mut acc = 0.0;
        for b in beta {
            acc += b;
            cum.push(acc);
        }
        PitchSums { cum }
    }

    /// C(j, i) for 0-based start face `j0` and `count` = i terms (1..=N).
    #[inline]
    pub(crate) fn c(&self, j0: usize, count: usize) -> f64 {
        let n = self.cum.len() - 1;
        let end = j0 + count;
        if end <= n {
            self.cum[end] - self.cum[j0]
        } else {
            self.cum[n] - self.cum[j0] + self.cum[end - n]
        }
    }
}
