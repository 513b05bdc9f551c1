//! Fourier series of a periodic angle error, in the amplitude–phase form the papers use.
//!
//! A term of order k is `A·sin(k·θ + φ)` (Hsieh et al., 2022 write their fit as `A·sin(2θ + B)`),
//! which equals `a·cos kθ + b·sin kθ` with `a = A·sin φ` and `b = A·cos φ`.

use crate::Radians;
use serde::{Deserialize, Serialize};

/// One harmonic term `amplitude·sin(order·θ + phase)`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Harmonic {
    /// Harmonic order k (cycles per turn), ≥ 1.
    pub order: u32,
    /// Amplitude A, in the series' unit (arcseconds for encoder errors).
    pub amplitude: f64,
    /// Phase φ in radians.
    pub phase_rad: f64,
}

impl Harmonic {
    /// From the cosine and sine coefficients `a·cos kθ + b·sin kθ`.
    ///
    /// ```
    /// use gonio_core::Harmonic;
    /// let h = Harmonic::from_cos_sin(2, 0.6, 0.8);
    /// assert!((h.amplitude - 1.0).abs() < 1e-15);
    /// let (a, b) = h.cos_sin();
    /// assert!((a - 0.6).abs() < 1e-15 && (b - 0.8).abs() < 1e-15);
    /// ```
    pub fn from_cos_sin(order: u32, a: f64, b: f64) -> Self {
        Harmonic {
            order,
            amplitude: a.hypot(b),
            phase_rad: a.atan2(b),
        }
    }

    /// The cosine and sine coefficients `(a, b)`.
    pub fn cos_sin(&self) -> (f64, f64) {
        (
            self.amplitude * self.phase_rad.sin(),
            self.amplitude * self.phase_rad.cos(),
        )
    }

    /// The term's value at angle θ.
    #[inline]
    pub fn eval(&self, theta: Radians) -> f64 {
        self.amplitude * (self.order as f64 * theta.0 + self.phase_rad).sin()
    }
}

/// A constant plus a sum of harmonics.
///
/// ```
/// use gonio_core::{Harmonic, HarmonicSeries, Radians};
/// let s = HarmonicSeries { offset: 0.5, terms: vec![Harmonic { order: 1, amplitude: 2.0, phase_rad: 0.0 }] };
/// assert!((s.eval(Radians(std::f64::consts::FRAC_PI_2)) - 2.5).abs() < 1e-12);
/// ```
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct HarmonicSeries {
    /// Constant term.
    pub offset: f64,
    /// Harmonic terms.
    pub terms: Vec<Harmonic>,
}

impl HarmonicSeries {
    /// The series' value at angle θ.
    pub fn eval(&self, theta: Radians) -> f64 {
        self.offset + self.terms.iter().map(|h| h.eval(theta)).sum::<f64>()
    }
}
