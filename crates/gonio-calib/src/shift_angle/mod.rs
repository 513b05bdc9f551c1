//! Cross-calibration by the shift-angle method (Hsieh et al., 2022, §2.1–2.2).
//!
//! A polygon of N faces sits on the table of the encoder under test; an autocollimator reads one
//! face. For shift angle S, step i (table angle θ_i = (i−1)·360°/N + S) and start face j:
//!
//! ```text
//! ε_ij = α(θ_i) + C(j, i) + U_j + noise,     C(j, i) = β_j + … + β_(j+i−1)   (faces wrap)
//! ```
//!
//! with Σβ = 0 and, per shift, Σ_i α(θ_i) = 0 (circle closure). Two estimators:
//! - [`Method::LeastSquares`] (default): all readings of all shifts jointly, exploiting the
//!   block structure of the normal equations ([`least_squares`]).
//! - [`Method::Paper`]: the seed's algorithm (Table 2 differences, Eq. 7 closure, one row per
//!   shift), kept as the reference baseline ([`paper`]).
//!
//! ```
//! use gonio_calib::shift_angle::{calibrate, Method, Options, Reading, ReadingSet};
//! // A noise-free 3-face polygon at one shift: α = (0.5, −0.2, −0.3), β = (0.1, 0.2, −0.3), U = 0.
//! let (alpha, beta) = ([0.5, -0.2, -0.3], [0.1, 0.2, -0.3]);
//! let mut readings = Vec::new();
//! for j in 1..=3usize {
//!     for i in 1..=3usize {
//!         let c: f64 = (0..i).map(|t| beta[(j - 1 + t) % 3]).sum();
//!         readings.push(Reading::new(0.0, j, i, alpha[i - 1] + c));
//!     }
//! }
//! let set = ReadingSet::new(3, readings).unwrap();
//! let cal = calibrate(&set, &Options::default()).unwrap();
//! assert!((cal.shifts[0].alpha_arcsec[0] - 0.5).abs() < 1e-12);
//! assert!((cal.beta_arcsec[2] + 0.3).abs() < 1e-12);
//! let paper = calibrate(&set, &Options { method: Method::Paper, ..Options::default() }).unwrap();
//! assert!((paper.shifts[0].alpha_arcsec[1] + 0.2).abs() < 1e-12);
//! ```

mod check;
mod data;
mod error;
pub mod least_squares;
pub mod paper;
mod range;
mod result;

pub use check::{HarmonicCheck, ShiftCheck, harmonic_check};
pub use data::{MAX_FACES, Reading, ReadingSet, ShiftKey};
pub use error::ShiftAngleError;
pub use range::{MAX_SHIFTS, SHIFT_DEG, shift_range};
pub(crate) use result::residual_stats;
pub use result::{
    Calibration, Chi2Check, FullCovariance, Residuals, SetupError, ShiftResult, undetectable_orders,
};

/// Which estimator to run.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Method {
    /// Joint constrained least squares over all readings (the project's default).
    #[default]
    LeastSquares,
    /// The seed's algorithm: β from one full matrix, α and U from one row per shift.
    Paper,
}

gonio_core::choices!(Method {
    LeastSquares => "least-squares" | "ls",
    Paper => "paper",
});

/// How much of the covariance to compute.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum CovarianceLevel {
    /// Standard uncertainties only (the diagonal).
    #[default]
    Diagonal,
    /// Also the full covariance matrices of α (all shifts) and β (least squares only).
    Full,
}

/// Options of [`calibrate`].
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Options {
    /// The estimator.
    pub method: Method,
    /// Standard deviation of one reading, arcsec, if known. It scales the covariance and is
    /// checked against the residuals (χ²); without it, σ̂ from the residuals is used.
    pub sigma_arcsec: Option<f64>,
    /// How much covariance to compute.
    pub covariance: CovarianceLevel,
}

/// Calibrates the encoder (and the polygon) from a set of readings.
///
/// # Errors
/// [`ShiftAngleError::Undetermined`] when the readings leave unknowns undetermined (it names
/// them); [`ShiftAngleError::PaperNeeds`] when the paper's algorithm lacks the full matrix or a
/// complete row it needs. Without residual degrees of freedom and without a given σ it is not an
/// error: the uncertainties are then NaN (undefined).
pub fn calibrate(set: &ReadingSet, opts: &Options) -> Result<Calibration, ShiftAngleError> {
    if let Some(s) = opts.sigma_arcsec
        && !(s > 0.0 && s.is_finite())
    {
        return Err(ShiftAngleError::InvalidSigma { sigma_arcsec: s });
    }
    match opts.method {
        Method::LeastSquares => least_squares::solve(set, opts),
        Method::Paper => paper::solve(set, opts),
    }
}
