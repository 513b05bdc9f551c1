//! One encoder measured on both rigs: the polygon + autocollimator (shift-angle method) and the
//! multi-head read-out (self-calibration), for the joint calibration.
//!
//! Both simulators read the same [`EncoderModel`]; each keeps its own seed streams, so the
//! polygon's readings are exactly those of [`crate::shift_angle::simulate`] with the same
//! configuration, and likewise for the heads. The truth on the heads' grid gives the encoder's
//! true harmonic coefficients, so an estimate can be checked order by order.
//!
//! ```
//! use gonio_sim::{EncoderModel, joint::{JointSimConfig, simulate, true_coefficients}};
//! let enc = EncoderModel::default_with_seed(1);
//! let mut cfg = JointSimConfig::new(24, (0..15).map(f64::from).collect(), 1);
//! cfg.heads.positions = 3600;
//! let sim = simulate(&enc, &cfg).unwrap();
//! assert_eq!(sim.polygon.readings.len(), 15 * 24 * 24);
//! let (c, s) = true_coefficients(&sim.heads.truth, 2);
//! assert!((c.hypot(s) - 1.0314).abs() < 0.01); // the 2nd harmonic of Hsieh et al., 2022 (plus graduation noise)
//! ```

use crate::selfcal::{SelfcalSim, SelfcalSimConfig, SelfcalTruth};
use crate::shift_angle::{Rows, ShiftAngleConfig, ShiftAngleSim};
use crate::{EncoderModel, SimError};
use gonio_calib::selfcal::Heads;

/// Configuration of both rigs.
#[derive(Debug, Clone, PartialEq)]
pub struct JointSimConfig {
    /// The polygon rig.
    pub polygon: ShiftAngleConfig,
    /// The head rig.
    pub heads: SelfcalSimConfig,
}

impl JointSimConfig {
    /// A polygon of `faces` faces read in full matrices at `shifts_deg` (σ 0.05″, resolution
    /// 0.001″), and SelfA's twelve heads at 36,000 positions (σ 0.01″); the heads draw from
    /// `seed + 1000` so the two rigs' noises are independent.
    pub fn new(faces: usize, shifts_deg: Vec<f64>, seed: u64) -> Self {
        JointSimConfig {
            polygon: ShiftAngleConfig {
                faces,
                shifts_deg,
                rows: Rows::Full,
                seed,
                ..ShiftAngleConfig::default()
            },
            heads: SelfcalSimConfig::new(Heads::selfa12(), seed + 1000),
        }
    }
}

/// Both measurements of one encoder.
#[derive(Debug, Clone, PartialEq)]
pub struct JointSim {
    /// The polygon readings and their truth.
    pub polygon: ShiftAngleSim,
    /// The head readings and their truth (a(θ) on the grid, zero mean).
    pub heads: SelfcalSim,
}

/// Simulates both rigs.
///
/// # Errors
/// As [`crate::shift_angle::simulate`] and [`crate::selfcal::simulate`].
pub fn simulate(encoder: &EncoderModel, cfg: &JointSimConfig) -> Result<JointSim, SimError> {
    Ok(JointSim {
        polygon: crate::shift_angle::simulate(encoder, &cfg.polygon)?,
        heads: crate::selfcal::simulate(encoder, &cfg.heads)?,
    })
}

/// The true (cos, sin) coefficients of order k of a(θ) on the heads' grid (its exact DFT), arcsec:
/// `a(θ) = Σ_k cos_k·cos kθ + sin_k·sin kθ`.
pub fn true_coefficients(truth: &SelfcalTruth, order: u32) -> (f64, f64) {
    let ns = truth.errors.len() as f64;
    let k = order as f64;
    let (mut c, mut s) = (0.0, 0.0);
    for p in &truth.errors {
        let (sn, cs) = (k * p.position_deg.to_radians()).sin_cos();
        c += p.value_arcsec * cs;
        s += p.value_arcsec * sn;
    }
    let scale = if 2 * order as usize == truth.errors.len() {
        1.0
    } else {
        2.0
    };
    (scale * c / ns, scale * s / ns)
}

/// The true a(θ) at grid positions `angles_deg` without the harmonic orders `without` (what an
/// estimate that cannot contain those orders can recover), arcsec.
///
/// # Panics
/// If an angle is not a grid position of the truth.
pub fn truth_without(truth: &SelfcalTruth, without: &[u32], angles_deg: &[f64]) -> Vec<f64> {
    let ns = truth.errors.len();
    let step = 360.0 / ns as f64;
    let start = truth.errors[0].position_deg;
    let coefs: Vec<(u32, f64, f64)> = without
        .iter()
        .map(|&k| {
            let (c, s) = true_coefficients(truth, k);
            (k, c, s)
        })
        .collect();
    angles_deg
        .iter()
        .map(|&a| {
            let m = ((a - start) / step).round() as i64;
            assert!(
                ((a - start) / step - m as f64).abs() < 1e-6,
                "{a}° is off the grid"
            );
            let v = truth.errors[m.rem_euclid(ns as i64) as usize].value_arcsec;
            let t = a.to_radians();
            v - coefs
                .iter()
                .map(|&(k, c, s)| {
                    let (sn, cs) = (k as f64 * t).sin_cos();
                    c * cs + s * sn
                })
                .sum::<f64>()
        })
        .collect()
}
