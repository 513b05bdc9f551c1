//! Self-calibration of a rotary encoder with several read heads: EDA, SelfA and Fourier least squares.
//!
//! Model (spec `self-calibration.md`): the scale's deviation a(θ) (arcsec, zero mean over the
//! circle) is read by M heads at angles φ_1 = 0 < φ_2 < … < φ_M. At rotation position θ the
//! difference between head h and head 1 is
//!
//! ```text
//! D_h(θ) = a(θ + φ_h) − a(θ) + c_h + noise          (arcsec; c_h the head's mounting offset)
//! ```
//!
//! Sampled at NS equally spaced positions over one turn and transformed over θ, harmonic k of D_h
//! is `w_hk·A(k)` with `w_hk = e^{ikφ_h} − 1`. Every estimator here is linear per harmonic,
//! `Â(k) = Σ_h v_hk·D̂_h(k)`:
//!
//! - [`Method::Fourier`] (default, any head positions): `v_hk = conj(w_hk) / Σ_h |w_hk|²`, the
//!   least-squares solution. Harmonic k is undetectable when every `w_hk = 0`; its noise gain is
//!   `1 / Σ_h |w_hk|²` (1/28 at k = 1 for SelfA).
//! - [`Method::Eda`] on one set of NH equally spaced heads (Hsieh et al., 2022, Eq. 9):
//!   `μ_i = −(1/NH)·Σ_j D_j(θ_i)` (the seed's δ_(1,j) = −D_j); harmonics divisible by NH vanish.
//! - [`Method::Eda`] on an arrangement with several sets (SelfA: 3, 4 and 7 heads on 12): each
//!   set's EDA, combined harmonic by harmonic from the sets whose NH does not divide k
//!   (inverse-variance weights NH²/(NH−1)); only multiples of lcm(NH) are lost (84 for SelfA).
//!
//! The algorithm is the product here, so the spectral bookkeeping is written out; the FFT is
//! `realfft`. The uncertainty of a(θ) comes from the residuals of the model (σ̂ per reading, then
//! propagated through each harmonic's noise gain) or, with repeated turns, from the spread of the
//! turn-by-turn results.
//!
//! ```
//! use gonio_calib::selfcal::{calibrate, Heads, SelfcalOptions, Turn};
//! // A pure 3rd harmonic read by 4 equally spaced heads at 360 positions.
//! let heads = Heads::preset("eda:4").unwrap();
//! let ns = 360;
//! let a = |t: f64| 0.5 * (3.0 * t.to_radians()).sin();
//! let positions_deg: Vec<f64> = (0..ns).map(|i| i as f64).collect();
//! let differences_arcsec = heads.angles_deg()[1..]
//!     .iter()
//!     .map(|&p| positions_deg.iter().map(|&t| a(t + p) - a(t)).collect())
//!     .collect();
//! let r = calibrate(&heads, &[Turn { positions_deg, differences_arcsec }], &SelfcalOptions::default()).unwrap();
//! assert!((r.errors[30].value_arcsec - a(30.0)).abs() < 1e-9);
//! assert!(r.undetectable_orders.contains(&4));
//! ```

mod data;
mod error;
mod estimate;
mod heads;
mod result;
mod scratch;

pub use data::{MIN_POSITIONS, Turn};
pub use error::SelfcalError;
pub(crate) use estimate::{HeadSpectra, head_spectra, phasor_table};
pub use estimate::{MAX_NOISE_GAIN, calibrate, eda_direct, noise_gain};
pub use heads::{EQUAL_DIVISION_TOL_DEG, Heads};
pub use result::{ErrorPoint, HarmonicRow, Residuals, SelfcalResult, UncertaintyInfo};

use serde::{Deserialize, Serialize};

/// The estimator.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Method {
    /// General Fourier least squares (any head positions).
    #[default]
    Fourier,
    /// Equal-division averaging (one set), or the SelfA combination of several sets.
    Eda,
}

gonio_core::choices!(Method {
    Fourier => "fourier",
    Eda => "eda" | "selfa",
});

/// How the reading noise is modelled when propagating it to a(θ).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum NoiseModel {
    /// Each head's reading has independent noise σ, so every D_h shares head 1's noise
    /// (covariance σ²(I + 11ᵀ)). Head 1's noise looks exactly like a(θ) and passes into it.
    #[default]
    Readings,
    /// Each difference D_h has independent noise σ (the textbook noise gain 1/Σ|w|²).
    Differences,
}

gonio_core::choices!(NoiseModel {
    Readings => "readings",
    Differences => "differences",
});

/// Largest harmonic order a harmonic table and the lists of undetectable orders may ask for
/// (`max_order`, `--max-order`; the joint calibration's `blind_max_order` too): 100,000.
pub const MAX_ORDER: u32 = 100_000;

/// Options of [`calibrate`].
#[derive(Debug, Clone, PartialEq)]
pub struct SelfcalOptions {
    /// The estimator.
    pub method: Method,
    /// The noise model for the uncertainty.
    pub noise_model: NoiseModel,
    /// 0-based heads whose averaged reading is the one calibrated (default `[0]`, head 1; the
    /// seed's SelfA averages heads 1 and 7, `[0, 6]`). The result is then the error of that
    /// averaged reading: `Σ_r a(θ + φ_r) / R`.
    pub reference_heads: Vec<usize>,
    /// Largest harmonic order in the harmonic table and the undetectable list (clamped below NS/2).
    pub max_order: u32,
}

impl Default for SelfcalOptions {
    fn default() -> Self {
        SelfcalOptions {
            method: Method::Fourier,
            noise_model: NoiseModel::Readings,
            reference_heads: vec![0],
            max_order: 360,
        }
    }
}
