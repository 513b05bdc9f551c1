//! The multi-head measurement simulator: one encoder scale read by several heads over full turns
//! (Hsieh et al., 2022, §2.3).
//!
//! Head h sits at φ_h + δ_h (δ_h its mounting offset, arcsec; δ_1 = 0 since head 1 is the
//! reference). At rotation position θ it reads the scale at θ + φ_h + δ_h, so its reading is
//!
//! ```text
//! r_h(θ) = θ + φ_h + δ_h + a(θ + φ_h + δ_h) + n_h        (n_h ~ N(0, σ²), quantised to the resolution)
//! D_h(θ) = r_h − r_1 − φ_h = a(θ + φ_h + δ_h) − a(θ) + δ_h + n_h − n_1
//! ```
//!
//! with a(θ) the [`EncoderModel`]'s error, the same model file the shift-angle simulator reads,
//! so both methods calibrate one encoder. Positions are `start + i·360°/NS`; repeated turns
//! draw fresh noise. Offsets and noise have their own ChaCha streams.
//!
//! ```
//! use gonio_sim::{EncoderModel, selfcal::{SelfcalSimConfig, simulate}};
//! use gonio_calib::selfcal::{calibrate, Heads, SelfcalOptions};
//! let enc = EncoderModel::default_with_seed(1);
//! let cfg = SelfcalSimConfig { positions: 360, ..SelfcalSimConfig::new(Heads::selfa12(), 5) };
//! let sim = simulate(&enc, &cfg).unwrap();
//! let r = calibrate(&cfg.heads, &sim.turns, &SelfcalOptions::default()).unwrap();
//! let worst = r.errors.iter().zip(&sim.truth.errors)
//!     .map(|(e, t)| (e.value_arcsec - t.value_arcsec).abs()).fold(0.0, f64::max);
//! assert!(worst < 0.05, "{worst}");
//! ```

use crate::{EncoderModel, SimError};
use gonio_calib::selfcal::{Heads, Turn};
use gonio_core::Degrees;
use rand_distr::{Distribution, Normal};
use serde::Serialize;

/// The truth file's `format` value.
pub const TRUTH_FORMAT: &str = "gonio-selfcal-truth";

/// Configuration of a simulated multi-head measurement.
#[derive(Debug, Clone, PartialEq)]
pub struct SelfcalSimConfig {
    /// Head arrangement.
    pub heads: Heads,
    /// Mounting offsets δ_h per head, arcsec (head 1's is ignored: it is the reference); `None`
    /// draws them normal with `offset_sigma_arcsec`.
    pub offsets_arcsec: Option<Vec<f64>>,
    /// Standard deviation of drawn mounting offsets, arcsec.
    pub offset_sigma_arcsec: f64,
    /// Rotation positions per turn NS (36 000 in the seed).
    pub positions: usize,
    /// First rotation position, degrees.
    pub start_deg: f64,
    /// Noise per head reading (standard deviation), arcsec.
    pub noise_sigma_arcsec: f64,
    /// Head resolution (quantisation step of each reading), arcsec; 0 for none.
    pub resolution_arcsec: f64,
    /// Repeated turns (≥ 1).
    pub turns: usize,
    /// Seed of the offsets and the noise.
    pub seed: u64,
}

impl SelfcalSimConfig {
    /// Defaults: 36 000 positions from 0°, σ = 0.01″ per reading, offsets drawn with σ = 5″,
    /// no quantisation, one turn.
    pub fn new(heads: Heads, seed: u64) -> Self {
        SelfcalSimConfig {
            heads,
            offsets_arcsec: None,
            offset_sigma_arcsec: 5.0,
            positions: 36_000,
            start_deg: 0.0,
            noise_sigma_arcsec: 0.01,
            resolution_arcsec: 0.0,
            turns: 1,
            seed,
        }
    }
}

/// One head of the truth.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct TrueHead {
    /// Nominal angle φ_h, degrees.
    pub angle_deg: f64,
    /// Mounting offset δ_h, arcsec.
    pub offset_arcsec: f64,
}

/// The true a(θ) at one rotation position (shaped like a calibration result's `errors`, so
/// `gonio compare` can compare a result with the truth).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct TruePoint {
    /// Rotation position, degrees in [0, 360).
    pub position_deg: f64,
    /// a(θ) with its mean over the NS positions removed, arcsec.
    pub value_arcsec: f64,
    /// Always 0 (the truth has no uncertainty).
    pub u_arcsec: f64,
}

/// Ground truth of a simulated measurement (written as `truth.json`).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SelfcalTruth {
    /// Always [`TRUTH_FORMAT`].
    pub format: String,
    /// `truth`.
    pub method: String,
    /// Heads with their offsets.
    pub heads: Vec<TrueHead>,
    /// Positions per turn.
    pub positions: usize,
    /// Turns.
    pub turns: usize,
    /// Noise per reading, arcsec.
    pub noise_sigma_arcsec: f64,
    /// Resolution, arcsec.
    pub resolution_arcsec: f64,
    /// Seed used.
    pub seed: u64,
    /// a(θ) at every position of one turn.
    pub errors: Vec<TruePoint>,
}

/// A simulated measurement: the head differences (and raw readings) per turn, and the truth.
#[derive(Debug, Clone, PartialEq)]
pub struct SelfcalSim {
    /// D_h per turn, arcsec (what `gonio selfcal` reads by default).
    pub turns: Vec<Turn>,
    /// Raw readings per turn: `raw_deg[turn][h − 1][i]`, degrees (for `--raw`).
    pub raw_deg: Vec<Vec<Vec<f64>>>,
    /// Ground truth.
    pub truth: SelfcalTruth,
}

/// Most head readings one simulation may produce (positions × turns × heads): 50 million, about
/// 1.2 GB with the raw readings kept.
pub const MAX_VALUES: u64 = 50_000_000;

/// Simulates the measurement.
///
/// # Errors
/// [`SimError::Parameter`] for fewer than 8 positions, zero turns, more than [`MAX_VALUES`]
/// readings, a negative or non-finite σ or
/// resolution, or an offsets list whose length is not the number of heads.
pub fn simulate(encoder: &EncoderModel, cfg: &SelfcalSimConfig) -> Result<SelfcalSim, SimError> {
    let m = cfg.heads.len();
    let ns = cfg.positions;
    if ns < 8 {
        return Err(SimError::parameter("positions", ns, "at least 8"));
    }
    if cfg.turns == 0 {
        return Err(SimError::parameter("turns", 0, "at least 1"));
    }
    let values = ns as u64 * cfg.turns as u64 * m as u64;
    if values > MAX_VALUES {
        return Err(SimError::parameter(
            "positions × turns × heads",
            values,
            &format!("at most {MAX_VALUES} head readings"),
        ));
    }
    for (name, v) in [
        ("sigma", cfg.noise_sigma_arcsec),
        ("resolution", cfg.resolution_arcsec),
        ("offset_sigma", cfg.offset_sigma_arcsec),
    ] {
        if !(v >= 0.0 && v.is_finite()) {
            return Err(SimError::parameter(name, v, "a finite value ≥ 0 (arcsec)"));
        }
    }
    if !cfg.start_deg.is_finite() {
        return Err(SimError::parameter(
            "start",
            cfg.start_deg,
            "a finite angle",
        ));
    }
    let offsets: Vec<f64> = match &cfg.offsets_arcsec {
        Some(o) => {
            if o.len() != m {
                return Err(SimError::parameter(
                    "offsets_arcsec",
                    format!("{} values", o.len()),
                    &format!("one per head ({m})"),
                ));
            }
            if let Some(x) = o.iter().find(|x| !x.is_finite()) {
                return Err(SimError::parameter("offsets_arcsec", x, "finite values"));
            }
            let mut o = o.clone();
            o[0] = 0.0;
            o
        }
        None => {
            let mut r = crate::rng_stream(cfg.seed, 1);
            let n = Normal::new(0.0, cfg.offset_sigma_arcsec).expect("sigma checked");
            let mut o: Vec<f64> = (0..m).map(|_| n.sample(&mut r)).collect();
            o[0] = 0.0;
            o
        }
    };
    let noise = Normal::new(0.0, cfg.noise_sigma_arcsec).expect("sigma checked");
    let mut r_noise = crate::rng_stream(cfg.seed, 2);
    let step = 360.0 / ns as f64;
    let positions_deg: Vec<f64> = (0..ns)
        .map(|i| Degrees(cfg.start_deg + i as f64 * step).normalized().0)
        .collect();
    let phi = cfg.heads.angles_deg();
    // Noise-free scale error under each head (the same every turn), arcsec.
    let scale: Vec<Vec<f64>> = (0..m)
        .map(|h| {
            positions_deg
                .iter()
                .map(|&t| {
                    encoder
                        .error_at(Degrees(t + phi[h] + offsets[h] / 3600.0))
                        .0
                })
                .collect()
        })
        .collect();
    let quant = |x: f64| {
        if cfg.resolution_arcsec > 0.0 {
            (x / cfg.resolution_arcsec).round() * cfg.resolution_arcsec
        } else {
            x
        }
    };
    let mut turns = Vec::with_capacity(cfg.turns);
    let mut raw_all = Vec::with_capacity(cfg.turns);
    for _ in 0..cfg.turns {
        // Readings in arcsec (absolute), quantised, head-major.
        let mut reading = vec![vec![0.0; ns]; m];
        for (i, &t) in positions_deg.iter().enumerate() {
            for h in 0..m {
                let x =
                    (t + phi[h]) * 3600.0 + offsets[h] + scale[h][i] + noise.sample(&mut r_noise);
                reading[h][i] = quant(x);
            }
        }
        let differences_arcsec = (1..m)
            .map(|h| {
                (0..ns)
                    .map(|i| reading[h][i] - reading[0][i] - phi[h] * 3600.0)
                    .collect()
            })
            .collect();
        turns.push(Turn {
            positions_deg: positions_deg.clone(),
            differences_arcsec,
        });
        raw_all.push(
            reading
                .iter()
                .map(|col| col.iter().map(|x| x / 3600.0).collect())
                .collect(),
        );
    }
    let mut truth_vals = scale[0].clone();
    gonio_core::closure::remove_mean(&mut truth_vals);
    let truth = SelfcalTruth {
        format: TRUTH_FORMAT.to_string(),
        method: "truth".to_string(),
        heads: phi
            .iter()
            .zip(&offsets)
            .map(|(&angle_deg, &offset_arcsec)| TrueHead {
                angle_deg,
                offset_arcsec,
            })
            .collect(),
        positions: ns,
        turns: cfg.turns,
        noise_sigma_arcsec: cfg.noise_sigma_arcsec,
        resolution_arcsec: cfg.resolution_arcsec,
        seed: cfg.seed,
        errors: positions_deg
            .iter()
            .zip(&truth_vals)
            .map(|(&position_deg, &value_arcsec)| TruePoint {
                position_deg,
                value_arcsec,
                u_arcsec: 0.0,
            })
            .collect(),
    };
    Ok(SelfcalSim {
        turns,
        raw_deg: raw_all,
        truth,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn same_seed_same_bytes_and_model_holds() {
        let enc = EncoderModel::default_with_seed(2);
        let cfg = SelfcalSimConfig {
            positions: 72,
            turns: 2,
            ..SelfcalSimConfig::new(Heads::preset("eda:3").unwrap(), 9)
        };
        let a = simulate(&enc, &cfg).unwrap();
        let b = simulate(&enc, &cfg).unwrap();
        assert_eq!(a, b);
        assert_ne!(a.turns[0], a.turns[1]);
        // Noise-free: D_h = a(θ+φ_h+δ_h) − a(θ) + δ_h exactly.
        let cfg0 = SelfcalSimConfig {
            noise_sigma_arcsec: 0.0,
            ..cfg.clone()
        };
        let s = simulate(&enc, &cfg0).unwrap();
        let d = s.truth.heads[1].offset_arcsec;
        let t = s.turns[0].positions_deg[5];
        let want = enc.error_at(Degrees(t + 120.0 + d / 3600.0)).0 - enc.error_at(Degrees(t)).0 + d;
        assert!((s.turns[0].differences_arcsec[0][5] - want).abs() < 1e-8);
        assert!(
            simulate(
                &enc,
                &SelfcalSimConfig {
                    turns: 0,
                    ..cfg.clone()
                }
            )
            .is_err()
        );
        assert!(
            simulate(
                &enc,
                &SelfcalSimConfig {
                    offsets_arcsec: Some(vec![0.0]),
                    ..cfg
                }
            )
            .is_err()
        );
    }
}
