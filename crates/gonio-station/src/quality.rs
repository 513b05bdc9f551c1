//! Quality gates on one measuring turn: may the station push on this eccentricity?
//!
//! A fit always returns a number; this module says whether the turn behind it can be trusted.
//! Every fit is judged ([`crate::fit::fit_judged`]) on seven checks, each against a limit derived
//! from the detector's stated accuracy, the station's frame noise, the geometry of the fit and the
//! recipe's acceptance threshold (the derivations are in `docs/quality-gates.md`):
//!
//! | check | statistic | default limit |
//! |---|---|---|
//! | `residual_rms` | RMS of the least-squares residuals, px | 3·√(acc² + σ²) = 0.95 px |
//! | `coverage` | share of the 36 sectors of 10° holding a used frame | ≥ 1 − gap/360° = 87.5 % |
//! | `largest_gap` | largest angle without a used frame, ° | ≤ 45° |
//! | `frames_used` | frames used / frames taken | ≥ 75 % |
//! | `outliers` | frames rejected by the fit / frames given to it | ≤ 5 % |
//! | `u_e` | standard uncertainty of e, µm | ≤ 5 % of the threshold (0.25 µm) |
//! | `half_turns` | the second half-turn's steps (Δc₀, Δa, Δb), in σ | ≤ 4.6 σ |
//!
//! (acc: the detector's accuracy bound per valid frame, 0.1 px; σ: the station's per-frame noise,
//! 0.3 px.) A turn fitted with the ring's roundness carried from a full turn of the same part
//! ([`crate::ring`]) has its largest gap judged against 72° (coverage 80 %): there the carried
//! roundness inflates u(e) by no more than a free roundness does at 45° (1.55× against 1.56×).
//! The gate judges the turn's data through the least-squares model whatever the fit method: the
//! seed's extreme-point method has no residual model of its own.
//!
//! ```
//! use gonio_station::fit::{fit_judged, FitOptions, Sample};
//! use gonio_station::quality::QualitySettings;
//! let limits = QualitySettings::default().limits(5.0, 0.75);
//! // A clean turn, but a third of it (120°) missing: e is exact, the turn is not trusted.
//! let s: Vec<Sample> = (0..200)
//!     .map(|i| 1.8 * i as f64)
//!     .filter(|t| !(120.0..240.0).contains(t))
//!     .map(|t| Sample { theta_deg: t, c_px: 720.0 + 40.0 * (t - 33.0f64).to_radians().cos() })
//!     .collect();
//! let f = fit_judged(&s, 200, &FitOptions::default(), &limits).unwrap();
//! assert!((f.e_px - 40.0).abs() < 1e-6);
//! assert!(!f.quality.ok);
//! assert!(f.quality.reasons().iter().any(|r| r.starts_with("largest_gap")));
//! ```

use crate::sample::Sample;
use serde::{Deserialize, Serialize};

/// The detector's accuracy bound per valid frame, px (issue 9: |c − c_true| ≤ 0.1 px).
pub const DETECTOR_ACCURACY_PX: f64 = 0.1;
/// The station's per-frame scatter of the ring's column, px (the default plant: 0.3 px).
pub const FRAME_NOISE_PX: f64 = 0.3;
/// The residual limit in units of the per-frame budget √(acc² + σ²).
pub const RESIDUAL_FACTOR: f64 = 3.0;
/// The largest gap, degrees: up to here the roundness harmonics 2–4 (unconstrained) inflate the
/// eccentricity's uncertainty by at most 1.6× against a full turn (`docs/quality-gates.md`).
pub const MAX_GAP_DEG: f64 = 45.0;
/// Sectors counted by the coverage (10° each).
pub const COVERAGE_SECTORS: usize = 36;
/// The limit of the half-turn distance: √χ²₃ at a tail probability of 10⁻⁴.
pub const HALF_TURN_Z: f64 = 4.6;
/// The largest gap, degrees, of a turn fitted with the ring's roundness carried from a full turn
/// of the same part: up to here u(e) is inflated by at most 1.55× against a full turn (the
/// free-roundness limit [`MAX_GAP_DEG`] allows 1.56×; `docs/station-timing.md`).
pub const MAX_GAP_CARRIED_DEG: f64 = 72.0;

/// The recipe's quality settings (`[quality]`): the inputs of the derivation and, optionally,
/// limits that override the derived ones.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct QualitySettings {
    /// The detector's accuracy bound per valid frame, px.
    pub detector_accuracy_px: f64,
    /// The station's per-frame scatter of the ring's column, px.
    pub frame_noise_px: f64,
    /// Largest residual RMS, px (default: 3·√(accuracy² + noise²)).
    pub max_residual_rms_px: Option<f64>,
    /// Smallest share of the turn covered, 0–1 (default: 1 − max_gap_deg/360).
    pub min_coverage: Option<f64>,
    /// Largest angle without a used frame, degrees.
    pub max_gap_deg: f64,
    /// Largest angle without a used frame in a turn fitted with the ring's roundness carried
    /// from a full turn of the part, degrees (its coverage limit follows: 1 − gap/360).
    pub max_gap_carried_roundness_deg: f64,
    /// Smallest share of the frames taken that the fit used, 0–1.
    pub min_used_fraction: f64,
    /// Largest share of the fit's frames rejected as outliers, 0–1.
    pub max_outlier_fraction: f64,
    /// Largest u(e) as a share of the recipe's threshold (0.05: U = 2u ≤ threshold/10).
    pub max_u_e_fraction: f64,
    /// Largest distance between the two half-turns' (c₀, a, b), in standard deviations
    /// (√χ²₃ at a tail probability of 10⁻⁴).
    pub max_half_turn_z: f64,
    /// Turns measured again after one fails the gate (each after a refocus when
    /// `refocus_before_remeasure`).
    pub remeasure_turns: u32,
    /// Autofocus again before re-measuring a failed turn.
    pub refocus_before_remeasure: bool,
}

impl Default for QualitySettings {
    fn default() -> Self {
        QualitySettings {
            detector_accuracy_px: DETECTOR_ACCURACY_PX,
            frame_noise_px: FRAME_NOISE_PX,
            max_residual_rms_px: None,
            min_coverage: None,
            max_gap_deg: MAX_GAP_DEG,
            max_gap_carried_roundness_deg: MAX_GAP_CARRIED_DEG,
            min_used_fraction: 0.75,
            max_outlier_fraction: 0.05,
            max_u_e_fraction: 0.05,
            max_half_turn_z: HALF_TURN_Z,
            remeasure_turns: 1,
            refocus_before_remeasure: true,
        }
    }
}

impl QualitySettings {
    /// The limits for a recipe's acceptance threshold (µm) and pixel scale (µm per px).
    pub fn limits(&self, threshold_um: f64, um_per_px: f64) -> QualityLimits {
        let budget = self.detector_accuracy_px.hypot(self.frame_noise_px);
        QualityLimits {
            max_residual_rms_px: self.max_residual_rms_px.unwrap_or(RESIDUAL_FACTOR * budget),
            min_coverage: self.min_coverage.unwrap_or(1.0 - self.max_gap_deg / 360.0),
            max_gap_deg: self.max_gap_deg,
            min_coverage_carried: 1.0 - self.max_gap_carried_roundness_deg / 360.0,
            max_gap_carried_deg: self.max_gap_carried_roundness_deg,
            min_used_fraction: self.min_used_fraction,
            max_outlier_fraction: self.max_outlier_fraction,
            max_u_e_um: self.max_u_e_fraction * threshold_um,
            max_half_turn_z: self.max_half_turn_z,
            systematic_px: self.detector_accuracy_px,
            um_per_px,
        }
    }
}

/// The resolved limits of the gate.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct QualityLimits {
    /// Largest residual RMS, px.
    pub max_residual_rms_px: f64,
    /// Smallest share of the 36 sectors of 10° holding a used frame.
    pub min_coverage: f64,
    /// Largest angle without a used frame, degrees.
    pub max_gap_deg: f64,
    /// Smallest coverage of a turn fitted with a carried roundness.
    pub min_coverage_carried: f64,
    /// Largest gap of a turn fitted with a carried roundness, degrees.
    pub max_gap_carried_deg: f64,
    /// Smallest share of the frames taken that the fit used.
    pub min_used_fraction: f64,
    /// Largest share of the fit's frames rejected as outliers.
    pub max_outlier_fraction: f64,
    /// Largest standard uncertainty of e, µm.
    pub max_u_e_um: f64,
    /// Largest half-turn distance, standard deviations.
    pub max_half_turn_z: f64,
    /// Floor of the per-frame scatter in the half-turn comparison, px: the detector's accuracy
    /// bound (in-spec systematic errors must not fail a turn whose random noise is tiny).
    pub systematic_px: f64,
    /// Pixel scale, µm per px.
    pub um_per_px: f64,
}

impl Default for QualityLimits {
    /// The seed's station: threshold 5 µm, 0.75 µm per px.
    fn default() -> Self {
        QualitySettings::default().limits(5.0, 0.75)
    }
}

/// What the gate measured on a turn.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct QualityMetrics {
    /// RMS of the least-squares residuals of the used frames, px (`None`, JSON `null`: the
    /// data do not determine the least-squares model).
    pub residual_rms_px: Option<f64>,
    /// Share of the 36 sectors of 10° holding a used frame.
    pub coverage: f64,
    /// Largest angle without a used frame, degrees.
    pub largest_gap_deg: f64,
    /// Frames the station took in the turn.
    pub frames_taken: usize,
    /// Frames the fit used (valid and not outliers).
    pub frames_used: usize,
    /// Frames rejected by the fit as outliers.
    pub outliers: usize,
    /// Share of the fit's frames rejected as outliers.
    pub outlier_fraction: f64,
    /// Standard uncertainty of e, µm, of the least-squares model, whichever method measured e
    /// (`None`, JSON `null`: the data do not determine it).
    pub u_e_um: Option<f64>,
    /// Distance between the half-turns' (c₀, a, b), standard deviations (`None`, JSON `null`:
    /// not determined, a half-turn had too few frames).
    pub half_turn_z: Option<f64>,
    /// Difference of the half-turns' mean columns c₀, px (`None`: not determined).
    pub half_turn_dc0_px: Option<f64>,
    /// Length of the difference of the half-turns' eccentricity vectors, µm (`None`: not
    /// determined).
    pub half_turn_de_um: Option<f64>,
}

/// One check of the gate.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
#[non_exhaustive]
pub enum QualityCheck {
    /// Residual RMS.
    ResidualRms,
    /// Share of the turn covered.
    Coverage,
    /// Largest angular gap.
    LargestGap,
    /// Frames used out of frames taken.
    FramesUsed,
    /// Outlier fraction.
    Outliers,
    /// u(e) against the threshold.
    UE,
    /// Consistency of the first and second half-turns.
    HalfTurns,
}

impl QualityCheck {
    /// The check's short name (`residual_rms`, `coverage`, …).
    pub fn name(self) -> &'static str {
        match self {
            QualityCheck::ResidualRms => "residual_rms",
            QualityCheck::Coverage => "coverage",
            QualityCheck::LargestGap => "largest_gap",
            QualityCheck::FramesUsed => "frames_used",
            QualityCheck::Outliers => "outliers",
            QualityCheck::UE => "u_e",
            QualityCheck::HalfTurns => "half_turns",
        }
    }
}

/// A failed check: its value and the limit it broke.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct QualityFailure {
    /// Which check.
    pub check: QualityCheck,
    /// The value measured (`None`, JSON `null`: not determined).
    pub value: Option<f64>,
    /// The limit.
    pub limit: f64,
}

impl std::fmt::Display for QualityFailure {
    /// A short reason such as `residual_rms 26.70 px > 0.95 px`.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let name = self.check.name();
        let l = self.limit;
        let Some(v) = self.value.filter(|v| !v.is_nan()) else {
            return write!(f, "{name} not determined");
        };
        match self.check {
            QualityCheck::ResidualRms => write!(f, "{name} {v:.2} px > {l:.2} px"),
            QualityCheck::Coverage | QualityCheck::FramesUsed => {
                write!(f, "{name} {:.1} % < {:.1} %", 100.0 * v, 100.0 * l)
            }
            QualityCheck::Outliers => {
                write!(f, "{name} {:.1} % > {:.1} %", 100.0 * v, 100.0 * l)
            }
            QualityCheck::LargestGap => write!(f, "{name} {v:.1}° > {l:.1}°"),
            QualityCheck::UE => write!(f, "{name} {v:.3} µm > {l:.3} µm"),
            QualityCheck::HalfTurns => write!(f, "{name} {v:.1}σ apart > {l:.1}σ"),
        }
    }
}

/// The gate's verdict on one turn.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct QualityVerdict {
    /// Every check passed: the station may push on this turn.
    pub ok: bool,
    /// The checks that failed.
    pub failures: Vec<QualityFailure>,
    /// What was measured (absent only on a verdict that was never judged).
    pub metrics: Option<QualityMetrics>,
}

impl QualityVerdict {
    /// The failures as short strings (`residual_rms 26.70 px > 0.95 px`).
    pub fn reasons(&self) -> Vec<String> {
        self.failures.iter().map(ToString::to_string).collect()
    }
}

/// What the half-turn comparison found.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct HalfTurns {
    /// Mahalanobis distance of the second half's steps (Δc₀, Δa, Δb) from zero.
    pub z: f64,
    /// c₀ difference, px.
    pub dc0_px: f64,
    /// Eccentricity-vector difference, px.
    pub de_px: f64,
}

/// Share of [`COVERAGE_SECTORS`] sectors holding an angle, and the largest gap (degrees)
/// between angles around the circle.
pub fn coverage(angles_deg: &[f64]) -> (f64, f64) {
    if angles_deg.is_empty() {
        return (0.0, 360.0);
    }
    let mut a: Vec<f64> = angles_deg.iter().map(|t| t.rem_euclid(360.0)).collect();
    a.sort_by(f64::total_cmp);
    let mut filled = [false; COVERAGE_SECTORS];
    let width = 360.0 / COVERAGE_SECTORS as f64;
    for t in &a {
        filled[((t / width) as usize).min(COVERAGE_SECTORS - 1)] = true;
    }
    let share = filled.iter().filter(|&&f| f).count() as f64 / COVERAGE_SECTORS as f64;
    let wrap = a[0] + 360.0 - a[a.len() - 1];
    let gap = a.windows(2).map(|w| w[1] - w[0]).fold(wrap, f64::max);
    (share, gap)
}

/// Judges a turn from the least-squares evidence; `carried`: the fit took the ring's roundness
/// from an earlier turn (the coverage limits for a carried roundness apply).
#[allow(clippy::too_many_arguments)]
pub(crate) fn judge(
    used: &[Sample],
    given: usize,
    frames_taken: usize,
    residual_rms_px: Option<f64>,
    u_e_px: Option<f64>,
    halves: Option<HalfTurns>,
    limits: &QualityLimits,
    carried: bool,
) -> QualityVerdict {
    let (min_coverage, max_gap) = if carried {
        (limits.min_coverage_carried, limits.max_gap_carried_deg)
    } else {
        (limits.min_coverage, limits.max_gap_deg)
    };
    let angles: Vec<f64> = used.iter().map(|s| s.theta_deg).collect();
    let (cov, gap) = coverage(&angles);
    let outliers = given - used.len();
    let um = limits.um_per_px;
    let m = QualityMetrics {
        residual_rms_px,
        coverage: cov,
        largest_gap_deg: gap,
        frames_taken,
        frames_used: used.len(),
        outliers,
        outlier_fraction: outliers as f64 / given.max(1) as f64,
        u_e_um: u_e_px.map(|u| u * um),
        half_turn_z: halves.map(|h| h.z),
        half_turn_dc0_px: halves.map(|h| h.dc0_px),
        half_turn_de_um: halves.map(|h| h.de_px * um),
    };
    let used_fraction = used.len() as f64 / frames_taken.max(1) as f64;
    // A value that is not determined (`None`, or not finite) fails its check.
    // The last field: whether the limit is a maximum (else a minimum).
    let (le, ge) = (true, false);
    let det = |v: f64| v.is_finite().then_some(v);
    let checks = [
        (
            QualityCheck::ResidualRms,
            m.residual_rms_px.and_then(det),
            limits.max_residual_rms_px,
            le,
        ),
        (QualityCheck::Coverage, det(m.coverage), min_coverage, ge),
        (
            QualityCheck::LargestGap,
            det(m.largest_gap_deg),
            max_gap,
            le,
        ),
        (
            QualityCheck::FramesUsed,
            det(used_fraction),
            limits.min_used_fraction,
            ge,
        ),
        (
            QualityCheck::Outliers,
            det(m.outlier_fraction),
            limits.max_outlier_fraction,
            le,
        ),
        (
            QualityCheck::UE,
            m.u_e_um.and_then(det),
            limits.max_u_e_um,
            le,
        ),
        (
            QualityCheck::HalfTurns,
            m.half_turn_z.and_then(det),
            limits.max_half_turn_z,
            le,
        ),
    ];
    let failures: Vec<QualityFailure> = checks
        .into_iter()
        .filter(|&(_, value, limit, max)| {
            !value.is_some_and(|v| if max { v <= limit } else { v >= limit })
        })
        .map(|(check, value, limit, _)| QualityFailure {
            check,
            value,
            limit,
        })
        .collect();
    QualityVerdict {
        ok: failures.is_empty(),
        failures,
        metrics: Some(m),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn derived_defaults() {
        let l = QualityLimits::default();
        assert!((l.max_residual_rms_px - 3.0 * 0.1f64.hypot(0.3)).abs() < 1e-12);
        assert!((l.min_coverage - 0.875).abs() < 1e-12);
        assert!((l.max_u_e_um - 0.25).abs() < 1e-12);
    }

    #[test]
    fn coverage_and_gap() {
        let full: Vec<f64> = (0..200).map(|i| 7.0 + 1.8 * i as f64).collect();
        let (c, g) = coverage(&full);
        assert_eq!(c, 1.0);
        assert!((g - 1.8).abs() < 1e-9);
        let cut: Vec<f64> = full
            .iter()
            .copied()
            .filter(|t| !(100.0..220.0).contains(t))
            .collect();
        let (c, g) = coverage(&cut);
        // Last kept below 100°: 98.8°; first kept from 220°: 221.2°.
        assert!((g - 122.4).abs() < 1e-9, "{g}");
        assert!(c < 0.7, "{c}");
    }

    #[test]
    fn reasons_read_plainly() {
        let f = QualityFailure {
            check: QualityCheck::ResidualRms,
            value: Some(26.7),
            limit: 0.95,
        };
        assert_eq!(f.to_string(), "residual_rms 26.70 px > 0.95 px");
        let f = QualityFailure {
            check: QualityCheck::HalfTurns,
            value: None,
            limit: 4.6,
        };
        assert_eq!(f.to_string(), "half_turns not determined");
    }
}
