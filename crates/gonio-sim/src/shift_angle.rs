//! The shift-angle measurement simulator: a polygon on the encoder's table, read by an
//! autocollimator at shifted start angles (Hsieh et al., 2022, §2.2).
//!
//! For shift S, start face j and step i the autocollimator reads
//!
//! ```text
//! ε_ij = α(θ_i) + C(j, i) + U_(S,j) + noise,   θ_i = (i−1)·360°/N + S
//! ```
//!
//! quantised to the autocollimator's resolution. α comes from an [`EncoderModel`]; the polygon's
//! pitch deviations β are normal with Σβ = 0; every run (shift, start face) has its own setup
//! error U. Each random part has its own ChaCha stream, so changing (say) the dropped fraction
//! leaves the polygon and the setup errors unchanged.
//!
//! ```
//! use gonio_sim::{EncoderModel, shift_angle::{ShiftAngleConfig, simulate}};
//! let enc = EncoderModel::default_with_seed(1);
//! let cfg = ShiftAngleConfig { faces: 24, shifts_deg: vec![0.0, 5.0, 10.0], ..ShiftAngleConfig::default() };
//! let sim = simulate(&enc, &cfg).unwrap();
//! assert_eq!(sim.readings.len(), 576 + 2 * 24); // full matrix at 0°, one row elsewhere
//! ```

use crate::{EncoderModel, SimError};
use gonio_calib::shift_angle::Reading;
use gonio_core::Degrees;
use gonio_core::closure::{cyclic_sum, remove_mean};
use rand_distr::{Distribution, Normal, Uniform};
use serde::Serialize;

/// Which runs are measured at each shift.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Rows {
    /// Every start face at every shift: N×N readings per shift.
    Full,
    /// Only start face 1 at every shift (β is then not determined: the data cannot be solved).
    One,
    /// The seed's protocol: the full matrix at the first shift, start face 1 at the others.
    #[default]
    Seed,
}

gonio_core::choices!(Rows {
    Full => "full",
    One => "one",
    Seed => "seed",
});

/// Configuration of a simulated shift-angle measurement.
#[derive(Debug, Clone, PartialEq)]
pub struct ShiftAngleConfig {
    /// Polygon faces N (≥ 3).
    pub faces: usize,
    /// Shift angles, degrees.
    pub shifts_deg: Vec<f64>,
    /// Runs measured at each shift.
    pub rows: Rows,
    /// Standard deviation of the polygon's pitch deviations, arcsec.
    pub pitch_sigma_arcsec: f64,
    /// Standard deviation of the setup error of each run, arcsec.
    pub setup_sigma_arcsec: f64,
    /// Autocollimator noise per reading (standard deviation), arcsec.
    pub noise_sigma_arcsec: f64,
    /// Autocollimator resolution (quantisation step), arcsec; 0 for none.
    pub resolution_arcsec: f64,
    /// Readings of every (shift, face, step): 1 for none repeated.
    pub repeats: u32,
    /// Fraction of readings dropped at random (0 ≤ f < 1).
    pub drop_fraction: f64,
    /// Seed of the polygon, setup errors, noise and drops.
    pub seed: u64,
}

impl Default for ShiftAngleConfig {
    /// The seed's set-up: 24 faces, S = 0°, 5°, 10°, 0.05″ noise, 0.001″ resolution.
    fn default() -> Self {
        ShiftAngleConfig {
            faces: 24,
            shifts_deg: vec![0.0, 5.0, 10.0],
            rows: Rows::Seed,
            pitch_sigma_arcsec: 0.3,
            setup_sigma_arcsec: 1.0,
            noise_sigma_arcsec: 0.05,
            resolution_arcsec: 0.001,
            repeats: 1,
            drop_fraction: 0.0,
            seed: 0,
        }
    }
}

/// The true encoder error at one sampled angle.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct TrueAlpha {
    /// Shift angle, degrees.
    pub shift_deg: f64,
    /// Step (1-based).
    pub step: usize,
    /// Table angle, degrees in [0, 360).
    pub angle_deg: f64,
    /// α after the shift's closure (mean over its N angles removed), arcsec: what an estimator
    /// can recover.
    pub value_arcsec: f64,
    /// α as the encoder model gives it, arcsec.
    pub model_arcsec: f64,
}

/// The true setup error of one run.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct TrueSetup {
    /// Shift angle, degrees.
    pub shift_deg: f64,
    /// Start face (1-based).
    pub start_face: usize,
    /// U plus the mean of α over the shift's angles, arcsec: what an estimator can recover.
    pub value_arcsec: f64,
    /// U as planted, arcsec.
    pub planted_arcsec: f64,
}

/// The true pitch deviation of one face.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct TruePitch {
    /// Face (1-based).
    pub face: usize,
    /// β, arcsec.
    pub value_arcsec: f64,
}

/// Ground truth of a simulated measurement (written as `truth.json`).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ShiftAngleTruth {
    /// Polygon faces.
    pub faces: usize,
    /// Seed used.
    pub seed: u64,
    /// β per face.
    pub pitch_deviations: Vec<TruePitch>,
    /// U per run.
    pub setup_errors: Vec<TrueSetup>,
    /// α at every sampled angle, sorted by shift then step.
    pub encoder_errors: Vec<TrueAlpha>,
}

/// A simulated measurement: the readings and their truth.
#[derive(Debug, Clone, PartialEq)]
pub struct ShiftAngleSim {
    /// Readings in measurement order.
    pub readings: Vec<Reading>,
    /// Ground truth.
    pub truth: ShiftAngleTruth,
}

/// Most readings one simulation may produce (shifts × faces² × repeats, before dropping).
pub const MAX_READINGS: u64 = 20_000_000;

/// Simulates a measurement of `encoder`.
///
/// # Errors
/// [`SimError::Parameter`] for fewer than 3 or more than `MAX_FACES` faces, no shifts or a
/// shift listed twice, a negative or non-finite σ or resolution, zero repeats, more than
/// [`MAX_READINGS`] readings, or a dropped fraction outside [0, 1).
pub fn simulate(encoder: &EncoderModel, cfg: &ShiftAngleConfig) -> Result<ShiftAngleSim, SimError> {
    let n = cfg.faces;
    if n < 3 {
        return Err(SimError::parameter("faces", n, "at least 3"));
    }
    if cfg.shifts_deg.is_empty() || cfg.shifts_deg.iter().any(|s| !s.is_finite()) {
        return Err(SimError::parameter(
            "shifts",
            format!("{:?}", cfg.shifts_deg),
            "one or more finite angles in degrees",
        ));
    }
    for (name, v) in [
        ("pitch sigma", cfg.pitch_sigma_arcsec),
        ("setup sigma", cfg.setup_sigma_arcsec),
        ("sigma", cfg.noise_sigma_arcsec),
        ("resolution", cfg.resolution_arcsec),
    ] {
        if !(v >= 0.0 && v.is_finite()) {
            return Err(SimError::parameter(name, v, "a finite value ≥ 0 arcsec"));
        }
    }
    if n > gonio_calib::shift_angle::MAX_FACES {
        return Err(SimError::parameter(
            "faces",
            n,
            &format!("at most {}", gonio_calib::shift_angle::MAX_FACES),
        ));
    }
    if cfg.repeats == 0 {
        return Err(SimError::parameter("repeats", 0, "at least 1"));
    }
    // Readings: every shift has at most N runs of N steps, each repeated.
    let most = cfg.shifts_deg.len() as u64 * (n * n) as u64 * u64::from(cfg.repeats);
    if most > MAX_READINGS {
        return Err(SimError::parameter(
            "shifts × faces² × repeats",
            most,
            &format!("at most {MAX_READINGS} readings"),
        ));
    }
    let mut keys = std::collections::HashSet::new();
    if let Some(s) = cfg
        .shifts_deg
        .iter()
        .find(|&&s| !keys.insert(gonio_calib::shift_angle::ShiftKey::of(s)))
    {
        return Err(SimError::parameter(
            "shifts",
            format!("{s}° twice"),
            "each shift once (the readings of one shift, start face and step would conflict)",
        ));
    }
    if !(0.0..1.0).contains(&cfg.drop_fraction) {
        return Err(SimError::parameter(
            "drop fraction",
            cfg.drop_fraction,
            "0 ≤ f < 1",
        ));
    }
    let normal = |s: f64| Normal::new(0.0, s).expect("σ checked");
    let mut beta: Vec<f64> = {
        let mut r = crate::rng_stream(cfg.seed, 1);
        let d = normal(cfg.pitch_sigma_arcsec);
        (0..n).map(|_| d.sample(&mut r)).collect()
    };
    remove_mean(&mut beta);
    let mut r_setup = crate::rng_stream(cfg.seed, 2);
    let mut r_noise = crate::rng_stream(cfg.seed, 3);
    let mut r_drop = crate::rng_stream(cfg.seed, 4);
    let d_setup = normal(cfg.setup_sigma_arcsec);
    let d_noise = normal(cfg.noise_sigma_arcsec);
    let unit = Uniform::new(0.0, 1.0).expect("valid range");
    let pitch = 360.0 / n as f64;
    let quantise = |v: f64| {
        if cfg.resolution_arcsec > 0.0 {
            (v / cfg.resolution_arcsec).round() * cfg.resolution_arcsec
        } else {
            v
        }
    };

    let mut readings = Vec::new();
    let mut setup_errors = Vec::new();
    let mut encoder_errors = Vec::new();
    for (si, &shift) in cfg.shifts_deg.iter().enumerate() {
        let angles: Vec<f64> = (0..n)
            .map(|i| Degrees(shift + i as f64 * pitch).normalized().0)
            .collect();
        let model: Vec<f64> = angles
            .iter()
            .map(|&a| encoder.error_at(Degrees(a)).0)
            .collect();
        let mut closed = model.clone();
        let mean = remove_mean(&mut closed);
        for i in 0..n {
            encoder_errors.push(TrueAlpha {
                shift_deg: shift,
                step: i + 1,
                angle_deg: angles[i],
                value_arcsec: closed[i],
                model_arcsec: model[i],
            });
        }
        let faces: Vec<usize> = match cfg.rows {
            Rows::Full => (1..=n).collect(),
            Rows::One => vec![1],
            Rows::Seed if si == 0 => (1..=n).collect(),
            Rows::Seed => vec![1],
        };
        for j in faces {
            let u = d_setup.sample(&mut r_setup);
            setup_errors.push(TrueSetup {
                shift_deg: shift,
                start_face: j,
                value_arcsec: u + mean,
                planted_arcsec: u,
            });
            for i in 1..=n {
                let exact = model[i - 1] + cyclic_sum(&beta, j, i) + u;
                for repeat in 1..=cfg.repeats {
                    let noisy = exact + d_noise.sample(&mut r_noise);
                    let dropped =
                        cfg.drop_fraction > 0.0 && unit.sample(&mut r_drop) < cfg.drop_fraction;
                    if !dropped {
                        readings.push(Reading {
                            shift_deg: shift,
                            start_face: j,
                            step: i,
                            repeat,
                            value_arcsec: quantise(noisy),
                        });
                    }
                }
            }
        }
    }
    Ok(ShiftAngleSim {
        readings,
        truth: ShiftAngleTruth {
            faces: n,
            seed: cfg.seed,
            pitch_deviations: beta
                .iter()
                .enumerate()
                .map(|(k, &b)| TruePitch {
                    face: k + 1,
                    value_arcsec: b,
                })
                .collect(),
            setup_errors,
            encoder_errors,
        },
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn same_seed_same_readings_and_streams_are_independent() {
        let enc = EncoderModel::default_with_seed(5);
        let cfg = ShiftAngleConfig {
            seed: 9,
            ..ShiftAngleConfig::default()
        };
        let a = simulate(&enc, &cfg).unwrap();
        assert_eq!(a, simulate(&enc, &cfg).unwrap());
        let dropped = simulate(
            &enc,
            &ShiftAngleConfig {
                drop_fraction: 0.2,
                ..cfg.clone()
            },
        )
        .unwrap();
        assert_eq!(a.truth, dropped.truth);
        assert!(dropped.readings.len() < a.readings.len());
    }

    #[test]
    fn noise_free_readings_follow_the_model() {
        let enc = EncoderModel::default_with_seed(1);
        let cfg = ShiftAngleConfig {
            noise_sigma_arcsec: 0.0,
            resolution_arcsec: 0.0,
            rows: Rows::Full,
            faces: 6,
            shifts_deg: vec![0.0, 20.0],
            ..ShiftAngleConfig::default()
        };
        let sim = simulate(&enc, &cfg).unwrap();
        assert_eq!(sim.readings.len(), 2 * 36);
        let sum_beta: f64 = sim
            .truth
            .pitch_deviations
            .iter()
            .map(|p| p.value_arcsec)
            .sum();
        assert!(sum_beta.abs() < 1e-14);
        // Step N of any run: C(j, N) = Σβ = 0, so ε = α(θ_N) + U.
        let r = sim
            .readings
            .iter()
            .find(|r| r.start_face == 3 && r.step == 6 && r.shift_deg == 20.0)
            .unwrap();
        let a = sim
            .truth
            .encoder_errors
            .iter()
            .find(|a| a.shift_deg == 20.0 && a.step == 6)
            .unwrap();
        let u = sim
            .truth
            .setup_errors
            .iter()
            .find(|u| u.shift_deg == 20.0 && u.start_face == 3)
            .unwrap();
        assert!((r.value_arcsec - (a.model_arcsec + u.planted_arcsec)).abs() < 1e-12);
        assert!((a.angle_deg - 20.0 - 5.0 * 60.0).abs() < 1e-12);
    }
}
