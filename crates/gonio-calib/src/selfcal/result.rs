//! The result of self-calibration: a(θ) per position with its random standard uncertainty, the
//! harmonic table, residuals and how u was obtained. The expanded uncertainty (instrument terms,
//! k, U) is attached by [`crate::certificate`], the one place that does it for every method.

use super::NoiseModel;
use gonio_uncertainty::budget::{deserialize_dof, serialize_dof};
use serde::{Deserialize, Serialize};

/// a(θ) at one rotation position.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ErrorPoint {
    /// Rotation position, degrees in [0, 360).
    pub position_deg: f64,
    /// Estimated error (zero mean over the circle), arcsec.
    pub value_arcsec: f64,
    /// Standard uncertainty of the estimator's random part, arcsec.
    pub u_arcsec: f64,
    /// Degrees of freedom of u (the residual degrees of freedom, or turns − 1).
    #[serde(serialize_with = "serialize_dof", deserialize_with = "deserialize_dof")]
    pub nu_eff: f64,
}

/// One harmonic of the estimated error, `amplitude·sin(order·θ + phase)`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct HarmonicRow {
    /// Order k (cycles per turn).
    pub order: u32,
    /// Amplitude, arcsec.
    pub amplitude_arcsec: f64,
    /// Phase, radians.
    pub phase_rad: f64,
    /// Whether the method can see this harmonic.
    pub detectable: bool,
    /// Variance of Â(k) per unit variance of independent noise on each D_h (Σ_h |v_hk|²;
    /// 1/Σ|w_hk|² for least squares); 0 when undetectable.
    pub noise_gain: f64,
    /// The same with the [`NoiseModel::Readings`] correlation (Σ|v|² + |Σv|²).
    pub noise_gain_readings: f64,
    /// Standard uncertainty of each of the cosine and sine coefficients, arcsec.
    pub u_coefficient_arcsec: f64,
}

/// Residual statistics of the model fit.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Residuals {
    /// RMS of D_h − (â(θ+φ_h) − â(θ) + ĉ_h) over all readings, arcsec.
    pub rms_arcsec: f64,
    /// Largest |residual|, arcsec.
    pub max_abs_arcsec: f64,
    /// Residual degrees of freedom (the expected-residual trace under the noise model).
    pub dof: f64,
    /// σ̂ per reading (per head reading for `readings`, per difference for `differences`), arcsec.
    pub sigma_arcsec: f64,
}

/// The uncertainty of a(θ) and where it came from.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct UncertaintyInfo {
    /// `residuals` or `repeated turns`.
    pub source: String,
    /// u from the residuals (σ̂ through the noise gains), arcsec.
    pub u_residuals_arcsec: f64,
    /// u from the turn-to-turn spread (pooled over positions, / √turns), arcsec; absent for one turn.
    pub u_turns_arcsec: Option<f64>,
}

/// The result of [`super::calibrate`]; [`crate::certificate::Certificate::from_selfcal`] turns it
/// into a certificate (the `gonio selfcal` JSON).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SelfcalResult {
    /// `selfcal-fourier`, `selfcal-eda` or `selfcal-selfa`.
    pub method: String,
    /// Head angles, degrees.
    pub heads_deg: Vec<f64>,
    /// 1-based heads whose averaged reading is calibrated.
    pub reference_heads: Vec<usize>,
    /// Rotation positions per turn NS.
    pub positions: usize,
    /// Number of turns.
    pub turns: usize,
    /// The noise model of the uncertainty.
    pub noise_model: NoiseModel,
    /// a(θ) at every rotation position.
    pub errors: Vec<ErrorPoint>,
    /// Harmonics 1..=`max_order`.
    pub harmonics: Vec<HarmonicRow>,
    /// Orders ≤ `max_order` the method cannot see (their amplitude is reported as 0).
    pub undetectable_orders: Vec<u32>,
    /// The largest order considered.
    pub max_order: u32,
    /// Estimated mounting offsets c_h of heads 2..M, arcsec.
    pub head_offsets_arcsec: Vec<f64>,
    /// Residuals of the fit.
    pub residuals: Residuals,
    /// How u was obtained.
    pub uncertainty: UncertaintyInfo,
}
