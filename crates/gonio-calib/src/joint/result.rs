//! The result of a joint calibration.

use super::spectrum::Invisible;
use crate::selfcal::NoiseModel;
use crate::shift_angle::SetupError;
use gonio_uncertainty::budget::{deserialize_dof, serialize_dof};
use nalgebra::DMatrix;
use serde::{Deserialize, Serialize};

/// The encoder error at one distinct polygon angle.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct JointAlpha {
    /// Table angle, degrees in [0, 360).
    pub angle_deg: f64,
    /// α, arcsec, with zero mean over the circle (the heads' convention; not closed per shift).
    pub value_arcsec: f64,
    /// Standard uncertainty (random part of both instruments), arcsec.
    pub u_arcsec: f64,
    /// The part of u due to the heads' noise, arcsec (u² = heads² + polygon²).
    pub u_heads_arcsec: f64,
    /// The part of u due to the polygon readings' noise, arcsec.
    pub u_polygon_arcsec: f64,
    /// Welch–Satterthwaite degrees of freedom of u (truncated; ∞ when both σ are stated;
    /// JSON: a number or `"inf"`).
    #[serde(serialize_with = "serialize_dof", deserialize_with = "deserialize_dof")]
    pub nu_eff: f64,
    /// Coverage factor at the requested coverage.
    pub k: f64,
    /// Expanded uncertainty k·u, arcsec.
    pub expanded_arcsec: f64,
    /// u of the heads alone with the same weighting (the joint estimate without the polygon),
    /// arcsec.
    pub u_heads_alone_arcsec: f64,
    /// u of the polygon alone (shift-angle least squares, closed per shift), the smallest over
    /// the shifts that read this angle, arcsec; absent when the polygon alone is not solvable.
    pub u_polygon_alone_arcsec: Option<f64>,
}

/// Which instrument can see a harmonic order on its own.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum SeenBy {
    /// Both the polygon and the heads.
    Both,
    /// Only the heads (the order is a multiple of N).
    Heads,
    /// Only the polygon (the heads cannot see it).
    Polygon,
    /// Neither.
    Neither,
}

/// One harmonic `cos·cos kθ + sin·sin kθ = amplitude·sin(kθ + phase)` of the joint estimate.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct JointHarmonic {
    /// Order k.
    pub order: u32,
    /// Whether the joint estimate contains this order (false: invisible, reported as 0).
    pub estimated: bool,
    /// Which instrument sees the order alone.
    pub seen_by: SeenBy,
    /// Cosine coefficient, arcsec.
    pub cos_arcsec: f64,
    /// Sine coefficient, arcsec.
    pub sin_arcsec: f64,
    /// Amplitude, arcsec.
    pub amplitude_arcsec: f64,
    /// Phase, radians.
    pub phase_rad: f64,
    /// Standard uncertainty of the cosine coefficient, arcsec.
    pub u_cos_arcsec: f64,
    /// Standard uncertainty of the sine coefficient, arcsec.
    pub u_sin_arcsec: f64,
    /// Standard uncertainty of each coefficient from the heads alone, arcsec (absent when the
    /// heads cannot see the order).
    pub u_heads_alone_arcsec: Option<f64>,
    /// Share of the joint information (1/u²) on this order that the heads provide (0…1).
    pub heads_share: f64,
    /// Share the polygon provides (1 − heads_share for an estimated order).
    pub polygon_share: f64,
    /// Why the order is not estimated.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub invisible: Option<Invisible>,
}

/// The blind orders of each method and of the joint estimate, up to `max_order`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct BlindOrders {
    /// The largest order listed.
    pub max_order: u32,
    /// Orders the polygon cannot see (multiples of N).
    pub polygon: Vec<u32>,
    /// Orders the heads cannot see.
    pub heads: Vec<u32>,
    /// Orders the joint estimate does not contain (with the reason in the harmonic table).
    pub joint: Vec<u32>,
    /// Orders the heads cannot see that the joint estimate takes from the polygon.
    pub from_polygon: Vec<u32>,
    /// The highest heads-blind order the polygon's angles were asked to resolve.
    pub polygon_resolution_cap: u32,
}

/// The σ of one reading of an instrument, as used.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct SigmaUsed {
    /// σ, arcsec (per head reading or per difference for the heads, per the noise model).
    pub sigma_arcsec: f64,
    /// Whether it was stated (true) or estimated from the instrument's own residuals.
    pub stated: bool,
    /// Degrees of freedom of the estimate (∞ when stated; JSON: a number or `"inf"`).
    #[serde(serialize_with = "serialize_dof", deserialize_with = "deserialize_dof")]
    pub dof: f64,
    /// Readings of the instrument.
    pub readings: usize,
}

/// Whether the two instruments agree: the increase of the weighted residual sum of squares
/// from the two separate fits to the joint fit, against its χ² distribution.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Consistency {
    /// Δχ² = χ²(joint) − χ²(polygon alone) − χ²(heads alone).
    pub chi2: f64,
    /// Its degrees of freedom: shifts·(N − 1) − 2·(orders taken from the polygon alone).
    pub dof: usize,
    /// P(χ²_dof ≥ chi2).
    pub p_upper: f64,
    /// Whether chi2 lies inside the central 95 % of its distribution.
    pub consistent: bool,
}

/// Residuals of the polygon readings against the joint estimate.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct PolygonResiduals {
    /// Readings compared.
    pub count: usize,
    /// RMS residual, arcsec.
    pub rms_arcsec: f64,
    /// Largest |residual|, arcsec.
    pub max_abs_arcsec: f64,
}

/// A joint calibration of the encoder (and the polygon and the heads).
#[derive(Debug, Clone, PartialEq)]
pub struct JointCalibration {
    /// Polygon faces N.
    pub faces: usize,
    /// Shift angles, degrees.
    pub shifts_deg: Vec<f64>,
    /// Polygon readings used.
    pub polygon_readings: usize,
    /// Rotation positions per turn of the heads (the encoder grid).
    pub positions: usize,
    /// Head angles, degrees.
    pub heads_deg: Vec<f64>,
    /// The heads' noise model.
    pub noise_model: NoiseModel,
    /// The head angles the heads' model used.
    pub head_angles: super::HeadAngles,
    /// How the heads' model placed the error between positions.
    pub interpolation: super::Interpolation,
    /// Coverage probability of the expanded uncertainties.
    pub coverage: f64,
    /// α at every distinct polygon angle, ascending.
    pub alpha: Vec<JointAlpha>,
    /// Full covariance of α at those angles, arcsec² (same order).
    pub covariance_alpha: DMatrix<f64>,
    /// Pitch deviation β_k (index k − 1), arcsec; Σβ = 0.
    pub beta_arcsec: Vec<f64>,
    /// Standard uncertainty of each β, arcsec.
    pub u_beta_arcsec: Vec<f64>,
    /// The setup error of every run (the whole error of the run's start: with α's mean over the
    /// circle being zero, it is not mixed with α as in the polygon-alone result, except for the
    /// orders invisible to both, which are constant on a shift's angles).
    pub setup: Vec<SetupError>,
    /// Mounting offsets c_h of heads 2..M, arcsec.
    pub head_offsets_arcsec: Vec<f64>,
    /// Harmonics 1..=max_order of the joint estimate, with the per-order variance split.
    pub harmonics: Vec<JointHarmonic>,
    /// Blind orders of each method and of the joint estimate.
    pub blind: BlindOrders,
    /// σ of one polygon reading.
    pub sigma_polygon: SigmaUsed,
    /// σ of one head reading (or difference).
    pub sigma_heads: SigmaUsed,
    /// Polygon residuals against the joint estimate.
    pub residuals_polygon: PolygonResiduals,
    /// RMS of the head-difference residuals against the joint estimate (Σ̃ metric), arcsec.
    pub residuals_heads_rms_arcsec: f64,
    /// The χ² agreement of the two instruments (absent when the polygon alone cannot be
    /// solved or the test has no degrees of freedom).
    pub consistency: Option<Consistency>,
}
