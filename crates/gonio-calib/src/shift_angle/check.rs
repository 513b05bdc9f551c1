//! The harmonic check of the setup error (Hsieh et al., 2022, §3.1).
//!
//! At the first shift, fit `α(θ) + U ≈ A·sin(kθ + B) + U_fit` (k = 2 in the seed: A = 1.0314″,
//! B = −2.4233 rad, U₀ = 0.9596″). At every other shift keep A and B fixed and fit only U_fit;
//! compare it with U from the circle closure (Eq. 7). On N equally spaced angles the fitted
//! offset equals the closure value whenever N does not divide k or 2k, so a large difference
//! flags a harmonic model that does not describe the encoder, or a setup error that changed
//! within a run.

use super::{Calibration, ShiftAngleError};
use gonio_core::{HarmonicFitSpec, HarmonicTerm};
use serde::{Deserialize, Serialize};

/// The check at one shift.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ShiftCheck {
    /// Shift angle, degrees.
    pub shift_deg: f64,
    /// The run whose setup error is checked (start face, 1-based).
    pub start_face: usize,
    /// U from the harmonic fit, arcsec.
    pub u_fit_arcsec: f64,
    /// U from the circle closure (Eq. 7 / the estimator), arcsec.
    pub u_closure_arcsec: f64,
    /// `u_fit − u_closure`, arcsec.
    pub difference_arcsec: f64,
}

/// The harmonic check over all shifts.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct HarmonicCheck {
    /// Harmonic order fitted.
    pub order: u32,
    /// Fitted amplitude A at the first shift, arcsec.
    pub amplitude_arcsec: f64,
    /// Its standard uncertainty, arcsec (`None`, JSON `null`: not determined, when the fit has
    /// no residual degrees of freedom, e.g. a 3-face polygon, or A = 0).
    pub u_amplitude_arcsec: Option<f64>,
    /// Fitted phase B, radians (`A·sin(kθ + B)`).
    pub phase_rad: f64,
    /// Its standard uncertainty, radians (`None`, JSON `null`: not determined, as for A, or A
    /// = 0, where the phase is undefined).
    pub u_phase_rad: Option<f64>,
    /// One entry per shift (the first is the one A and B come from).
    pub shifts: Vec<ShiftCheck>,
}

/// Runs the check with harmonic `order` (2 in the seed).
///
/// # Errors
/// [`ShiftAngleError::Undetermined`] when the order cannot be fitted on N points (N divides k or
/// 2k), or when a shift has no estimated setup error.
pub fn harmonic_check(cal: &Calibration, order: u32) -> Result<HarmonicCheck, ShiftAngleError> {
    let mut out = Vec::with_capacity(cal.shifts.len());
    let mut held = None;
    let mut first = None;
    for (s, sh) in cal.shifts.iter().enumerate() {
        let face = if cal.setup_error(s, 1).is_some() {
            1
        } else {
            cal.setup
                .iter()
                .find(|u| u.shift_deg == sh.shift_deg)
                .map(|u| u.start_face)
                .ok_or_else(|| ShiftAngleError::Undetermined {
                    count: 1,
                    names: format!("U at shift {}°", sh.shift_deg),
                })?
        };
        let u_closure = cal.setup_error(s, face).expect("found").value_arcsec;
        let theta: Vec<f64> = sh.angles_deg.iter().map(|a| a.to_radians()).collect();
        let y: Vec<f64> = sh.alpha_arcsec.iter().map(|a| a + u_closure).collect();
        let spec = match &held {
            None => HarmonicFitSpec::new(&[order]),
            Some(h) => HarmonicFitSpec::new(&[order]).hold_harmonic(h),
        };
        let fit = spec
            .fit(&theta, &y, None)
            .map_err(|e| ShiftAngleError::Undetermined {
                count: 1,
                names: format!("harmonic {order} at shift {}° ({e})", sh.shift_deg),
            })?;
        if held.is_none() {
            let h = fit.harmonic(order).expect("order in the model");
            let (ua, up) = fit.harmonic_uncertainty(order).expect("order in the model");
            first = Some((h, ua, up));
            held = Some(h);
        }
        let u_fit = fit.coefficient(HarmonicTerm::Offset);
        out.push(ShiftCheck {
            shift_deg: sh.shift_deg,
            start_face: face,
            u_fit_arcsec: u_fit,
            u_closure_arcsec: u_closure,
            difference_arcsec: u_fit - u_closure,
        });
    }
    let (h, ua, up) = first.ok_or(ShiftAngleError::Empty)?;
    Ok(HarmonicCheck {
        order,
        amplitude_arcsec: h.amplitude,
        u_amplitude_arcsec: ua.is_finite().then_some(ua),
        phase_rad: h.phase_rad,
        u_phase_rad: up.is_finite().then_some(up),
        shifts: out,
    })
}
