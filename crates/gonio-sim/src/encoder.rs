//! The encoder error model: the angle error α(θ) of a rotary encoder.
//!
//! ```text
//! α(θ) = Σ_k A_k·sin(k·θ + φ_k) + g(θ)      [arcsec]
//! ```
//!
//! `g` is the random graduation error: one independent normal value per graduation line
//! (standard deviation `sigma_arcsec`), with its mean removed (circle closure), interpolated
//! linearly between lines. The line values are generated from the model's own seed, so the JSON
//! file stays small and reproduces the same encoder exactly.
//!
//! ```
//! use gonio_sim::EncoderModel;
//! use gonio_core::Degrees;
//! let enc = EncoderModel::default_with_seed(7);
//! let again = EncoderModel::from_json(&enc.to_json()).unwrap();
//! assert_eq!(enc.error_at(Degrees(12.5)), again.error_at(Degrees(12.5)));
//! ```

use crate::SimError;
use gonio_core::bound::Bound;
use gonio_core::{Arcsec, Degrees, Harmonic, Radians};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};
use serde::{Deserialize, Serialize};

/// Most graduation lines of a model (each holds one random error: 800 MB at this limit; real
/// gratings have up to a few hundred thousand).
pub const MAX_LINES: u32 = 100_000_000;

/// A harmonic's amplitude: an encoder error of up to a few degrees.
pub const AMPLITUDE_ARCSEC: Bound = Bound::new(-1e4, 1e4, "″");
/// A harmonic's phase.
pub const PHASE_RAD: Bound = Bound::new(-1e3, 1e3, "rad");
/// The graduation lines' σ.
pub const GRADUATION_SIGMA_ARCSEC: Bound = Bound::new(0.0, 3600.0, "″");

/// Most harmonics of a model.
pub const MAX_HARMONICS: usize = 10_000;

/// The model file's `format` value.
pub const ENCODER_FORMAT: &str = "gonio-encoder-model";

/// One harmonic of the encoder error, `amplitude_arcsec·sin(order·θ + phase_rad)`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct HarmonicArcsec {
    /// Order k (cycles per turn), ≥ 1.
    pub order: u32,
    /// Amplitude in arcseconds.
    pub amplitude_arcsec: f64,
    /// Phase in radians.
    pub phase_rad: f64,
}

impl From<HarmonicArcsec> for Harmonic {
    fn from(h: HarmonicArcsec) -> Self {
        Harmonic {
            order: h.order,
            amplitude: h.amplitude_arcsec,
            phase_rad: h.phase_rad,
        }
    }
}

/// The random graduation error of the scale.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Graduation {
    /// Number of graduation lines on the circle (36 000 in Hsieh et al., 2022: a 36″ pitch).
    pub lines: u32,
    /// Standard deviation of one line's position error, arcseconds (0 for none).
    pub sigma_arcsec: f64,
    /// Seed of the line errors.
    pub seed: u64,
}

#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct ModelFile {
    format: String,
    version: u32,
    harmonics: Vec<HarmonicArcsec>,
    graduation: Graduation,
}

/// An encoder's angle error as a function of the angle.
#[derive(Debug, Clone, PartialEq)]
pub struct EncoderModel {
    harmonics: Vec<HarmonicArcsec>,
    graduation: Graduation,
    /// Line errors, closed (zero mean), arcsec; empty when sigma is 0.
    lines: Vec<f64>,
}

impl EncoderModel {
    /// The default harmonics: a low-order error like the encoder of Hsieh et al., 2022 (its fitted
    /// 2nd harmonic, A = 1.0314″, B = −2.4233 rad), a few higher orders, and small terms at orders
    /// 24 and 84 that a 24-face polygon and the SelfA heads respectively cannot see.
    pub fn default_harmonics() -> Vec<HarmonicArcsec> {
        let h = |order, amplitude_arcsec, phase_rad| HarmonicArcsec {
            order,
            amplitude_arcsec,
            phase_rad,
        };
        vec![
            h(1, 0.45, 0.8),
            h(2, 1.0314, -2.4233),
            h(3, 0.22, 1.3),
            h(4, 0.12, -0.4),
            h(6, 0.05, 2.2),
            h(12, 0.03, -1.7),
            h(24, 0.008, 0.5),
            h(84, 0.005, 1.0),
        ]
    }

    /// The default graduation: 36 000 lines with 0.01″ random error.
    pub fn default_graduation(seed: u64) -> Graduation {
        Graduation {
            lines: 36_000,
            sigma_arcsec: 0.01,
            seed,
        }
    }

    /// The default encoder with its graduation error drawn from `seed`.
    pub fn default_with_seed(seed: u64) -> Self {
        Self::new(Self::default_harmonics(), Self::default_graduation(seed))
            .expect("the default model is valid")
    }

    /// A model from its harmonics and graduation.
    ///
    /// # Errors
    /// [`SimError::Parameter`] for order 0, an amplitude or phase outside [`AMPLITUDE_ARCSEC`]
    /// or [`PHASE_RAD`], zero lines or more than [`MAX_LINES`], more than [`MAX_HARMONICS`]
    /// harmonics, or a sigma outside [`GRADUATION_SIGMA_ARCSEC`].
    pub fn new(harmonics: Vec<HarmonicArcsec>, graduation: Graduation) -> Result<Self, SimError> {
        for h in &harmonics {
            if h.order == 0 {
                return Err(SimError::parameter("order", 0, "a harmonic order ≥ 1"));
            }
            for (name, v, bound) in [
                ("amplitude_arcsec", h.amplitude_arcsec, AMPLITUDE_ARCSEC),
                ("phase_rad", h.phase_rad, PHASE_RAD),
            ] {
                if let Err(e) = bound.check(v) {
                    return Err(SimError::parameter(name, v, &e.to_string()));
                }
            }
        }
        if harmonics.len() > MAX_HARMONICS {
            return Err(SimError::parameter(
                "harmonics",
                harmonics.len(),
                "at most 10000 harmonics",
            ));
        }
        if graduation.lines == 0 || graduation.lines > MAX_LINES {
            return Err(SimError::parameter(
                "lines",
                graduation.lines,
                "1 to 100000000 graduation lines",
            ));
        }
        if let Err(e) = GRADUATION_SIGMA_ARCSEC.check(graduation.sigma_arcsec) {
            return Err(SimError::parameter(
                "sigma_arcsec",
                graduation.sigma_arcsec,
                &e.to_string(),
            ));
        }
        let lines = if graduation.sigma_arcsec > 0.0 {
            let mut rng = ChaCha8Rng::seed_from_u64(graduation.seed);
            let normal = Normal::new(0.0, graduation.sigma_arcsec).expect("sigma checked");
            let mut v: Vec<f64> = (0..graduation.lines)
                .map(|_| normal.sample(&mut rng))
                .collect();
            gonio_core::closure::remove_mean(&mut v);
            v
        } else {
            Vec::new()
        };
        Ok(EncoderModel {
            harmonics,
            graduation,
            lines,
        })
    }

    /// A model with harmonics only (no graduation error).
    pub fn harmonics_only(harmonics: Vec<HarmonicArcsec>) -> Result<Self, SimError> {
        Self::new(
            harmonics,
            Graduation {
                lines: 36_000,
                sigma_arcsec: 0.0,
                seed: 0,
            },
        )
    }

    /// The harmonics of the model.
    pub fn harmonics(&self) -> &[HarmonicArcsec] {
        &self.harmonics
    }

    /// The graduation parameters.
    pub fn graduation(&self) -> Graduation {
        self.graduation
    }

    /// The encoder's angle error α at table angle θ (any real angle; periodic in 360°).
    pub fn error_at(&self, theta: Degrees) -> Arcsec {
        let rad = Radians::from(theta);
        let mut a: f64 = self
            .harmonics
            .iter()
            .map(|h| Harmonic::from(*h).eval(rad))
            .sum();
        if !self.lines.is_empty() {
            let n = self.lines.len();
            let pos = theta.normalized().0 / 360.0 * n as f64;
            let i0 = (pos.floor() as usize) % n;
            let f = pos - pos.floor();
            let i1 = (i0 + 1) % n;
            a += self.lines[i0] * (1.0 - f) + self.lines[i1] * f;
        }
        Arcsec(a)
    }

    /// The model as a JSON document (the model file).
    pub fn to_json(&self) -> String {
        let f = ModelFile {
            format: ENCODER_FORMAT.to_string(),
            version: 1,
            harmonics: self.harmonics.clone(),
            graduation: self.graduation,
        };
        let mut s = serde_json::to_string_pretty(&f).expect("serialisable");
        s.push('\n');
        s
    }

    /// Reads a model file's text.
    ///
    /// # Errors
    /// [`SimError::ModelFormat`] with the line and column of malformed JSON, a missing or
    /// unknown field, or a wrong `format`/`version`; [`SimError::Parameter`] for invalid values.
    pub fn from_json(text: &str) -> Result<Self, SimError> {
        let f: ModelFile = serde_json::from_str(text).map_err(|e| SimError::ModelFormat {
            line: e.line(),
            column: e.column(),
            message: e.to_string(),
        })?;
        if f.format != ENCODER_FORMAT || f.version != 1 {
            return Err(SimError::ModelFormat {
                line: 1,
                column: 1,
                message: format!(
                    "expected format \"{ENCODER_FORMAT}\" version 1, found \"{}\" version {}",
                    f.format, f.version
                ),
            });
        }
        Self::new(f.harmonics, f.graduation)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn graduation_closes_and_is_reproducible() {
        let a = EncoderModel::default_with_seed(3);
        let b = EncoderModel::default_with_seed(3);
        let c = EncoderModel::default_with_seed(4);
        assert_eq!(a, b);
        assert_ne!(a.lines, c.lines);
        let mean: f64 = a.lines.iter().sum::<f64>() / a.lines.len() as f64;
        assert!(mean.abs() < 1e-15);
        // Sample std of 36 000 normal draws is within 4 standard errors of sigma.
        let s = (a.lines.iter().map(|x| x * x).sum::<f64>() / a.lines.len() as f64).sqrt();
        assert!((s - 0.01).abs() < 4.0 * 0.01 / (2.0 * 36_000f64).sqrt());
    }

    #[test]
    fn harmonic_only_value() {
        let m = EncoderModel::harmonics_only(vec![HarmonicArcsec {
            order: 2,
            amplitude_arcsec: 1.0,
            phase_rad: 0.0,
        }])
        .unwrap();
        assert!((m.error_at(Degrees(45.0)).0 - 1.0).abs() < 1e-15);
        assert!((m.error_at(Degrees(405.0)).0 - 1.0).abs() < 1e-12);
    }

    #[test]
    fn bad_files_name_line_and_column() {
        let e = EncoderModel::from_json("{\n \"format\": \"gonio-encoder-model\",\n \"version\": 1,\n \"harmonics\": [{\"order\": 1}]\n}").unwrap_err();
        assert!(matches!(e, SimError::ModelFormat { line: 4, .. }), "{e}");
        let e = EncoderModel::from_json("{\"format\":\"x\",\"version\":1,\"harmonics\":[],\"graduation\":{\"lines\":1,\"sigma_arcsec\":0,\"seed\":0}}").unwrap_err();
        assert!(e.to_string().contains("gonio-encoder-model"));
    }
}
