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
use crate::quality::{QualityLimits, QualitySettings};
use gonio_core::bound::Bound;
use serde::{Deserialize, Serialize};

/// One grating type's settings.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Recipe {
    /// The recipe's name (written into every part record).
    pub name: String,
    /// Radius of the alignment ring, mm: the detector's optics (`Recipe::optics`) and the chord
    /// correction of a carried roundness ([`crate::ring`]).
    pub ring_radius_mm: f64,
    /// Width of the alignment ring, µm.
    pub ring_width_um: f64,
    /// Pixel scale on the grating, µm per px (seed: 4.5 µm pixels, 6× lens → 0.75).
    pub um_per_px: f64,
    /// Processing window, px (width, height): the camera's window and the detector's, centred
    /// on the sensor. Its height sets the camera's frame rate (`measure.camera_line_time_us`);
    /// the ring crosses every row, so fewer rows cost the detector only its averaging
    /// (`docs/station-timing.md`).
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
    /// The quality gate on every turn ([`crate::quality`]).
    pub quality: QualitySettings,
    /// What the learning strategies learn from each push, and within which bounds.
    pub learn: LearnSettings,
    /// What a batch does after a device error ends a part.
    pub on_device_error: DeviceErrorPolicy,
}

/// What a batch does after a device error ends a part (the part is recorded as
/// `rejected_device_error` either way).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum DeviceErrorPolicy {
    /// Stop the batch after the part (default: a station with a failing device stops safely).
    #[default]
    Stop,
    /// Go on with the next part.
    Continue,
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
    /// Angle covered by a verify turn, degrees, fitted with the ring's roundness carried from
    /// the part's trusted turn of `turn_deg` (`docs/station-timing.md`); at least
    /// 360° − `quality.max_gap_carried_roundness_deg` (a shorter turn fails the gate's largest
    /// gap). A verify turn covers `turn_deg` when this is not shorter, or without a carried
    /// roundness (the paper's fit), and so does a re-measurement.
    pub verify_turn_deg: f64,
    /// Take a turn's frames from the start of the servo's ramp (their angles come from the
    /// angle log) instead of once it is at speed.
    pub frames_from_rest: bool,
    /// The servo's acceleration, °/s²: the ramp to `speed_deg_per_s` (the frames a turn from
    /// rest needs).
    pub servo_accel_deg_per_s2: f64,
    /// The camera's line time, µs: a row-by-row readout gives at most
    /// 1 / (line time · (window rows + blank lines)) frames per second.
    pub camera_line_time_us: f64,
    /// The camera's blanking between frames, in lines.
    pub camera_blank_lines: u32,
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
    /// Start from the focus the last part of this controller found and check it with a few
    /// frames around it ([`FocusSettings::check_step_um`]); a full sweep only when the check
    /// finds no peak.
    pub carry_from_last_part: bool,
    /// Spacing of the check's positions, µm.
    pub check_step_um: f64,
    /// Most positions of one check (it walks toward the peak until the best is inside), ≥ 3.
    pub check_max_points: usize,
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
    /// The live strategy pushes again while a trusted turn finds e at or above this share of
    /// `threshold_um` (spring-back is random, up to 3 % of the move, so one push from 150 µm
    /// can end near 3 µm); below the threshold a part is still accepted when the pushes or the
    /// time are used up. 1 turns it off.
    pub live_aim_fraction: f64,
    /// Frames averaged per live-feedback reading.
    pub live_frames: usize,
    /// Most live-feedback readings in one push.
    pub live_max_steps: u32,
    /// The first live step covers this share of the remaining distance (the push's gain is not
    /// known yet) …
    pub live_first_step_fraction: f64,
    /// … when the remaining distance is above this, µm.
    pub live_first_step_above_um: f64,
    /// Measure the push's gain from a live step only when it was expected to move at least
    /// this, µm.
    pub live_gain_min_move_um: f64,
    /// A live step that brings the remaining distance down by less than this is a stall, µm.
    pub live_stall_um: f64,
    /// Stop the live push after this many stalls.
    pub live_max_stalls: u32,
    /// Smallest move asked of one live step, µm (just above the rod's stiction, 1 µm).
    pub live_min_step_um: f64,
    /// Tolerance of the verify turn against the push model's prediction: this much, µm …
    pub verify_tolerance_um: f64,
    /// … plus this share of the predicted move.
    pub verify_tolerance_fraction: f64,
    /// After a measuring turn that a push follows, move the servo to the push angle straight
    /// from the turn (its stop and the align move in one motion) instead of stopping first.
    pub align_during_stop: bool,
}

/// What the learning strategies learn from each push: the push gain and the angle offset
/// between the commanded and the actual push direction.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct LearnSettings {
    /// Smallest plausible push gain: learned gains are clamped to it and gains measured below it
    /// are not learned.
    pub gain_min: f64,
    /// Largest plausible push gain (as `gain_min`).
    pub gain_max: f64,
    /// Learn the gain only from pushes commanded at least this far, µm.
    pub gain_min_push_um: f64,
    /// Learn the angle offset only from moves at least this long, µm.
    pub offset_min_move_um: f64,
    /// Learn the angle offset only from moves within this angle of the commanded direction,
    /// degrees.
    pub max_offset_deg: f64,
    /// Weight of the prior (gain 1, offset 0°) in the running means, in observations.
    pub prior_weight: f64,
}

impl Default for Recipe {
    fn default() -> Self {
        Recipe {
            name: "default".into(),
            ring_radius_mm: 20.0,
            ring_width_um: 8.0,
            um_per_px: 0.75,
            window_px: [1440, 180],
            threshold_um: 5.0,
            timeout_s: 150.0,
            measure: MeasureSettings::default(),
            focus: FocusSettings::default(),
            push: PushSettings::default(),
            fit: FitOptions::default(),
            quality: QualitySettings::default(),
            learn: LearnSettings::default(),
            on_device_error: DeviceErrorPolicy::Stop,
        }
    }
}

impl Default for LearnSettings {
    fn default() -> Self {
        LearnSettings {
            gain_min: 0.5,
            gain_max: 1.5,
            gain_min_push_um: 20.0,
            offset_min_move_um: 20.0,
            max_offset_deg: 10.0,
            prior_weight: 1.0,
        }
    }
}

impl Default for MeasureSettings {
    fn default() -> Self {
        MeasureSettings {
            // 1.8° between frames, as the seed's 180°/s at 100 fps, at the frame rate a 180-row
            // window allows (264 fps; `docs/station-timing.md`).
            speed_deg_per_s: 432.0,
            fps: 240.0,
            exposure_s: 0.5e-3,
            turn_deg: 360.0,
            min_valid_fraction: 0.5,
            verify_turn_deg: 300.0,
            frames_from_rest: true,
            // The twin's servo: 0.2 s to the seed's 180°/s.
            servo_accel_deg_per_s2: 900.0,
            // The seed's 100 fps at its 540-row window: 10 ms = 580 lines of 17.24 µs.
            camera_line_time_us: 17.24,
            camera_blank_lines: 40,
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
            carry_from_last_part: true,
            check_step_um: 25.0,
            check_max_points: 7,
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
            // 2.75 µm of the 5 µm threshold: a part accepted below it is truly under 3 µm,
            // the quality gate's largest u(e) (0.25 µm) included.
            live_aim_fraction: 0.55,
            live_frames: 3,
            live_max_steps: 60,
            live_first_step_fraction: 0.85,
            live_first_step_above_um: 10.0,
            live_gain_min_move_um: 10.0,
            live_stall_um: 0.2,
            live_max_stalls: 3,
            live_min_step_um: 1.05,
            verify_tolerance_um: VERIFY_TOLERANCE_UM,
            verify_tolerance_fraction: VERIFY_TOLERANCE_FRACTION,
            align_during_stop: true,
        }
    }
}

/// Most frames in one measuring turn (`measure.turn_deg / measure.speed_deg_per_s ·
/// measure.fps`): a turn's samples are held whole.
pub const MAX_FRAMES_PER_TURN: usize = 100_000;

/// The pixel scale on the grating ([`Recipe::um_per_px`]).
pub const UM_PER_PX: Bound = Bound::new(0.0, 1000.0, "µm/px").lo_excluded();
/// The acceptance threshold of e ([`Recipe::threshold_um`]).
pub const THRESHOLD_UM: Bound = Bound::new(0.0, 10_000.0, "µm").lo_excluded();
/// Frames one turn had, valid or not: up to [`MAX_FRAMES_PER_TURN`].
pub const FRAMES_PER_TURN: Bound = Bound::new(1.0, MAX_FRAMES_PER_TURN as f64, "frames");

/// Default absolute part of the verify-turn tolerance, µm (`docs/quality-gates.md`).
pub const VERIFY_TOLERANCE_UM: f64 = 8.0;
/// Default share of the predicted move in the verify-turn tolerance (`docs/quality-gates.md`).
pub const VERIFY_TOLERANCE_FRACTION: f64 = 0.45;

fn bad(key: &str, value: impl ToString, expected: &str) -> StationError {
    StationError::RecipeValue {
        key: key.to_string(),
        value: gonio_core::bound::tidy(&value.to_string()),
        expected: expected.to_string(),
        line: 0,
        column: 0,
    }
}

fn check(key: &str, v: f64, ok: bool, expected: &str) -> Result<(), StationError> {
    if v.is_finite() && ok {
        Ok(())
    } else {
        Err(bad(key, v, expected))
    }
}

fn pos(key: &str, v: f64) -> Result<(), StationError> {
    check(key, v, v > 0.0, "a finite number > 0")
}

fn non_neg(key: &str, v: f64) -> Result<(), StationError> {
    check(key, v, v >= 0.0, "a finite number ≥ 0")
}

fn finite(key: &str, v: f64) -> Result<(), StationError> {
    check(key, v, true, "a finite number")
}

fn unit(key: &str, v: f64) -> Result<(), StationError> {
    check(key, v, (0.0..=1.0).contains(&v), "a fraction from 0 to 1")
}

/// 1-based line and column of a dotted key (`fit.huber_k`) in a TOML text, if the text sets it
/// (used for every TOML file whose values are range-checked after parsing).
pub fn key_position(text: &str, key: &str) -> Option<(usize, usize)> {
    let doc = toml::de::DeTable::parse(text).ok()?;
    let mut table = doc.get_ref();
    let parts: Vec<&str> = key.split('.').collect();
    for (i, part) in parts.iter().enumerate() {
        let (k, v) = table.iter().find(|(k, _)| k.get_ref().as_ref() == *part)?;
        if i + 1 == parts.len() {
            return Some(line_col(text, k.span().start));
        }
        match v.get_ref() {
            toml::de::DeValue::Table(t) => table = t,
            _ => return None,
        }
    }
    None
}

use gonio_core::text::line_col;

impl Recipe {
    /// Parses a recipe from TOML text and checks its values.
    ///
    /// # Errors
    /// [`StationError::Recipe`] with the line and column of a syntax error, an unknown key or a
    /// value of the wrong type; [`StationError::RecipeValue`] with the key, its line and column
    /// for a value out of its range.
    pub fn from_toml(text: &str) -> Result<Recipe, StationError> {
        let r: Recipe = toml::from_str(text).map_err(|e| {
            let (line, column) = e.span().map_or((1, 1), |s| line_col(text, s.start));
            StationError::Recipe {
                line,
                column,
                message: e.message().trim().replace('\n', " "),
            }
        })?;
        r.validate().map_err(|e| match e {
            StationError::RecipeValue {
                key,
                value,
                expected,
                ..
            } => {
                let (line, column) = key_position(text, &key).unwrap_or((0, 0));
                StationError::RecipeValue {
                    key,
                    value,
                    expected,
                    line,
                    column,
                }
            }
            other => other,
        })?;
        Ok(r)
    }

    /// The sequence of the published station (Yu et al., 2024), for comparison: the seed's
    /// 540-row window at 100 fps and 180°/s, every turn a full turn started at speed, a focus
    /// sweep for every part, a stop before each align (`docs/station-timing.md`). Everything
    /// else is the default.
    pub fn published() -> Recipe {
        let d = Recipe::default();
        Recipe {
            name: "published".into(),
            window_px: [1440, 540],
            measure: MeasureSettings {
                speed_deg_per_s: 180.0,
                fps: 100.0,
                verify_turn_deg: d.measure.turn_deg,
                frames_from_rest: false,
                ..d.measure
            },
            focus: FocusSettings {
                carry_from_last_part: false,
                ..d.focus
            },
            push: PushSettings {
                align_during_stop: false,
                ..d.push
            },
            ..d
        }
    }

    /// Writes the recipe as TOML.
    pub fn to_toml(&self) -> String {
        toml::to_string(self).unwrap_or_default()
    }

    /// Checks the ranges of the values (and that they fit together).
    ///
    /// # Errors
    /// [`StationError::RecipeValue`] (line 0) naming the first key out of range and what is
    /// allowed.
    pub fn validate(&self) -> Result<(), StationError> {
        let m = &self.measure;
        let f = &self.focus;
        let p = &self.push;
        let q = &self.quality;
        let l = &self.learn;
        pos("um_per_px", self.um_per_px)?;
        pos("threshold_um", self.threshold_um)?;
        pos("timeout_s", self.timeout_s)?;
        pos("ring_radius_mm", self.ring_radius_mm)?;
        pos("ring_width_um", self.ring_width_um)?;
        if self.window_px.contains(&0) || self.window_px.iter().any(|&v| v > 32768) {
            return Err(bad(
                "window_px",
                format!("{:?}", self.window_px),
                "two sizes (width, height) from 1 to 32768 px",
            ));
        }
        pos("measure.speed_deg_per_s", m.speed_deg_per_s)?;
        pos("measure.fps", m.fps)?;
        pos("measure.exposure_s", m.exposure_s)?;
        if m.exposure_s > 1.0 / m.fps {
            return Err(bad(
                "measure.exposure_s",
                m.exposure_s,
                "no longer than one frame period (1/fps)",
            ));
        }
        pos("measure.turn_deg", m.turn_deg)?;
        if m.turn_deg > 720.0 {
            return Err(bad("measure.turn_deg", m.turn_deg, "at most 720°"));
        }
        unit("measure.min_valid_fraction", m.min_valid_fraction)?;
        self.validate_timing()?;
        // Sizes: each of these counts allocates or loops per part (limits far above real use).
        let turn_frames = m.turn_deg.max(m.verify_turn_deg) / m.speed_deg_per_s * m.fps
            + if m.frames_from_rest {
                0.5 * m.speed_deg_per_s / m.servo_accel_deg_per_s2 * m.fps
            } else {
                0.0
            };
        if turn_frames.is_nan() || turn_frames > MAX_FRAMES_PER_TURN as f64 {
            return Err(bad(
                "measure.fps",
                m.fps,
                "at most 100000 frames per turn (turn_deg / speed_deg_per_s · fps, and the ramp's)",
            ));
        }
        for (key, v, max) in [
            ("focus.steps", f.steps as u64, 1000),
            ("push.max_pushes", u64::from(p.max_pushes), 1000),
            ("push.live_frames", p.live_frames as u64, 1000),
            ("push.live_max_steps", u64::from(p.live_max_steps), 100_000),
            (
                "push.live_max_stalls",
                u64::from(p.live_max_stalls),
                100_000,
            ),
            (
                "quality.remeasure_turns",
                u64::from(self.quality.remeasure_turns),
                100,
            ),
        ] {
            if v > max {
                return Err(bad(key, v, &format!("at most {max}")));
            }
        }
        if self.frames_per_turn() < 10 {
            return Err(bad(
                "measure.fps",
                m.fps,
                "at least 10 frames per turn (turn_deg / speed_deg_per_s · fps)",
            ));
        }
        pos("focus.range_um", f.range_um)?;
        if f.steps < 5 {
            return Err(bad("focus.steps", f.steps, "at least 5"));
        }
        finite("focus.nominal_um", f.nominal_um)?;
        if !(f.check_step_um.is_finite() && f.check_step_um > 0.0 && f.check_step_um <= f.range_um)
        {
            return Err(bad(
                "focus.check_step_um",
                f.check_step_um,
                &format!("above 0, at most focus.range_um ({} µm)", f.range_um),
            ));
        }
        if !(3..=1000).contains(&f.check_max_points) {
            return Err(bad(
                "focus.check_max_points",
                f.check_max_points,
                "from 3 to 1000",
            ));
        }
        non_neg("focus.min_measure", f.min_measure)?;
        pos("focus.min_contrast", f.min_contrast)?;
        pos("push.max_push_um", p.max_push_um)?;
        non_neg("push.slow_contact_below_um", p.slow_contact_below_um)?;
        non_neg("push.overshoot_fast_um", p.overshoot_fast_um)?;
        non_neg("push.overshoot_slow_um", p.overshoot_slow_um)?;
        non_neg("push.slip_um", p.slip_um)?;
        if !(0.0..1.0).contains(&p.spring_back) {
            return Err(bad("push.spring_back", p.spring_back, "0 to below 1"));
        }
        pos("push.live_tolerance_um", p.live_tolerance_um)?;
        if !(p.live_aim_fraction > 0.0 && p.live_aim_fraction <= 1.0) {
            return Err(bad(
                "push.live_aim_fraction",
                p.live_aim_fraction,
                "above 0, at most 1",
            ));
        }
        if p.live_frames == 0 {
            return Err(bad("push.live_frames", 0, "at least 1"));
        }
        if p.live_max_steps == 0 {
            return Err(bad("push.live_max_steps", 0, "at least 1"));
        }
        if !(p.live_first_step_fraction > 0.0 && p.live_first_step_fraction <= 1.0) {
            return Err(bad(
                "push.live_first_step_fraction",
                p.live_first_step_fraction,
                "above 0, at most 1",
            ));
        }
        non_neg("push.live_first_step_above_um", p.live_first_step_above_um)?;
        non_neg("push.live_gain_min_move_um", p.live_gain_min_move_um)?;
        non_neg("push.live_stall_um", p.live_stall_um)?;
        if p.live_max_stalls == 0 {
            return Err(bad("push.live_max_stalls", 0, "at least 1"));
        }
        pos("push.live_min_step_um", p.live_min_step_um)?;
        non_neg("push.verify_tolerance_um", p.verify_tolerance_um)?;
        non_neg(
            "push.verify_tolerance_fraction",
            p.verify_tolerance_fraction,
        )?;
        // Lengths and times a station can have, far above real use: beyond them the twin's
        // random draws and the renderer's sizes stop being meaningful (a focus sweep of 1e160 µm).
        for (key, v, max, what) in [
            (
                "um_per_px",
                self.um_per_px,
                1000.0,
                "at most 1000 µm per px",
            ),
            (
                "threshold_um",
                self.threshold_um,
                10_000.0,
                "at most 10000 µm",
            ),
            (
                "timeout_s",
                self.timeout_s,
                86_400.0,
                "at most 86400 s (a day)",
            ),
            (
                "ring_radius_mm",
                self.ring_radius_mm,
                1000.0,
                "at most 1000 mm",
            ),
            (
                "ring_width_um",
                self.ring_width_um,
                10_000.0,
                "at most 10000 µm",
            ),
            (
                "focus.range_um",
                f.range_um,
                10_000.0,
                "at most 10000 µm (±10 mm of focus travel)",
            ),
            (
                "focus.nominal_um",
                f.nominal_um.abs(),
                10_000.0,
                "within ±10000 µm",
            ),
            (
                "push.max_push_um",
                p.max_push_um,
                10_000.0,
                "at most 10000 µm",
            ),
            (
                "push.slow_contact_below_um",
                p.slow_contact_below_um,
                10_000.0,
                "at most 10000 µm",
            ),
            (
                "push.overshoot_fast_um",
                p.overshoot_fast_um,
                1000.0,
                "at most 1000 µm",
            ),
            (
                "push.overshoot_slow_um",
                p.overshoot_slow_um,
                1000.0,
                "at most 1000 µm",
            ),
            ("push.slip_um", p.slip_um, 1000.0, "at most 1000 µm"),
            (
                "push.live_tolerance_um",
                p.live_tolerance_um,
                10_000.0,
                "at most 10000 µm",
            ),
            (
                "push.live_min_step_um",
                p.live_min_step_um,
                10_000.0,
                "at most 10000 µm",
            ),
        ] {
            if v > max {
                let shown = if key == "focus.nominal_um" {
                    f.nominal_um
                } else {
                    v
                };
                return Err(bad(key, shown, what));
            }
        }
        self.fit.validate(None).map_err(|e| match e {
            StationError::OutOfRange {
                name,
                value,
                expected,
            } => {
                let value = if name == "roundness_orders" {
                    format!("{:?}", self.fit.roundness_orders)
                } else {
                    value.to_string()
                };
                bad(&format!("fit.{name}"), value, expected)
            }
            other => other,
        })?;
        if 2 * self.fit.paper_half_window + 1 > self.frames_per_turn() {
            return Err(bad(
                "fit.paper_half_window",
                self.fit.paper_half_window,
                "a spline window (2·half + 1 points) no larger than the frames of one turn",
            ));
        }
        pos("quality.detector_accuracy_px", q.detector_accuracy_px)?;
        pos("quality.frame_noise_px", q.frame_noise_px)?;
        if let Some(v) = q.max_residual_rms_px {
            pos("quality.max_residual_rms_px", v)?;
        }
        if let Some(v) = q.min_coverage {
            unit("quality.min_coverage", v)?;
        }
        if !(q.max_gap_deg > 0.0 && q.max_gap_deg <= 360.0) {
            return Err(bad(
                "quality.max_gap_deg",
                q.max_gap_deg,
                "above 0°, at most 360°",
            ));
        }
        unit("quality.min_used_fraction", q.min_used_fraction)?;
        unit("quality.max_outlier_fraction", q.max_outlier_fraction)?;
        pos("quality.max_u_e_fraction", q.max_u_e_fraction)?;
        pos("quality.max_half_turn_z", q.max_half_turn_z)?;
        pos("learn.gain_min", l.gain_min)?;
        pos("learn.gain_max", l.gain_max)?;
        if l.gain_max <= l.gain_min {
            return Err(bad("learn.gain_max", l.gain_max, "above learn.gain_min"));
        }
        non_neg("learn.gain_min_push_um", l.gain_min_push_um)?;
        non_neg("learn.offset_min_move_um", l.offset_min_move_um)?;
        if !(l.max_offset_deg > 0.0 && l.max_offset_deg < 90.0) {
            return Err(bad(
                "learn.max_offset_deg",
                l.max_offset_deg,
                "above 0°, below 90°",
            ));
        }
        pos("learn.prior_weight", l.prior_weight)?;
        // The settings above that have no natural end get one, far above real use.
        let um = Bound::new(0.0, 10_000.0, "µm");
        let ratio = Bound::new(0.0, 1000.0, "");
        for (key, v, bound) in [
            (
                "measure.speed_deg_per_s",
                m.speed_deg_per_s,
                Bound::new(0.0, 1e6, "°/s"),
            ),
            ("measure.fps", m.fps, Bound::new(0.0, 1e6, "frames/s")),
            ("focus.min_measure", f.min_measure, Bound::new(0.0, 1e6, "")),
            ("focus.min_contrast", f.min_contrast, ratio),
            (
                "push.live_first_step_above_um",
                p.live_first_step_above_um,
                um,
            ),
            ("push.live_gain_min_move_um", p.live_gain_min_move_um, um),
            ("push.live_stall_um", p.live_stall_um, um),
            ("push.verify_tolerance_um", p.verify_tolerance_um, um),
            (
                "push.verify_tolerance_fraction",
                p.verify_tolerance_fraction,
                ratio,
            ),
            (
                "quality.detector_accuracy_px",
                q.detector_accuracy_px,
                Bound::new(0.0, 1000.0, "px"),
            ),
            (
                "quality.frame_noise_px",
                q.frame_noise_px,
                Bound::new(0.0, 1000.0, "px"),
            ),
            (
                "quality.max_residual_rms_px",
                q.max_residual_rms_px.unwrap_or(1.0),
                Bound::new(0.0, 1000.0, "px"),
            ),
            ("quality.max_u_e_fraction", q.max_u_e_fraction, ratio),
            ("quality.max_half_turn_z", q.max_half_turn_z, ratio),
            ("learn.gain_min", l.gain_min, ratio),
            ("learn.gain_max", l.gain_max, ratio),
            ("learn.gain_min_push_um", l.gain_min_push_um, um),
            ("learn.offset_min_move_um", l.offset_min_move_um, um),
            (
                "learn.prior_weight",
                l.prior_weight,
                Bound::new(0.0, 1e6, ""),
            ),
        ] {
            if let Err(e) = bound.check(v) {
                return Err(bad(key, v, &e.to_string()));
            }
        }
        Ok(())
    }

    /// The sequence's timing settings: the verify turn, the servo's ramp, the camera's frame
    /// rate against its window; each bound named in its error.
    fn validate_timing(&self) -> Result<(), StationError> {
        let m = &self.measure;
        let gap = self.quality.max_gap_carried_roundness_deg;
        if !(gap > 0.0 && gap <= 360.0) {
            return Err(bad(
                "quality.max_gap_carried_roundness_deg",
                gap,
                "above 0°, at most 360°",
            ));
        }
        let shortest = 360.0 - gap;
        if !(m.verify_turn_deg.is_finite()
            && m.verify_turn_deg > shortest
            && m.verify_turn_deg <= 720.0)
        {
            return Err(bad(
                "measure.verify_turn_deg",
                m.verify_turn_deg,
                &format!(
                    "above {shortest}° (360° − quality.max_gap_carried_roundness_deg: a shorter verify turn fails the quality gate's largest gap), at most 720°"
                ),
            ));
        }
        if !(m.servo_accel_deg_per_s2.is_finite()
            && m.servo_accel_deg_per_s2 >= 1.0
            && m.servo_accel_deg_per_s2 <= 1.0e6)
        {
            return Err(bad(
                "measure.servo_accel_deg_per_s2",
                m.servo_accel_deg_per_s2,
                "from 1 to 1000000 °/s²",
            ));
        }
        if !(m.camera_line_time_us.is_finite()
            && m.camera_line_time_us > 0.0
            && m.camera_line_time_us <= 1000.0)
        {
            return Err(bad(
                "measure.camera_line_time_us",
                m.camera_line_time_us,
                "above 0, at most 1000 µs",
            ));
        }
        if m.camera_blank_lines > 100_000 {
            return Err(bad(
                "measure.camera_blank_lines",
                m.camera_blank_lines,
                "at most 100000 lines",
            ));
        }
        let max_fps = self.camera_max_fps();
        if m.fps > max_fps * (1.0 + 1e-9) {
            return Err(bad(
                "measure.fps",
                m.fps,
                &format!(
                    "at most {max_fps:.1} fps, the camera's frame rate for a {}-row window (1 / (measure.camera_line_time_us · (window_px[1] + measure.camera_blank_lines)))",
                    self.window_px[1]
                ),
            ));
        }
        Ok(())
    }

    /// The detector's optics for this recipe: the seed station's (`Optics::default()`) with the
    /// recipe's processing window (`window_px`, centred on the sensor) and ring radius.
    pub fn optics(&self) -> gonio_vision::Optics {
        gonio_vision::Optics {
            window_width_px: self.window_px[0],
            window_height_px: self.window_px[1],
            ring_radius_um: self.ring_radius_mm * 1000.0,
            ..gonio_vision::Optics::default()
        }
    }

    /// The ring's radius in pixels (`ring_radius_mm` at `um_per_px`).
    pub fn ring_radius_px(&self) -> f64 {
        self.ring_radius_mm * 1000.0 / self.um_per_px
    }

    /// The camera's highest frame rate for the recipe's window height, frames per second:
    /// 1 / (`measure.camera_line_time_us` · (`window_px[1]` + `measure.camera_blank_lines`)).
    /// The seed's camera: 100 fps at 540 rows, 187 fps at 270, 263.7 fps at 180.
    pub fn camera_max_fps(&self) -> f64 {
        let m = &self.measure;
        let lines = f64::from(self.window_px[1]) + f64::from(m.camera_blank_lines);
        1.0e6 / (m.camera_line_time_us * lines)
    }

    /// Frames a turn over `arc_deg` takes: at the measuring speed, from the start of the servo's
    /// ramp when `measure.frames_from_rest` (the ramp at `measure.servo_accel_deg_per_s2`
    /// covers v²/2a at half the speed).
    pub fn frames_for_arc(&self, arc_deg: f64) -> usize {
        let m = &self.measure;
        let v = m.speed_deg_per_s;
        let t = if m.frames_from_rest {
            let ramp_s = v / m.servo_accel_deg_per_s2;
            let ramp_deg = 0.5 * v * ramp_s;
            if arc_deg <= ramp_deg {
                (2.0 * arc_deg / m.servo_accel_deg_per_s2).sqrt()
            } else {
                ramp_s + (arc_deg - ramp_deg) / v
            }
        } else {
            arc_deg / v
        };
        (t * m.fps).round() as usize
    }

    /// The nominal angle a turn has covered `t_s` after it started, degrees: from rest up the
    /// ramp when `measure.frames_from_rest`, else at the measuring speed.
    pub fn nominal_turn_deg(&self, t_s: f64) -> f64 {
        let m = &self.measure;
        let v = m.speed_deg_per_s;
        if !m.frames_from_rest {
            return v * t_s;
        }
        let ramp_s = v / m.servo_accel_deg_per_s2;
        let t = t_s.max(0.0);
        if t < ramp_s {
            0.5 * m.servo_accel_deg_per_s2 * t * t
        } else {
            0.5 * v * ramp_s + v * (t - ramp_s)
        }
    }

    /// The quality gate's limits for this recipe (derived defaults unless overridden).
    pub fn quality_limits(&self) -> QualityLimits {
        self.quality.limits(self.threshold_um, self.um_per_px)
    }

    /// Frames in one measuring turn of `measure.turn_deg`.
    pub fn frames_per_turn(&self) -> usize {
        self.frames_for_arc(self.measure.turn_deg)
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
    fn out_of_range_values_name_their_key_and_line() {
        for (text, key, line) in [
            ("[fit]\nhuber_k = -1.0\n", "fit.huber_k", 2),
            (
                "name = \"x\"\n[fit]\npaper_half_window = 500\n",
                "fit.paper_half_window",
                3,
            ),
            (
                "[fit]\nroundness_orders = [1, 2]\n",
                "fit.roundness_orders",
                2,
            ),
            ("window_px = [0, 540]\n", "window_px", 1),
            ("[focus]\nrange_um = -150.0\n", "focus.range_um", 2),
            ("[focus]\nrange_um = 1e160\n", "focus.range_um", 2),
            ("[push]\nmax_push_um = 1e12\n", "push.max_push_um", 2),
            (
                "[learn]\ngain_min = 1.5\ngain_max = 0.5\n",
                "learn.gain_max",
                3,
            ),
            ("[quality]\nmax_gap_deg = 0.0\n", "quality.max_gap_deg", 2),
            ("[measure]\nexposure_s = 0.5\n", "measure.exposure_s", 2),
            ("[learn]\nprior_weight = 1e300\n", "learn.prior_weight", 2),
            (
                "[quality]\nframe_noise_px = 1e300\n",
                "quality.frame_noise_px",
                2,
            ),
            ("[push]\nlive_stall_um = 1e300\n", "push.live_stall_um", 2),
            (
                "[measure]\nverify_turn_deg = 280.0\n",
                "measure.verify_turn_deg",
                2,
            ),
            ("[measure]\nfps = 300.0\n", "measure.fps", 2),
            (
                "[measure]\nservo_accel_deg_per_s2 = 0.0\n",
                "measure.servo_accel_deg_per_s2",
                2,
            ),
            (
                "[measure]\ncamera_line_time_us = -1.0\n",
                "measure.camera_line_time_us",
                2,
            ),
            ("[focus]\ncheck_step_um = 400.0\n", "focus.check_step_um", 2),
            (
                "[focus]\ncheck_max_points = 2\n",
                "focus.check_max_points",
                2,
            ),
            (
                "[quality]\nmax_gap_carried_roundness_deg = 400.0\n",
                "quality.max_gap_carried_roundness_deg",
                2,
            ),
        ] {
            match Recipe::from_toml(text).unwrap_err() {
                StationError::RecipeValue {
                    key: k, line: l, ..
                } => assert_eq!((k.as_str(), l), (key, line), "{text}"),
                other => panic!("{text}: {other:?}"),
            }
        }
        let e = Recipe::from_toml("[learn]\nprior_weight = 1e300\n").unwrap_err();
        assert_eq!(
            e.to_string(),
            "line 2, column 1: learn.prior_weight = 1e300: expected at most 1000000"
        );
        let e = Recipe::from_toml("[fit]\nhuber_k = 0.0\n").unwrap_err();
        assert_eq!(
            e.to_string(),
            "line 2, column 1: fit.huber_k = 0: expected a finite number > 0"
        );
        // The camera's frame rate for the window, the bound named in the error.
        let e = Recipe::from_toml("window_px = [1440, 540]\n[measure]\nfps = 240.0\n").unwrap_err();
        assert_eq!(
            e.to_string(),
            "line 3, column 1: measure.fps = 240: expected at most 100.0 fps, the camera's frame rate for a 540-row window (1 / (measure.camera_line_time_us · (window_px[1] + measure.camera_blank_lines)))"
        );
        let e = Recipe::from_toml("[measure]\nverify_turn_deg = 200.0\n").unwrap_err();
        assert!(e.to_string().contains("above 288°"), "{e}");
    }

    #[test]
    fn round_trips_and_defaults() {
        let r = Recipe::default();
        assert_eq!(Recipe::from_toml(&r.to_toml()).unwrap(), r);
        // From rest: the 0.48 s ramp to 432°/s covers 103.68° in 115 frames, the remaining
        // 256.32° take 142.4 frames at 240 fps (1.8° apart).
        assert_eq!(r.frames_per_turn(), 258);
        assert_eq!(r.frames_for_arc(r.measure.verify_turn_deg), 224);
        let constant = Recipe {
            measure: MeasureSettings {
                frames_from_rest: false,
                ..r.measure.clone()
            },
            ..r.clone()
        };
        assert_eq!(constant.frames_per_turn(), 200);
        assert!((r.camera_max_fps() - 263.7).abs() < 0.05);
        let seed = Recipe {
            window_px: [1440, 540],
            ..r
        };
        assert!((seed.camera_max_fps() - 100.0).abs() < 0.01);
    }
}
