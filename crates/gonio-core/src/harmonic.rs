//! The general harmonic least-squares fit: any set of orders, an optional offset, any coefficients
//! held fixed, with the covariance of the estimates.
//!
//! Model, for samples `(θ_n, y_n)`:
//!
//! ```text
//! y(θ) = c₀ + Σ_k (a_k·cos kθ + b_k·sin kθ)
//! ```
//!
//! The free coefficients are found by linear least squares (QR of the design matrix; for large
//! fits the column-scaled normal equations instead, when Gershgorin's bound proves them well
//! conditioned, cond ≤ 3); held coefficients are subtracted from `y` first. The covariance is
//! `σ²·(XᵀX)⁻¹` with σ either given or estimated from the residuals, `σ̂² = RSS/(n − p)`.
//! Written here rather than taken from a crate because the held-coefficient form (Hsieh et al.,
//! 2022, §3.1 keeps A and B fixed and refits only U) is not offered by the general solvers.
//!
//! ```
//! use gonio_core::{HarmonicFitSpec, Harmonic, Radians};
//! let truth = Harmonic { order: 2, amplitude: 1.0314, phase_rad: -2.4233 };
//! let theta: Vec<f64> = (0..24).map(|i| (i as f64 * 15.0).to_radians()).collect();
//! let y: Vec<f64> = theta.iter().map(|&t| 0.9596 + truth.eval(Radians(t))).collect();
//! let fit = HarmonicFitSpec::new(&[2]).fit(&theta, &y, None).unwrap();
//! let h = fit.harmonic(2).unwrap();
//! assert!((h.amplitude - 1.0314).abs() < 1e-12 && (h.phase_rad + 2.4233).abs() < 1e-12);
//! assert!((fit.offset() - 0.9596).abs() < 1e-12);
//! ```

use crate::{CoreError, Harmonic};
use nalgebra::{DMatrix, DVector};

/// One coefficient of the harmonic model.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum HarmonicTerm {
    /// The constant c₀.
    Offset,
    /// `a_k`, the coefficient of cos kθ.
    Cos(u32),
    /// `b_k`, the coefficient of sin kθ.
    Sin(u32),
}

impl HarmonicTerm {
    /// The term's basis function at angle `theta` (radians): 1, cos kθ or sin kθ.
    pub fn basis(self, theta: f64) -> f64 {
        match self {
            HarmonicTerm::Offset => 1.0,
            HarmonicTerm::Cos(k) => (k as f64 * theta).cos(),
            HarmonicTerm::Sin(k) => (k as f64 * theta).sin(),
        }
    }
}

/// What to fit: the orders, whether there is an offset, and which coefficients are held fixed.
#[derive(Debug, Clone, PartialEq)]
pub struct HarmonicFitSpec {
    /// Harmonic orders in the model (each contributes a cos and a sin term).
    pub orders: Vec<u32>,
    /// Whether the model has a constant term.
    pub offset: bool,
    /// Coefficients held at a given value instead of being fitted.
    pub fixed: Vec<(HarmonicTerm, f64)>,
}

impl HarmonicFitSpec {
    /// The given orders plus an offset, nothing held.
    pub fn new(orders: &[u32]) -> Self {
        HarmonicFitSpec {
            orders: orders.to_vec(),
            offset: true,
            fixed: Vec::new(),
        }
    }

    /// Without the constant term.
    pub fn without_offset(mut self) -> Self {
        self.offset = false;
        self
    }

    /// Holds one coefficient at `value`.
    pub fn hold(mut self, term: HarmonicTerm, value: f64) -> Self {
        self.fixed.retain(|(t, _)| *t != term);
        self.fixed.push((term, value));
        self
    }

    /// Holds harmonic `h` (both its coefficients) at its value.
    pub fn hold_harmonic(self, h: &Harmonic) -> Self {
        let (a, b) = h.cos_sin();
        self.hold(HarmonicTerm::Cos(h.order), a)
            .hold(HarmonicTerm::Sin(h.order), b)
    }

    /// All terms of the model in order: offset (if any), then cos, sin of each order.
    pub fn terms(&self) -> Vec<HarmonicTerm> {
        let mut t = Vec::with_capacity(1 + 2 * self.orders.len());
        if self.offset {
            t.push(HarmonicTerm::Offset);
        }
        for &k in &self.orders {
            t.push(HarmonicTerm::Cos(k));
            t.push(HarmonicTerm::Sin(k));
        }
        t
    }

    /// Fits samples `y` at angles `theta_rad`; `sigma` is the known standard deviation of one
    /// sample (else it is estimated from the residuals).
    ///
    /// # Errors
    /// [`CoreError::NotFinite`] for a NaN or infinite input, [`CoreError::TooFewPoints`] when
    /// there are fewer samples than free coefficients, [`CoreError::Singular`] when the angles do
    /// not separate the terms (e.g. order k sampled at multiples of 360°/k).
    pub fn fit(
        &self,
        theta_rad: &[f64],
        y: &[f64],
        sigma: Option<f64>,
    ) -> Result<HarmonicFit, CoreError> {
        let n = theta_rad.len().min(y.len());
        for (i, v) in theta_rad.iter().chain(y.iter()).enumerate() {
            if !v.is_finite() {
                return Err(CoreError::NotFinite {
                    index: i % n.max(1),
                    value: *v,
                });
            }
        }
        let terms = self.terms();
        let fixed_value = |t: HarmonicTerm| self.fixed.iter().find(|(f, _)| *f == t).map(|p| p.1);
        let free: Vec<usize> = (0..terms.len())
            .filter(|&i| fixed_value(terms[i]).is_none())
            .collect();
        let p = free.len();
        if n < p {
            return Err(CoreError::TooFewPoints {
                expected: p,
                found: n,
            });
        }
        let mut x = DMatrix::<f64>::zeros(n, p);
        let mut r = DVector::<f64>::zeros(n);
        for s in 0..n {
            let th = theta_rad[s];
            let mut held = 0.0;
            for t in &terms {
                if let Some(v) = fixed_value(*t) {
                    held += v * t.basis(th);
                }
            }
            r[s] = y[s] - held;
            for (c, &ti) in free.iter().enumerate() {
                x[(s, c)] = terms[ti].basis(th);
            }
        }
        let (coef_free, xtx_inv) = if p == 0 {
            (DVector::zeros(0), DMatrix::zeros(0, 0))
        } else if let Some(sol) = (n * p * p >= NORMAL_EQUATIONS_WORK)
            .then(|| well_conditioned_solve(&x, &r))
            .flatten()
        {
            sol
        } else {
            qr_solve(x.clone(), &r, |i| format!("{:?}", terms[free[i]]))?
        };
        let fitted = &x * &coef_free;
        let resid: Vec<f64> = (0..n).map(|s| r[s] - fitted[s]).collect();
        let rss: f64 = resid.iter().map(|e| e * e).sum();
        let dof = n - p;
        let sigma_hat = if dof > 0 {
            (rss / dof as f64).sqrt()
        } else {
            f64::NAN
        };
        let s = sigma.unwrap_or(sigma_hat);
        let mut coefficients = vec![0.0; terms.len()];
        let mut cov = vec![vec![0.0; terms.len()]; terms.len()];
        for (i, t) in terms.iter().enumerate() {
            if let Some(v) = fixed_value(*t) {
                coefficients[i] = v;
            }
        }
        for (a, &ia) in free.iter().enumerate() {
            coefficients[ia] = coef_free[a];
            for (b, &ib) in free.iter().enumerate() {
                cov[ia][ib] = s * s * xtx_inv[(a, b)];
            }
        }
        Ok(HarmonicFit {
            terms,
            coefficients,
            covariance: cov,
            residuals: resid,
            dof,
            sigma_hat,
        })
    }
}

/// The result of a harmonic fit.
#[derive(Debug, Clone, PartialEq)]
pub struct HarmonicFit {
    /// The model's terms, in the order of `coefficients`.
    pub terms: Vec<HarmonicTerm>,
    /// Estimated (or held) value of each term.
    pub coefficients: Vec<f64>,
    /// Covariance of the coefficients (rows and columns of held terms are zero).
    pub covariance: Vec<Vec<f64>>,
    /// Residual `y − model` of every sample.
    pub residuals: Vec<f64>,
    /// Degrees of freedom `n − p` (p = free coefficients).
    pub dof: usize,
    /// `√(RSS/dof)`, NaN when dof = 0.
    pub sigma_hat: f64,
}

impl HarmonicFit {
    fn index(&self, t: HarmonicTerm) -> Option<usize> {
        self.terms.iter().position(|x| *x == t)
    }

    /// The value of one coefficient (0 if the term is not in the model).
    pub fn coefficient(&self, t: HarmonicTerm) -> f64 {
        self.index(t).map_or(0.0, |i| self.coefficients[i])
    }

    /// The standard uncertainty of one coefficient.
    pub fn uncertainty(&self, t: HarmonicTerm) -> f64 {
        self.index(t).map_or(0.0, |i| self.covariance[i][i].sqrt())
    }

    /// The constant term (0 without one).
    pub fn offset(&self) -> f64 {
        self.coefficient(HarmonicTerm::Offset)
    }

    /// Harmonic `order` in amplitude–phase form, if it is in the model.
    pub fn harmonic(&self, order: u32) -> Option<Harmonic> {
        self.index(HarmonicTerm::Cos(order))?;
        Some(Harmonic::from_cos_sin(
            order,
            self.coefficient(HarmonicTerm::Cos(order)),
            self.coefficient(HarmonicTerm::Sin(order)),
        ))
    }

    /// Standard uncertainties `(u(A), u(φ) in rad)` of harmonic `order`, by linear propagation.
    pub fn harmonic_uncertainty(&self, order: u32) -> Option<(f64, f64)> {
        let ia = self.index(HarmonicTerm::Cos(order))?;
        let ib = self.index(HarmonicTerm::Sin(order))?;
        let (a, b) = (self.coefficients[ia], self.coefficients[ib]);
        let amp = a.hypot(b);
        if amp == 0.0 {
            return Some((f64::NAN, f64::NAN));
        }
        let c = &self.covariance;
        // A = √(a²+b²): dA = (a da + b db)/A ; φ = atan2(a, b): dφ = (b da − a db)/A².
        let ja = [a / amp, b / amp];
        let jp = [b / (amp * amp), -a / (amp * amp)];
        let q = |j: [f64; 2]| {
            j[0] * j[0] * c[ia][ia] + 2.0 * j[0] * j[1] * c[ia][ib] + j[1] * j[1] * c[ib][ib]
        };
        Some((q(ja).sqrt(), q(jp).sqrt()))
    }

    /// The fitted model at angle θ (radians).
    pub fn eval(&self, theta_rad: f64) -> f64 {
        self.terms
            .iter()
            .zip(&self.coefficients)
            .map(|(t, c)| c * t.basis(theta_rad))
            .sum()
    }

    /// Root-mean-square of the residuals.
    pub fn rms(&self) -> f64 {
        if self.residuals.is_empty() {
            return 0.0;
        }
        (self.residuals.iter().map(|e| e * e).sum::<f64>() / self.residuals.len() as f64).sqrt()
    }
}

/// Size n·p² of the fit from which the normal equations are tried first (below it, QR always:
/// about 0.1 s of unblocked Householder work).
const NORMAL_EQUATIONS_WORK: usize = 50_000_000;

/// Least squares by Householder QR of X (n × p): the coefficients and (XᵀX)⁻¹ = R⁻¹R⁻ᵀ.
fn qr_solve(
    x: DMatrix<f64>,
    r: &DVector<f64>,
    name: impl Fn(usize) -> String,
) -> Result<(DVector<f64>, DMatrix<f64>), CoreError> {
    let p = x.ncols();
    let qr = x.qr();
    let rm = qr.r();
    let scale = (0..p).map(|i| rm[(i, i)].abs()).fold(0.0, f64::max);
    for i in 0..p {
        if rm[(i, i)].abs() <= 1e-10 * scale.max(1e-300) {
            return Err(CoreError::Singular { what: name(i) });
        }
    }
    let qtb = qr.q().transpose() * r;
    let c = rm
        .solve_upper_triangular(&qtb)
        .ok_or_else(|| CoreError::Singular {
            what: "harmonic coefficients".into(),
        })?;
    let rinv = rm
        .solve_upper_triangular(&DMatrix::identity(p, p))
        .ok_or_else(|| CoreError::Singular {
            what: "harmonic coefficients".into(),
        })?;
    Ok((c, &rinv * rinv.transpose()))
}

/// Least squares by the column-scaled normal equations, used only when they are provably well
/// conditioned: with D the column norms of X and G = D⁻¹XᵀXD⁻¹ (unit diagonal), Gershgorin's
/// theorem puts every eigenvalue of G in [1 − ρ, 1 + ρ], ρ the largest off-diagonal row sum;
/// ρ ≤ 1/2 bounds cond(G) by 3, so the solve loses no more accuracy than QR. Harmonic columns on
/// (nearly) uniform angles are nearly orthogonal, which is the large case (a certificate's
/// spectrum over thousands of angles), and the Gram matrix is one blocked product instead of p
/// unblocked reflections. `None` when the bound fails (then QR decides).
fn well_conditioned_solve(
    x: &DMatrix<f64>,
    r: &DVector<f64>,
) -> Option<(DVector<f64>, DMatrix<f64>)> {
    let p = x.ncols();
    let d: Vec<f64> = x.column_iter().map(|c| c.norm()).collect();
    let dmax = d.iter().fold(0.0f64, |a, &b| a.max(b));
    let separated = dmax > 0.0 && d.iter().all(|&v| v > 1e-10 * dmax);
    if !separated {
        return None;
    }
    let mut gram = x.transpose() * x;
    for a in 0..p {
        for b in 0..p {
            gram[(a, b)] /= d[a] * d[b];
        }
    }
    let rho = (0..p)
        .map(|a| {
            (0..p)
                .filter(|&b| b != a)
                .map(|b| gram[(a, b)].abs())
                .sum::<f64>()
        })
        .fold(0.0f64, f64::max);
    let bounded = rho <= 0.5;
    if !bounded {
        return None;
    }
    let ch = gram.cholesky()?;
    let mut xtr = x.tr_mul(r);
    for a in 0..p {
        xtr[a] /= d[a];
    }
    let mut c = ch.solve(&xtr);
    let mut inv = ch.inverse();
    for a in 0..p {
        c[a] /= d[a];
        for b in 0..p {
            inv[(a, b)] /= d[a] * d[b];
        }
    }
    Some((c, inv))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Radians;

    fn grid(n: usize, shift_deg: f64) -> Vec<f64> {
        (0..n)
            .map(|i| (shift_deg + i as f64 * 360.0 / n as f64).to_radians())
            .collect()
    }

    #[test]
    fn recovers_several_orders_exactly() {
        let hs = [
            Harmonic {
                order: 1,
                amplitude: 0.7,
                phase_rad: 0.3,
            },
            Harmonic {
                order: 3,
                amplitude: 0.2,
                phase_rad: -1.0,
            },
            Harmonic {
                order: 5,
                amplitude: 0.05,
                phase_rad: 2.5,
            },
        ];
        let th = grid(36, 3.0);
        let y: Vec<f64> = th
            .iter()
            .map(|&t| -0.4 + hs.iter().map(|h| h.eval(Radians(t))).sum::<f64>())
            .collect();
        let fit = HarmonicFitSpec::new(&[1, 3, 5]).fit(&th, &y, None).unwrap();
        for h in hs {
            let g = fit.harmonic(h.order).unwrap();
            assert!((g.amplitude - h.amplitude).abs() < 1e-12);
            assert!((g.phase_rad - h.phase_rad).abs() < 1e-10);
        }
        assert!((fit.offset() + 0.4).abs() < 1e-12);
        assert!(fit.rms() < 1e-12);
    }

    #[test]
    fn held_coefficients_refit_only_the_offset() {
        // Hsieh et al., 2022, §3.1: keep A and B from S = 0, refit U at S = 5°.
        let h = Harmonic {
            order: 2,
            amplitude: 1.0314,
            phase_rad: -2.4233,
        };
        let th = grid(24, 5.0);
        let y: Vec<f64> = th.iter().map(|&t| -1.5927 + h.eval(Radians(t))).collect();
        let fit = HarmonicFitSpec::new(&[2])
            .hold_harmonic(&h)
            .fit(&th, &y, None)
            .unwrap();
        assert!((fit.offset() + 1.5927).abs() < 1e-12);
        assert_eq!(fit.dof, 23);
        assert_eq!(fit.uncertainty(HarmonicTerm::Cos(2)), 0.0);
    }

    #[test]
    fn covariance_with_known_sigma_is_two_over_n() {
        // On an equally spaced grid, var(a_k) = var(b_k) = 2σ²/n and var(c₀) = σ²/n.
        let th = grid(24, 0.0);
        let y = vec![0.0; 24];
        let fit = HarmonicFitSpec::new(&[1, 2])
            .fit(&th, &y, Some(0.5))
            .unwrap();
        assert!((fit.uncertainty(HarmonicTerm::Offset) - 0.5 / 24f64.sqrt()).abs() < 1e-12);
        assert!(
            (fit.uncertainty(HarmonicTerm::Sin(2)) - 0.5 * (2.0 / 24.0f64).sqrt()).abs() < 1e-12
        );
    }

    #[test]
    fn aliased_order_is_singular() {
        // Order 24 sampled at 24 points is a constant: it cannot be separated from the offset.
        let th = grid(24, 0.0);
        let y = vec![1.0; 24];
        assert!(matches!(
            HarmonicFitSpec::new(&[24]).fit(&th, &y, None),
            Err(CoreError::Singular { .. })
        ));
    }

    #[test]
    fn too_few_points_and_nan_are_errors() {
        let th = grid(2, 0.0);
        assert!(matches!(
            HarmonicFitSpec::new(&[1, 2]).fit(&th, &[0.0, 1.0], None),
            Err(CoreError::TooFewPoints {
                expected: 5,
                found: 2
            })
        ));
        assert!(matches!(
            HarmonicFitSpec::new(&[1]).fit(&grid(4, 0.0), &[0.0, f64::NAN, 0.0, 0.0], None),
            Err(CoreError::NotFinite { .. })
        ));
    }
}
