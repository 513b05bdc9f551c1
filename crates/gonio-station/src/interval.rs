//! Angle stamping from the servo's angle log and the frame-interval error (Yu et al., 2024, Eq.
//! 3–5).
//!
//! The servo's angle is logged every millisecond. A frame integrates the ring over its exposure,
//! so its angle is the servo angle at mid-exposure, interpolated linearly between the two log
//! samples around it ([`Stamping::MidExposure`]). The seed latches the last logged sample instead
//! ([`Stamping::Latched`]), which lags by up to one log period (≈ 0.09° on average at 180°/s).
//!
//! Between two frames the grating turns by `γ = v/FPS`; the seed bounds the resulting error of e
//! by `ε = e·(1 − cos γ)` ([`frame_interval_error_um`]).
//!
//! ```
//! use gonio_station::interval::{frame_interval_error_um, max_speed_deg_per_s};
//! let eps = frame_interval_error_um(500.0, 180.0, 100.0);
//! assert!((eps - 0.2467).abs() < 1e-4); // seed: 0.25 µm
//! let v = max_speed_deg_per_s(500.0, 0.1, 100.0).unwrap();
//! assert!((frame_interval_error_um(500.0, v, 100.0) - 0.1).abs() < 1e-9);
//! ```

use crate::StationError;
use serde::{Deserialize, Serialize};

/// One servo angle log entry.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct AngleSample {
    /// Time, s.
    pub t_s: f64,
    /// Servo angle (unwrapped, continuous over the turn), degrees.
    pub theta_deg: f64,
}

/// How a frame's angle is taken from the angle log.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Stamping {
    /// Linear interpolation at mid-exposure (default).
    #[default]
    MidExposure,
    /// The last logged sample at or before mid-exposure (the seed's latch).
    Latched,
}

/// The servo's angle log: samples in increasing time.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct AngleLog {
    /// The samples, increasing in time.
    pub samples: Vec<AngleSample>,
}

impl AngleLog {
    /// The log from its samples.
    ///
    /// # Errors
    /// [`StationError::NotFinite`], [`StationError::NotIncreasing`] (times not increasing),
    /// [`StationError::TooFewSamples`] for fewer than 2 samples.
    pub fn new(samples: Vec<AngleSample>) -> Result<Self, StationError> {
        if samples.len() < 2 {
            return Err(StationError::TooFewSamples {
                expected: 2,
                found: samples.len(),
            });
        }
        for (i, s) in samples.iter().enumerate() {
            if !s.t_s.is_finite() || !s.theta_deg.is_finite() {
                return Err(StationError::NotFinite {
                    index: i,
                    what: if s.t_s.is_finite() {
                        "theta_deg"
                    } else {
                        "t_s"
                    },
                    value: if s.t_s.is_finite() {
                        s.theta_deg
                    } else {
                        s.t_s
                    },
                });
            }
            if i > 0 && s.t_s <= samples[i - 1].t_s {
                return Err(StationError::NotIncreasing {
                    index: i,
                    previous_deg: samples[i - 1].t_s,
                    found_deg: s.t_s,
                });
            }
        }
        Ok(AngleLog { samples })
    }

    fn outside(&self, t_s: f64) -> StationError {
        StationError::OutsideAngleLog {
            t_s,
            first_s: self.samples.first().map_or(f64::NAN, |s| s.t_s),
            last_s: self.samples.last().map_or(f64::NAN, |s| s.t_s),
        }
    }

    /// The angle at time `t_s` by linear interpolation.
    ///
    /// # Errors
    /// [`StationError::OutsideAngleLog`] when `t_s` is outside the log.
    pub fn interpolate(&self, t_s: f64) -> Result<f64, StationError> {
        let s = &self.samples;
        if s.len() < 2 || !(t_s >= s[0].t_s && t_s <= s[s.len() - 1].t_s) {
            return Err(self.outside(t_s));
        }
        let p = s.partition_point(|a| a.t_s <= t_s).clamp(1, s.len() - 1);
        let (a, b) = (s[p - 1], s[p]);
        let f = (t_s - a.t_s) / (b.t_s - a.t_s);
        Ok(a.theta_deg + f * (b.theta_deg - a.theta_deg))
    }

    /// The last logged angle at or before `t_s`.
    ///
    /// # Errors
    /// [`StationError::OutsideAngleLog`] when `t_s` is before the log.
    pub fn latched(&self, t_s: f64) -> Result<f64, StationError> {
        let p = self.samples.partition_point(|a| a.t_s <= t_s);
        if p == 0 || !t_s.is_finite() {
            return Err(self.outside(t_s));
        }
        Ok(self.samples[p - 1].theta_deg)
    }

    /// A frame's angle for an exposure starting at `start_s` and lasting `exposure_s`.
    ///
    /// # Errors
    /// [`StationError::OutsideAngleLog`].
    pub fn stamp(&self, start_s: f64, exposure_s: f64, how: Stamping) -> Result<f64, StationError> {
        let mid = start_s + 0.5 * exposure_s;
        match how {
            Stamping::MidExposure => self.interpolate(mid),
            Stamping::Latched => self.latched(mid),
        }
    }
}

/// The seed's frame-interval error `ε = e·(1 − cos(v/FPS))`, µm, for eccentricity `e_um`, speed
/// `speed_deg_per_s` and frame rate `fps`.
pub fn frame_interval_error_um(e_um: f64, speed_deg_per_s: f64, fps: f64) -> f64 {
    e_um * (1.0 - (speed_deg_per_s / fps).to_radians().cos())
}

/// The highest speed (°/s) that keeps the frame-interval error of an eccentricity `e_um` below
/// `target_um` at `fps` frames per second: `v = FPS·acos(1 − ε/e)`.
///
/// # Errors
/// [`StationError::OutOfRange`] for a non-positive or non-finite argument.
pub fn max_speed_deg_per_s(e_um: f64, target_um: f64, fps: f64) -> Result<f64, StationError> {
    for (name, v) in [("e_um", e_um), ("target_um", target_um), ("fps", fps)] {
        if !(v.is_finite() && v > 0.0) {
            return Err(StationError::OutOfRange {
                name,
                value: v,
                expected: "a finite number > 0",
            });
        }
    }
    let ratio = (1.0 - target_um / e_um).max(-1.0);
    Ok(fps * ratio.acos().to_degrees())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn epsilon_matches_the_seed() {
        // Yu et al., 2024, §3: e = 500 µm, 180°/s, 100 fps → ε ≈ 0.25 µm.
        let eps = frame_interval_error_um(500.0, 180.0, 100.0);
        assert!((eps - 0.25).abs() < 0.005, "{eps}");
    }

    #[test]
    fn stamping_interpolates_and_latches() {
        let log = AngleLog::new(
            (0..10)
                .map(|i| AngleSample {
                    t_s: i as f64 * 1e-3,
                    theta_deg: 0.18 * i as f64,
                })
                .collect(),
        )
        .unwrap();
        let mid = log.stamp(2.3e-3, 0.5e-3, Stamping::MidExposure).unwrap();
        assert!((mid - 0.18 * 2.55).abs() < 1e-12);
        let lat = log.stamp(2.3e-3, 0.5e-3, Stamping::Latched).unwrap();
        assert!((lat - 0.36).abs() < 1e-12);
        assert!(log.interpolate(0.02).is_err());
    }
}
