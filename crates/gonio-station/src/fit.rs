//! Eccentricity from one turn's ring columns `(θ, c)`: the seed's extreme-point method and the
//! default robust least-squares sinusoid.
//!
//! Over one turn the ring's column traces `c(θ) = c₀ + e·cos(θ − θ_max) + r(θ)`, `e` the
//! eccentricity (px), `θ_max` the servo angle at which the ring is farthest out and `r` the ring's
//! roundness error (harmonics 2–4, a few tenths of a pixel).
//!
//! - [`FitMethod::LeastSquares`] (default): `c = c₀ + a cos θ + b sin θ + Σ_{k=2..4}(a_k cos kθ +
//!   b_k sin kθ)`, `e = √(a² + b²)`, `θ_max = atan2(b, a)`. The roundness coefficients carry a
//!   ridge penalty `(σ/σ_r)²` (a Gaussian prior of standard deviation `σ_r` =
//!   [`FitOptions::roundness_prior_px`]) so that on a partial turn they cannot soak up the
//!   eccentricity; Huber weights (iteratively reweighted least squares, robust scale from the
//!   median absolute deviation) bound the pull of outliers, and samples beyond
//!   [`FitOptions::outlier_sigma`] robust standard deviations are reported and dropped. The model is
//!   linear, so no non-linear solver is needed.
//! - [`FitMethod::Paper`] (Yu et al., 2024, §3, Eq. 1–2): natural cubic splines through the points
//!   around the largest and the smallest `c`; their extrema give `P_max`, `P_min`;
//!   `e = (c_max − c_min)/2`, `θ_max` at `P_max`.
//!
//! Both work on partial turns and with dropped frames (only the angles of the samples matter).
//! On a turn over part of a revolution the roundness and the eccentricity are confounded; a
//! roundness carried from a full turn of the same part ([`crate::ring`], [`fit_judged_with`])
//! takes the place of the zero-centred ridge and separates them again.
//!
//! ```
//! use gonio_station::fit::{fit, FitOptions, Sample};
//! let s: Vec<Sample> = (0..200)
//!     .map(|i| {
//!         let t = 10.0 + 1.8 * i as f64;
//!         Sample { theta_deg: t, c_px: 720.0 + 40.0 * (t - 33.0f64).to_radians().cos() }
//!     })
//!     .collect();
//! let f = fit(&s, &FitOptions::default()).unwrap();
//! assert!((f.e_px - 40.0).abs() < 1e-9 && (f.theta_max_deg - 33.0).abs() < 1e-9);
//! ```

use crate::StationError;
use crate::quality::{self, HalfTurns, QualityLimits, QualityVerdict};
use crate::ring::RoundnessPrior;
pub use crate::sample::Sample;
use nalgebra::{DMatrix, DVector, Matrix3, Vector3};
use serde::{Deserialize, Serialize};

/// Which eccentricity fit.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum FitMethod {
    /// Robust least-squares sinusoid with ridge-regularised roundness harmonics (default).
    #[default]
    LeastSquares,
    /// The seed's extreme points through cubic splines.
    Paper,
}

impl FitMethod {
    /// The name used on the command line and in JSON (`least-squares`, `paper`).
    pub fn name(self) -> &'static str {
        match self {
            FitMethod::LeastSquares => "least-squares",
            FitMethod::Paper => "paper",
        }
    }
}

/// Settings of the fit.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct FitOptions {
    /// Which method.
    pub method: FitMethod,
    /// Roundness harmonic orders fitted with the ridge penalty (least squares).
    pub roundness_orders: Vec<u32>,
    /// Prior standard deviation of one roundness coefficient, px (least squares).
    pub roundness_prior_px: f64,
    /// Huber threshold in robust standard deviations (least squares).
    pub huber_k: f64,
    /// Samples with |residual| above this many robust standard deviations (and above the
    /// detector's accuracy bound) are outliers.
    pub outlier_sigma: f64,
    /// Points on each side of the extreme sample in each spline (paper).
    pub paper_half_window: usize,
}

impl Default for FitOptions {
    fn default() -> Self {
        FitOptions {
            method: FitMethod::LeastSquares,
            roundness_orders: vec![2, 3, 4],
            roundness_prior_px: 0.5,
            huber_k: 1.345,
            outlier_sigma: 5.0,
            paper_half_window: 5,
        }
    }
}

impl FitOptions {
    /// The defaults with another method.
    pub fn with_method(method: FitMethod) -> Self {
        FitOptions {
            method,
            ..Self::default()
        }
    }

    /// Checks the settings; with `samples`, also those that depend on the number of samples.
    ///
    /// # Errors
    /// [`StationError::OutOfRange`] naming the setting (`huber_k`, `roundness_prior_px`,
    /// `outlier_sigma`, `roundness_orders`, `paper_half_window`).
    pub fn validate(&self, samples: Option<usize>) -> Result<(), StationError> {
        let positive = |name: &'static str, v: f64| {
            if v.is_finite() && v > 0.0 {
                Ok(())
            } else {
                Err(StationError::OutOfRange {
                    name,
                    value: v,
                    expected: "a finite number > 0",
                })
            }
        };
        positive("roundness_prior_px", self.roundness_prior_px)?;
        positive("huber_k", self.huber_k)?;
        positive("outlier_sigma", self.outlier_sigma)?;
        for (i, &k) in self.roundness_orders.iter().enumerate() {
            if !(2..=MAX_ROUNDNESS_ORDER).contains(&k) || self.roundness_orders[..i].contains(&k) {
                return Err(StationError::OutOfRange {
                    name: "roundness_orders",
                    value: k as f64,
                    expected: "distinct orders from 2 to 50 (0 and 1 are c₀ and the eccentricity)",
                });
            }
        }
        if self.paper_half_window == 0 {
            return Err(StationError::OutOfRange {
                name: "paper_half_window",
                value: 0.0,
                expected: "at least 1 point on each side",
            });
        }
        if let Some(n) = samples
            && self.method == FitMethod::Paper
            && 2 * self.paper_half_window + 1 > n
        {
            return Err(StationError::OutOfRange {
                name: "paper_half_window",
                value: self.paper_half_window as f64,
                expected: "a window (2·half + 1 points) no larger than the samples",
            });
        }
        Ok(())
    }
}

/// Highest roundness order the fit accepts.
pub const MAX_ROUNDNESS_ORDER: u32 = 50;

/// One roundness harmonic `amplitude_px·cos(order·θ − phase)`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct RoundnessTerm {
    /// Order k.
    pub order: u32,
    /// Amplitude, px.
    pub amplitude_px: f64,
    /// Angle of the first maximum, degrees (`kθ − phase = 0`, phase in degrees).
    pub phase_deg: f64,
}

/// The result of an eccentricity fit.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct EccentricityFit {
    /// The method used.
    pub method: FitMethod,
    /// Eccentricity, px.
    pub e_px: f64,
    /// Servo angle at which the ring's column is largest, degrees in [0, 360).
    pub theta_max_deg: f64,
    /// Mean column c₀, px.
    pub c0_px: f64,
    /// Standard uncertainty of e, px (least squares; `None`, JSON `null`, for the paper's
    /// method, which defines none).
    pub u_e_px: Option<f64>,
    /// Standard uncertainty of θ_max, degrees (least squares; `None`, JSON `null`, for the
    /// paper's method and at e = 0, where the direction is undefined).
    pub u_theta_max_deg: Option<f64>,
    /// RMS of the residuals of the samples used, px (for the paper's method: against the
    /// sinusoid `c₀ + e cos(θ − θ_max)`).
    pub residual_rms_px: f64,
    /// Robust standard deviation of one sample (1.4826·MAD), px.
    pub sigma_px: f64,
    /// Samples that entered the fit.
    pub frames_used: usize,
    /// Indices of the samples rejected as outliers.
    pub outliers: Vec<usize>,
    /// Residual `c − model` of every sample, px.
    pub residuals_px: Vec<f64>,
    /// The fitted roundness harmonics (least squares; empty for the paper's method).
    pub roundness: Vec<RoundnessTerm>,
    /// Angular span of the samples, degrees.
    pub arc_deg: f64,
    /// The quality gate's verdict on the turn ([`crate::quality`]).
    pub quality: QualityVerdict,
    /// The fitted roundness with its uncertainties, the prior a later turn of the same ring
    /// may carry (least squares; `None` for the paper's method).
    #[serde(default)]
    pub ring: Option<RoundnessPrior>,
    /// The fit took its roundness prior from an earlier turn ([`fit_judged_with`]).
    #[serde(default)]
    pub carried_roundness: bool,
}

impl EccentricityFit {
    /// Eccentricity in µm for a pixel scale.
    pub fn e_um(&self, um_per_px: f64) -> f64 {
        self.e_px * um_per_px
    }

    /// The fitted model's column at servo angle θ (degrees), roundness included.
    pub fn model_px(&self, theta_deg: f64) -> f64 {
        let mut c = self.c0_px + self.e_px * (theta_deg - self.theta_max_deg).to_radians().cos();
        for r in &self.roundness {
            c += r.amplitude_px
                * (r.order as f64 * theta_deg - r.phase_deg)
                    .to_radians()
                    .cos();
        }
        c
    }
}

/// Checks the samples: at least 3, finite, angles strictly increasing.
///
/// # Errors
/// [`StationError::TooFewSamples`], [`StationError::NotFinite`], [`StationError::NotIncreasing`].
pub fn validate(samples: &[Sample]) -> Result<(), StationError> {
    if samples.len() < 3 {
        return Err(StationError::TooFewSamples {
            expected: 3,
            found: samples.len(),
        });
    }
    for (i, s) in samples.iter().enumerate() {
        if !s.theta_deg.is_finite() {
            return Err(StationError::NotFinite {
                index: i,
                what: "theta_deg",
                value: s.theta_deg,
            });
        }
        if !s.c_px.is_finite() {
            return Err(StationError::NotFinite {
                index: i,
                what: "c_px",
                value: s.c_px,
            });
        }
        if i > 0 && s.theta_deg <= samples[i - 1].theta_deg {
            return Err(StationError::NotIncreasing {
                index: i,
                previous_deg: samples[i - 1].theta_deg,
                found_deg: s.theta_deg,
            });
        }
    }
    Ok(())
}

/// Fits the eccentricity of one turn (or part of one) and judges it against the seed station's
/// quality limits ([`QualityLimits::default`]), taking every sample as a frame taken. Use
/// [`fit_judged`] for a recipe's limits and the frames the station took.
///
/// # Errors
/// Those of [`validate`]; [`StationError::Singular`] when the angles do not determine the
/// sinusoid (least squares); [`StationError::OutOfRange`] for invalid options.
pub fn fit(samples: &[Sample], opts: &FitOptions) -> Result<EccentricityFit, StationError> {
    fit_judged(samples, samples.len(), opts, &QualityLimits::default())
}

/// Fits the eccentricity of one turn and judges the turn ([`crate::quality`]): `frames_taken`
/// is the number of frames the turn had, valid or not (at least `samples.len()`).
///
/// The verdict always comes from the robust least-squares model of the samples, also when the
/// method is the seed's (which has no residual model of its own).
///
/// # Errors
/// As [`fit`]; [`StationError::OutOfRange`] when `frames_taken < samples.len()`.
pub fn fit_judged(
    samples: &[Sample],
    frames_taken: usize,
    opts: &FitOptions,
    limits: &QualityLimits,
) -> Result<EccentricityFit, StationError> {
    fit_judged_with(samples, frames_taken, opts, limits, None)
}

/// As [`fit_judged`], with the ring's roundness carried from an earlier trusted turn of the same
/// part as the prior of the roundness coefficients (orders the prior does not carry keep the
/// zero-centred ridge of [`FitOptions::roundness_prior_px`]). The gate then judges the turn's
/// coverage against the limits for a carried roundness
/// ([`QualityLimits::max_gap_carried_deg`]); every other check is unchanged.
///
/// # Errors
/// As [`fit_judged`]; [`StationError::OutOfRange`] for an inconsistent prior.
pub fn fit_judged_with(
    samples: &[Sample],
    frames_taken: usize,
    opts: &FitOptions,
    limits: &QualityLimits,
    prior: Option<&RoundnessPrior>,
) -> Result<EccentricityFit, StationError> {
    validate(samples)?;
    opts.validate(Some(samples.len()))?;
    if let Some(p) = prior {
        p.validate()?;
    }
    if frames_taken < samples.len() {
        return Err(StationError::OutOfRange {
            name: "frames_taken",
            value: frames_taken as f64,
            expected: "at least the number of samples",
        });
    }
    let ridge = Ridge::new(opts, prior);
    let least_squares = fit_least_squares(samples, opts, &ridge, limits.systematic_px);
    let (mut out, ls) = match opts.method {
        FitMethod::LeastSquares => {
            let ls = least_squares?;
            (ls.clone(), Ok(ls))
        }
        FitMethod::Paper => (fit_paper(samples, opts)?, least_squares),
    };
    out.quality = match ls {
        Ok(ls) => {
            let used: Vec<Sample> = (0..samples.len())
                .filter(|i| !ls.outliers.contains(i))
                .map(|i| samples[i])
                .collect();
            let halves = half_turns(&used, opts, &ridge, ls.sigma_px, limits.systematic_px);
            quality::judge(
                &used,
                samples.len(),
                frames_taken,
                Some(ls.residual_rms_px),
                ls.u_e_px,
                halves,
                limits,
                ridge.carried,
            )
        }
        // The data do not determine the least-squares model: nothing to trust.
        Err(_) => quality::judge(
            &[],
            samples.len(),
            frames_taken,
            None,
            None,
            None,
            limits,
            ridge.carried,
        ),
    };
    out.carried_roundness = ridge.carried;
    // The ring's roundness as the prior of a later turn: its uncertainty from a per-sample
    // scatter of at least the detector's accuracy bound (as the half-turn check's), so that a
    // turn of tiny noise does not pin the next turn to in-spec systematic errors.
    if let Some(ring) = out.ring.as_mut() {
        let scale = (limits.systematic_px / out.sigma_px.max(1e-12)).max(1.0);
        for u in &mut ring.u_px {
            *u = u.map(|v| v * scale);
        }
    }
    Ok(out)
}

/// The roundness coefficients' prior in the normal equations: per coefficient (in the fit's
/// order: a₂, b₂, a₃, …) its centre and its variance u², px². The ridge added to the normal
/// matrix is σ²/u², σ the robust scale of one sample.
struct Ridge {
    centre: Vec<f64>,
    var: Vec<f64>,
    carried: bool,
}

impl Ridge {
    fn new(opts: &FitOptions, prior: Option<&RoundnessPrior>) -> Self {
        let free = opts.roundness_prior_px * opts.roundness_prior_px;
        let mut r = Ridge {
            centre: Vec::with_capacity(2 * opts.roundness_orders.len()),
            var: Vec::with_capacity(2 * opts.roundness_orders.len()),
            carried: false,
        };
        for &k in &opts.roundness_orders {
            match prior.and_then(|p| p.term(k)) {
                Some((c, u)) => {
                    r.carried = true;
                    r.centre.extend(c);
                    r.var.extend(u.map(|u| u * u));
                }
                None => {
                    r.centre.extend([0.0, 0.0]);
                    r.var.extend([free, free]);
                }
            }
        }
        r
    }

    /// Adds the ridge for a sample scale σ to the normal equations, whose roundness
    /// coefficients start at index `first`.
    fn add(&self, a: &mut DMatrix<f64>, rhs: &mut DVector<f64>, first: usize, sigma: f64) {
        for (j, (&c, &v)) in self.centre.iter().zip(&self.var).enumerate() {
            let lambda = sigma * sigma / v;
            a[(first + j, first + j)] += lambda;
            rhs[first + j] += lambda * c;
        }
    }
}

/// The agreement of the two half-turns: one least-squares fit of the used samples with the
/// ring's roundness shared by the whole turn (it belongs to the ring) and, for the second half
/// (from the middle of the span on), its own steps (Δc₀, Δa, Δb) of the mean column and of the
/// eccentricity vector. Their Mahalanobis distance from zero uses the per-frame scatter of this
/// model's residuals (RSS/(n − p)), at least `floor_px`: the detector's accuracy bound keeps
/// in-spec systematic errors from failing a turn whose random noise is tiny. The roundness
/// ridge uses the turn's robust `sigma_px` (as the fit does). `None` when the model is not
/// determined.
fn half_turns(
    used: &[Sample],
    opts: &FitOptions,
    ridge: &Ridge,
    sigma_px: f64,
    floor_px: f64,
) -> Option<HalfTurns> {
    let (first, last) = (used.first()?.theta_deg, used.last()?.theta_deg);
    let mid = 0.5 * (first + last);
    let split = used.partition_point(|s| s.theta_deg < mid);
    if split < 3 || used.len() - split < 3 {
        return None;
    }
    let orders = &opts.roundness_orders;
    let h = 3 + 2 * orders.len();
    let p = h + 3;
    let x = DMatrix::<f64>::from_fn(used.len(), p, |i, j| {
        let t = used[i].theta_deg.to_radians();
        let step = if i >= split { 1.0 } else { 0.0 };
        let base = |j: usize| match j {
            0 => 1.0,
            1 => t.cos(),
            _ => t.sin(),
        };
        if j < 3 {
            base(j)
        } else if j < h {
            let k = orders[(j - 3) / 2] as f64;
            if (j - 3) % 2 == 0 {
                (k * t).cos()
            } else {
                (k * t).sin()
            }
        } else {
            step * base(j - h)
        }
    });
    let n = used.len();
    if n <= p {
        return None;
    }
    let y = DVector::<f64>::from_iterator(n, used.iter().map(|s| s.c_px));
    let mut a = x.transpose() * &x;
    let mut rhs = x.transpose() * &y;
    ridge.add(&mut a, &mut rhs, 3, sigma_px.max(1e-9));
    let chol = a.cholesky()?;
    let beta = chol.solve(&rhs);
    let inv = chol.inverse();
    let rss = (&y - &x * &beta).norm_squared();
    let sigma = (rss / (n - p) as f64).sqrt().max(floor_px);
    let d = Vector3::new(beta[h], beta[h + 1], beta[h + 2]);
    let c = Matrix3::from_fn(|r, k| sigma * sigma * inv[(h + r, h + k)]);
    let z2 = c.cholesky()?.solve(&d).dot(&d);
    Some(HalfTurns {
        z: z2.max(0.0).sqrt(),
        dc0_px: d[0],
        de_px: d[1].hypot(d[2]),
    })
}

fn wrap360(d: f64) -> f64 {
    let w = d.rem_euclid(360.0);
    if w >= 360.0 { 0.0 } else { w }
}

/// Median of a slice (copied).
fn median(v: &[f64]) -> f64 {
    let mut s: Vec<f64> = v.to_vec();
    s.sort_by(|a, b| a.total_cmp(b));
    let n = s.len();
    if n == 0 {
        return f64::NAN;
    }
    if n % 2 == 1 {
        s[n / 2]
    } else {
        0.5 * (s[n / 2 - 1] + s[n / 2])
    }
}

/// Robust standard deviation: 1.4826·MAD, or 1.2533 × the mean absolute deviation when more
/// than half of the residuals are equal (MAD = 0, e.g. noise-free or quantised data).
fn robust_sigma(r: &[f64]) -> f64 {
    let med = median(r);
    let dev: Vec<f64> = r.iter().map(|x| (x - med).abs()).collect();
    let mad = 1.4826 * median(&dev);
    if mad > 0.0 {
        mad
    } else {
        1.2533 * dev.iter().sum::<f64>() / dev.len().max(1) as f64
    }
}

/// The robust least-squares fit. Its verdict is left unjudged (the caller judges). A residual
/// within `floor_px` (the detector's accuracy bound) is never cut as an outlier, however small
/// the turn's scatter: on noise-free columns the angle log's interpolation error during the
/// servo's ramp (≈ 10⁻⁴ px) would otherwise be.
fn fit_least_squares(
    samples: &[Sample],
    opts: &FitOptions,
    ridge: &Ridge,
    floor_px: f64,
) -> Result<EccentricityFit, StationError> {
    let n = samples.len();
    let orders = &opts.roundness_orders;
    let p = 3 + 2 * orders.len();
    let mut x = DMatrix::<f64>::zeros(n, p);
    let y = DVector::<f64>::from_iterator(n, samples.iter().map(|s| s.c_px));
    for (i, s) in samples.iter().enumerate() {
        let t = s.theta_deg.to_radians();
        x[(i, 0)] = 1.0;
        x[(i, 1)] = t.cos();
        x[(i, 2)] = t.sin();
        for (j, &k) in orders.iter().enumerate() {
            x[(i, 3 + 2 * j)] = (k as f64 * t).cos();
            x[(i, 4 + 2 * j)] = (k as f64 * t).sin();
        }
    }
    // Weighted, ridge-penalised normal equations: (XᵀWX + Λ) β = XᵀWy + Λμ, with Λ = σ²/u² on
    // the roundness coefficients and μ their prior's centre (`None`: the light start ridge).
    let solve = |w: &[f64],
                 sigma: Option<f64>,
                 want_inverse: bool|
     -> Result<(DVector<f64>, Option<DMatrix<f64>>), StationError> {
        let mut a = DMatrix::<f64>::zeros(p, p);
        let mut rhs = DVector::<f64>::zeros(p);
        for i in 0..n {
            if w[i] == 0.0 {
                continue;
            }
            let row = x.row(i);
            for r in 0..p {
                let v = w[i] * row[r];
                rhs[r] += v * y[i];
                for c in r..p {
                    a[(r, c)] += v * row[c];
                }
            }
        }
        for r in 0..p {
            for c in 0..r {
                a[(r, c)] = a[(c, r)];
            }
        }
        match sigma {
            Some(s) => ridge.add(&mut a, &mut rhs, 3, s),
            None => {
                for j in 3..p {
                    a[(j, j)] += 1e-6 * n as f64;
                }
            }
        }
        // Check that offset and first harmonic are determined by the data themselves.
        let scale = (0..3).map(|j| a[(j, j)]).fold(0.0, f64::max);
        let core = a.view((0, 0), (3, 3)).into_owned();
        let det_ok = core
            .clone()
            .cholesky()
            .map(|c| {
                let l = c.l();
                (0..3).all(|j| l[(j, j)] * l[(j, j)] > 1e-10 * scale)
            })
            .unwrap_or(false);
        if !det_ok {
            return Err(StationError::Singular {
                what: "c₀ and the first harmonic are not determined by the angles given".into(),
            });
        }
        let chol = a.cholesky().ok_or_else(|| StationError::Singular {
            what: "normal matrix not positive definite".into(),
        })?;
        let beta = chol.solve(&rhs);
        Ok((beta, want_inverse.then(|| chol.inverse())))
    };
    let resid = |beta: &DVector<f64>| -> Vec<f64> {
        let m = &x * beta;
        (0..n).map(|i| y[i] - m[i]).collect()
    };
    // Start: unweighted, a light ridge; then IRLS with Huber weights and the prior's ridge.
    let mut w = vec![1.0; n];
    let (mut beta, _) = solve(&w, None, false)?;
    let mut sigma = robust_sigma(&resid(&beta)).max(1e-9);
    // Huber-reweighted solves until β settles, at most `iterations`. In the first pass
    // (`first`) σ is re-estimated from each step's residuals and every weight is recomputed;
    // after the hard rejection σ stays and a rejected point's zero weight stays zero.
    let irls = |w: &mut [f64],
                beta: &mut DVector<f64>,
                sigma: &mut f64,
                iterations: usize,
                first: bool|
     -> Result<(), StationError> {
        for _ in 0..iterations {
            let r = resid(beta);
            if first {
                *sigma = robust_sigma(&r).max(1e-9);
            }
            let k = opts.huber_k * *sigma;
            for i in 0..n {
                if first || w[i] > 0.0 {
                    w[i] = if r[i].abs() <= k { 1.0 } else { k / r[i].abs() };
                }
            }
            let (nb, _) = solve(w, Some(*sigma), false)?;
            let delta = (&nb - &*beta).amax();
            *beta = nb;
            if delta < 1e-10 * (1.0 + beta.amax()) {
                break;
            }
        }
        Ok(())
    };
    irls(&mut w, &mut beta, &mut sigma, 100, true)?;
    // Hard rejection of gross outliers, then a final reweighted solve.
    let r = resid(&beta);
    let cut = (opts.outlier_sigma * sigma).max(floor_px);
    let mut outliers: Vec<usize> = (0..n).filter(|&i| r[i].abs() > cut).collect();
    if 2 * outliers.len() > n {
        // A majority cannot be outliers: the model does not describe these data (the gate's
        // residual check will say so).
        outliers.clear();
    }
    if !outliers.is_empty() {
        for &i in &outliers {
            w[i] = 0.0;
        }
        irls(&mut w, &mut beta, &mut sigma, 50, false)?;
    }
    let inv = solve(&w, Some(sigma), true)?
        .1
        .expect("the inverse was asked for");
    let r = resid(&beta);
    let used: Vec<usize> = (0..n).filter(|i| !outliers.contains(i)).collect();
    let rms = (used.iter().map(|&i| r[i] * r[i]).sum::<f64>() / used.len().max(1) as f64).sqrt();
    let (a, b) = (beta[1], beta[2]);
    let e = a.hypot(b);
    let s2 = sigma * sigma;
    let (caa, cab, cbb) = (s2 * inv[(1, 1)], s2 * inv[(1, 2)], s2 * inv[(2, 2)]);
    let (u_e, u_t) = if e > 0.0 {
        let (ja, jb) = (a / e, b / e);
        let (ta, tb) = (-b / (e * e), a / (e * e));
        (
            (ja * ja * caa + 2.0 * ja * jb * cab + jb * jb * cbb).sqrt(),
            Some(
                (ta * ta * caa + 2.0 * ta * tb * cab + tb * tb * cbb)
                    .sqrt()
                    .to_degrees(),
            ),
        )
    } else {
        // At e = 0 the direction is undefined; u(e) is the mean of the two components'.
        ((0.5 * (caa + cbb)).sqrt(), None)
    };
    let roundness = orders
        .iter()
        .enumerate()
        .map(|(j, &k)| {
            let (ak, bk) = (beta[3 + 2 * j], beta[4 + 2 * j]);
            RoundnessTerm {
                order: k,
                amplitude_px: ak.hypot(bk),
                phase_deg: bk.atan2(ak).to_degrees(),
            }
        })
        .collect();
    let ring = RoundnessPrior {
        orders: orders.clone(),
        coefficients_px: (0..orders.len())
            .map(|j| [beta[3 + 2 * j], beta[4 + 2 * j]])
            .collect(),
        u_px: (0..orders.len())
            .map(|j| [3 + 2 * j, 4 + 2 * j].map(|i| (s2 * inv[(i, i)]).sqrt()))
            .collect(),
    };
    let fit = EccentricityFit {
        method: FitMethod::LeastSquares,
        e_px: e,
        theta_max_deg: wrap360(b.atan2(a).to_degrees()),
        c0_px: beta[0],
        u_e_px: Some(u_e),
        u_theta_max_deg: u_t,
        residual_rms_px: rms,
        sigma_px: sigma,
        frames_used: used.len(),
        outliers,
        residuals_px: r,
        roundness,
        arc_deg: samples[n - 1].theta_deg - samples[0].theta_deg,
        quality: QualityVerdict::default(),
        ring: Some(ring),
        carried_roundness: false,
    };
    Ok(fit)
}

/// Points around sample `i` (± `half` samples), wrapping around a full turn; angles unwrapped.
fn window(samples: &[Sample], i: usize, half: usize, full_turn: bool) -> (Vec<f64>, Vec<f64>) {
    let n = samples.len() as isize;
    let mut xs = Vec::with_capacity(2 * half + 1);
    let mut ys = Vec::with_capacity(2 * half + 1);
    let h = half as isize;
    for j in (i as isize - h)..=(i as isize + h) {
        let (idx, shift) = if j < 0 {
            if !full_turn {
                continue;
            }
            (j + n, -360.0)
        } else if j >= n {
            if !full_turn {
                continue;
            }
            (j - n, 360.0)
        } else {
            (j, 0.0)
        };
        let s = samples[idx as usize];
        let t = s.theta_deg + shift;
        if let Some(&last) = xs.last()
            && t <= last
        {
            continue;
        }
        xs.push(t);
        ys.push(s.c_px);
    }
    (xs, ys)
}

fn fit_paper(samples: &[Sample], opts: &FitOptions) -> Result<EccentricityFit, StationError> {
    let n = samples.len();
    let arc = samples[n - 1].theta_deg - samples[0].theta_deg;
    let step = arc / (n - 1) as f64;
    // A full turn when the gap closing the circle is no larger than ~1.5 typical steps.
    let full_turn = arc >= 360.0 - 1.5 * step && arc < 360.0;
    let (imax, imin) = samples.iter().enumerate().fold((0, 0), |(mx, mn), (i, s)| {
        (
            if s.c_px > samples[mx].c_px { i } else { mx },
            if s.c_px < samples[mn].c_px { i } else { mn },
        )
    });
    let half = opts.paper_half_window;
    let (xa, ya) = window(samples, imax, half, full_turn);
    let (xb, yb) = window(samples, imin, half, full_turn);
    let (t_max, c_max) = crate::spline::NaturalSpline::new(&xa, &ya)?.maximum();
    let (_, c_min) = crate::spline::NaturalSpline::new(&xb, &yb)?.minimum();
    let e = (c_max - c_min) / 2.0;
    let c0 = (c_max + c_min) / 2.0;
    let theta_max = wrap360(t_max);
    let r: Vec<f64> = samples
        .iter()
        .map(|s| s.c_px - (c0 + e * (s.theta_deg - theta_max).to_radians().cos()))
        .collect();
    let rms = (r.iter().map(|v| v * v).sum::<f64>() / n as f64).sqrt();
    Ok(EccentricityFit {
        method: FitMethod::Paper,
        e_px: e,
        theta_max_deg: theta_max,
        c0_px: c0,
        u_e_px: None,
        u_theta_max_deg: None,
        residual_rms_px: rms,
        sigma_px: robust_sigma(&r),
        frames_used: n,
        outliers: Vec::new(),
        residuals_px: r,
        roundness: Vec::new(),
        arc_deg: arc,
        quality: QualityVerdict::default(),
        ring: None,
        carried_roundness: false,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sinusoid(e: f64, tmax: f64, start: f64, n: usize, step: f64) -> Vec<Sample> {
        (0..n)
            .map(|i| {
                let t = start + step * i as f64;
                Sample {
                    theta_deg: t,
                    c_px: 700.0 + e * (t - tmax).to_radians().cos(),
                }
            })
            .collect()
    }

    #[test]
    fn least_squares_is_exact_on_a_sinusoid_partial_turn() {
        let s = sinusoid(12.5, 200.0, 5.0, 150, 1.8);
        let f = fit(&s, &FitOptions::default()).unwrap();
        assert!((f.e_px - 12.5).abs() < 1e-8, "{}", f.e_px);
        assert!((f.theta_max_deg - 200.0).abs() < 1e-7);
        assert!(f.outliers.is_empty());
    }

    #[test]
    fn noise_free_turn_with_a_line_on_a_third_is_judged_not_an_error() {
        // More than half of the residuals equal (MAD = 0): σ collapses, yet a residual within
        // the detector's accuracy bound is never cut. The fit returns the sinusoid the other two
        // thirds lie on, cuts the line's 40 frames as outliers, and the gate says why not to
        // trust the turn.
        let mut s = sinusoid(10.0, 40.0, 0.0, 120, 3.0);
        for x in s.iter_mut().step_by(3) {
            x.c_px += 30.0;
        }
        let f = fit(&s, &FitOptions::default()).unwrap();
        assert_eq!(f.outliers.len(), 40, "{:?}", f.outliers);
        assert!(f.outliers.iter().all(|i| i % 3 == 0), "{:?}", f.outliers);
        assert!((f.e_px - 10.0).abs() < 1e-6, "{}", f.e_px);
        assert!(!f.quality.ok);
        let why = f.quality.reasons();
        assert!(why.iter().any(|r| r.starts_with("outliers ")), "{why:?}");
    }

    #[test]
    fn bad_input_is_an_error() {
        let s = sinusoid(1.0, 0.0, 0.0, 2, 1.8);
        assert!(matches!(
            fit(&s, &FitOptions::default()),
            Err(StationError::TooFewSamples { found: 2, .. })
        ));
        let mut s = sinusoid(1.0, 0.0, 0.0, 10, 1.8);
        s[4].theta_deg = s[3].theta_deg;
        assert!(matches!(
            fit(&s, &FitOptions::default()),
            Err(StationError::NotIncreasing { index: 4, .. })
        ));
        s[4].theta_deg = f64::NAN;
        assert!(matches!(
            fit(&s, &FitOptions::with_method(FitMethod::Paper)),
            Err(StationError::NotFinite { index: 4, .. })
        ));
    }
}
