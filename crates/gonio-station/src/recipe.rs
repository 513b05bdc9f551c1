//! Recipes: the settings of one grating type (ring, optics, measurement, focus, push limits),
//! read from TOML.
//!
//! Every key is optional (defaults are the seed's station); an unknown key is an error naming
//! its line and column, so a typo never silently falls back to a default.
//!
//! ```
//! use gonio_station::Recipe;
//! let r = Recipe::from_toml("name = \"R40\"\nthreshold_um = 4.0\n[push]\nmax_pushes = 6\n").unwrap();
//! assert_eq!(r.push.max_pushes, 6);
//! assert!(Recipe::from_toml("treshold_um = 4.0").unwrap_err().to_string().starts_with("line 1"));
//! ```

use crate::StationError;
use crate::fit::FitOptions;
use serde::{Deserialize, Serialize};

/// One grating type's settings.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Recipe {
    /// The recipe's name (written into every part record).
    pub name: String,
    /// Radius of the alignment ring, mm.
    pub ring_radius_mm: f64,
    /// Width of the alignment ring, µm.
    pub ring_width_um: f64,
    /// Pixel scale on the grating, µm per px (seed: 4.5 µm pixels, 6× lens → 0.75).
    pub um_per_px: f64,
    /// Processing window, px (width, height).
    pub window_px: [u32; 2],
    /// Accept the part when e is below this, µm.
    pub threshold_um: f64,
    /// Reject the part when it has taken longer than this, s.
    pub timeout_s: f64,
    /// The measuring turn.
    pub measure: MeasureSettings,
    /// Autofocus.
    pub focus: FocusSettings,
    /// Pushing.
    pub push: PushSettings,
    /// The least-squares fit's settings (the method itself comes from the strategy).
    pub fit: FitOptions,
}

/// The measuring turn.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct MeasureSettings {
    /// Servo speed during the turn, °/s.
    pub speed_deg_per_s: f64,
    /// Camera frame rate, frames per second.
    pub fps: f64,
    /// Exposure, s.
    pub exposure_s: f64,
    /// Angle covered by one measurement, degrees.
    pub turn_deg: f64,
    /// Reject (ring lost) when fewer than this fraction of a turn's frames have a valid ring.
    pub min_valid_fraction: f64,
}

/// Autofocus: one sweep, then a peak fit on the detector's focus measure.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct FocusSettings {
    /// Half-range of the sweep around the nominal position, µm.
    pub range_um: f64,
    /// Number of positions in the sweep (≥ 5).
    pub steps: usize,
    /// Nominal focus position, µm.
    pub nominal_um: f64,
    /// Focus failure when the best measure is below this.
    pub min_measure: f64,
    /// Focus failure when best/median of the sweep is below this (no peak).
    pub min_contrast: f64,
}

/// Pushing.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct PushSettings {
    /// Reject after this many pushes.
    pub max_pushes: u32,
    /// Largest single push, µm.
    pub max_push_um: f64,
    /// Approach slowly (smaller overshoot) when e is below this, µm (strategies with a push
    /// model only).
    pub slow_contact_below_um: f64,
    /// Expected overshoot on fast contact, µm (push model).
    pub overshoot_fast_um: f64,
    /// Expected overshoot on slow contact, µm (push model).
    pub overshoot_slow_um: f64,
    /// Expected stick-slip at the start of a push, µm (push model).
    pub slip_um: f64,
    /// Expected spring-back, as a fraction of the move (push model).
    pub spring_back: f64,
    /// Stop live-feedback pushing when the remaining distance is below this, µm.
    pub live_tolerance_um: f64,
    /// Frames averaged per live-feedback reading.
    pub live_frames: usize,
}

impl Default for Recipe {
    fn default() -> Self {
        Recipe {
            name: "default".into(),
            ring_radius_mm: 20.0,
            ring_width_um: 8.0,
            um_per_px: 0.75,
            window_px: [1440, 540],
            threshold_um: 5.0,
            timeout_s: 150.0,
            measure: MeasureSettings::default(),
            focus: FocusSettings::default(),
            push: PushSettings::default(),
            fit: FitOptions::default(),
        }
    }
}

impl Default for MeasureSettings {
    fn default() -> Self {
        MeasureSettings {
            speed_deg_per_s: 180.0,
            fps: 100.0,
            exposure_s: 0.5e-3,
            turn_deg: 360.0,
            min_valid_fraction: 0.5,
        }
    }
}

impl Default for FocusSettings {
    fn default() -> Self {
        FocusSettings {
            range_um: 150.0,
            steps: 19,
            nominal_um: 0.0,
            min_measure: 1.0,
            min_contrast: 1.2,
        }
    }
}

impl Default for PushSettings {
    fn default() -> Self {
        PushSettings {
            max_pushes: 10,
            max_push_um: 600.0,
            slow_contact_below_um: 15.0,
            // |N(0, 3 µm)| has mean 3·√(2/π) ≈ 2.39 µm; |N(0, 0.5 µm)| ≈ 0.40 µm.
            overshoot_fast_um: 2.39,
            overshoot_slow_um: 0.40,
            slip_um: 0.75,
            spring_back: 0.015,
            live_tolerance_um: 0.3,
            live_frames: 3,
        }
    }
}

/// 1-based line and column of a byte offset in `text`.
fn line_col(text: &str, offset: usize) -> (usize, usize) {
    let before = &text[..offset.min(text.len())];
    let line = before.matches('\n').count() + 1;
    let col = before
        .rfind('\n')
        .map_or(before.len(), |p| before.len() - p - 1)
        + 1;
    (line, col)
}

impl Recipe {
    /// Parses a recipe from TOML text.
    ///
    /// # Errors
    /// [`StationError::Recipe`] with the line and column of a syntax error, an unknown key or a
    /// value of the wrong type or range.
    pub fn from_toml(text: &str) -> Result<Recipe, StationError> {
        let r: Recipe = toml::from_str(text).map_err(|e| {
            let (line, column) = e.span().map_or((1, 1), |s| line_col(text, s.start));
            StationError::Recipe {
                line,
                column,
                message: e.message().trim().replace('\n', " "),
            }
        })?;
        r.validate()?;
        Ok(r)
    }

    /// Writes the recipe as TOML.
    pub fn to_toml(&self) -> String {
        toml::to_string(self).unwrap_or_default()
    }

    /// Checks the ranges of the values.
    ///
    /// # Errors
    /// [`StationError::Recipe`] (line 0) naming the key and the allowed range.
    pub fn validate(&self) -> Result<(), StationError> {
        let pos = |name: &str, v: f64| -> Result<(), StationError> {
            if v.is_finite() && v > 0.0 {
                Ok(())
            } else {
                Err(StationError::Recipe {
                    line: 0,
                    column: 0,
                    message: format!("{name} = {v}: expected a finite number > 0"),
                })
            }
        };
        pos("um_per_px", self.um_per_px)?;
        pos("threshold_um", self.threshold_um)?;
        pos("timeout_s", self.timeout_s)?;
        pos("ring_radius_mm", self.ring_radius_mm)?;
        pos("ring_width_um", self.ring_width_um)?;
        pos("measure.speed_deg_per_s", self.measure.speed_deg_per_s)?;
        pos("measure.fps", self.measure.fps)?;
        pos("measure.exposure_s", self.measure.exposure_s)?;
        pos("measure.turn_deg", self.measure.turn_deg)?;
        pos("push.max_push_um", self.push.max_push_um)?;
        pos("push.live_tolerance_um", self.push.live_tolerance_um)?;
        if self.focus.steps < 5 || self.push.live_frames == 0 {
            return Err(StationError::Recipe {
                line: 0,
                column: 0,
                message: "focus.steps must be ≥ 5 and push.live_frames ≥ 1".into(),
            });
        }
        if !(0.0..=1.0).contains(&self.measure.min_valid_fraction) {
            return Err(StationError::Recipe {
                line: 0,
                column: 0,
                message: format!(
                    "measure.min_valid_fraction = {}: expected 0 to 1",
                    self.measure.min_valid_fraction
                ),
            });
        }
        Ok(())
    }

    /// Frames in one measuring turn.
    pub fn frames_per_turn(&self) -> usize {
        (self.measure.turn_deg / self.measure.speed_deg_per_s * self.measure.fps).round() as usize
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn unknown_key_names_its_line() {
        let e = Recipe::from_toml("name = \"x\"\n\n[push]\nmax_pushes = 3\nmax_pusehs = 4\n")
            .unwrap_err();
        match e {
            StationError::Recipe { line, column, .. } => assert_eq!((line, column), (5, 1)),
            other => panic!("{other:?}"),
        }
    }

    #[test]
    fn round_trips_and_defaults() {
        let r = Recipe::default();
        assert_eq!(Recipe::from_toml(&r.to_toml()).unwrap(), r);
        assert_eq!(r.frames_per_turn(), 200);
    }
}
