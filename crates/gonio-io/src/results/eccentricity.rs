//! The result of one turn's eccentricity fit (`gonio eccentricity --json`, `gonio.eccentricity`
//! in Python): e in px and µm with u(e), θ_max, the residuals, the outliers' CSV lines and the
//! station's quality verdict (`quality_ok`, `quality_reasons`).
//!
//! Errors are `anyhow` errors naming the flag or the samples' file.
//!
//! ```
//! use gonio_io::formats::samples;
//! use gonio_io::results::eccentricity::{Settings, evaluate};
//! use gonio_station::{Recipe, fit::FitMethod};
//! let mut csv = String::from("theta_deg,c_px\n");
//! for i in 0..200 {
//!     let t = 1.8 * i as f64;
//!     csv.push_str(&format!("{t},{}\n", 700.0 + 10.0 * (t - 40.0f64).to_radians().cos()));
//! }
//! let read = samples::parse("turn.csv", &csv).unwrap();
//! let s = Settings::new(Recipe::default(), Some(0.75), None).unwrap();
//! let out = evaluate(&read, &s, FitMethod::LeastSquares, None).unwrap();
//! assert!((out.e_um - 7.5).abs() < 1e-5);
//! assert!(out.quality_ok);
//! ```

use crate::formats::samples::Samples;
use anyhow::{Result, anyhow};
use gonio_core::bound::Num;
use gonio_station::Recipe;
use gonio_station::fit::{FitMethod, FitOptions, fit_judged};
use gonio_station::quality::QualityMetrics;
use gonio_station::recipe::{FRAMES_PER_TURN, THRESHOLD_UM, UM_PER_PX};
use serde::Serialize;

/// The JSON output.
#[derive(Debug, Serialize)]
pub struct Output {
    /// `least-squares` or `paper`.
    pub method: &'static str,
    /// Eccentricity, px.
    pub e_px: f64,
    /// Eccentricity, µm.
    pub e_um: f64,
    /// Standard uncertainty of e, µm (none when undefined).
    pub u_e_um: Option<f64>,
    /// Angle of the largest c, degrees.
    pub theta_max_deg: f64,
    /// Its standard uncertainty, degrees.
    pub u_theta_max_deg: Option<f64>,
    /// Mean column, px.
    pub c0_px: f64,
    /// RMS of the residuals, px.
    pub residual_rms_px: f64,
    /// σ of one sample, px.
    pub sigma_px: f64,
    /// Samples used.
    pub frames_used: usize,
    /// Outliers rejected.
    pub outliers: usize,
    /// Their lines in the samples' CSV.
    pub outlier_lines: Vec<u64>,
    /// Arc of the turn covered, degrees.
    pub arc_deg: f64,
    /// Pixel scale used, µm per px.
    pub um_per_px: f64,
    /// Every check of the quality gate passed.
    pub quality_ok: bool,
    /// The checks that failed.
    pub quality_reasons: Vec<String>,
    /// The gate's metrics.
    pub quality: Option<QualityMetrics>,
}

/// The fit's settings: the recipe with the pixel scale and the threshold checked.
#[derive(Debug, Clone)]
pub struct Settings {
    /// The recipe (fit settings, quality limits).
    pub recipe: Recipe,
    /// µm per px.
    pub um_per_px: f64,
    /// Acceptance threshold of e, µm.
    pub threshold_um: f64,
}

impl Settings {
    /// The recipe's pixel scale and threshold unless given.
    ///
    /// # Errors
    /// A scale or threshold outside its bound ([`UM_PER_PX`], [`THRESHOLD_UM`]).
    pub fn new(
        recipe: Recipe,
        um_per_px: Option<f64>,
        threshold_um: Option<f64>,
    ) -> Result<Settings> {
        let um = um_per_px.unwrap_or(recipe.um_per_px);
        UM_PER_PX
            .check(um)
            .map_err(|e| anyhow!("--um-per-px {}: {e}", Num(um)))?;
        let threshold = threshold_um.unwrap_or(recipe.threshold_um);
        THRESHOLD_UM
            .check(threshold)
            .map_err(|e| anyhow!("--threshold-um {}: {e}", Num(threshold)))?;
        Ok(Settings {
            recipe,
            um_per_px: um,
            threshold_um: threshold,
        })
    }
}

/// Fits one turn's samples and judges the fit; `frames_taken` (default: the samples) counts the
/// frames of the turn, valid or not.
///
/// # Errors
/// Fewer frames taken than samples or more than [`FRAMES_PER_TURN`], a fit that fails, a result that is not finite; naming the
/// samples' file.
pub fn evaluate(
    read: &Samples,
    s: &Settings,
    method: FitMethod,
    frames_taken: Option<usize>,
) -> Result<Output> {
    let samples = &read.samples;
    let t = &read.table;
    let um = s.um_per_px;
    let frames_taken = frames_taken.unwrap_or(samples.len());
    FRAMES_PER_TURN
        .check_int(frames_taken)
        .map_err(|e| anyhow!("--frames-taken {frames_taken}: {e}"))?;
    if frames_taken < samples.len() {
        return Err(anyhow!(
            "--frames-taken {frames_taken}: expected at least the {} rows of {}",
            samples.len(),
            t.name
        ));
    }
    let limits = s.recipe.quality.limits(s.threshold_um, um);
    let opts = FitOptions {
        method,
        ..s.recipe.fit.clone()
    };
    let f = fit_judged(samples, frames_taken, &opts, &limits)
        .map_err(|e| anyhow!("{}: {e}", t.name))?;
    let out = Output {
        method: method.name(),
        e_px: f.e_px,
        e_um: f.e_px * um,
        u_e_um: f.u_e_px.map(|u| u * um),
        theta_max_deg: f.theta_max_deg,
        u_theta_max_deg: f.u_theta_max_deg,
        c0_px: f.c0_px,
        residual_rms_px: f.residual_rms_px,
        sigma_px: f.sigma_px,
        frames_used: f.frames_used,
        outliers: f.outliers.len(),
        outlier_lines: f.outliers.iter().map(|&i| read.line_of(i)).collect(),
        arc_deg: f.arc_deg,
        um_per_px: um,
        quality_ok: f.quality.ok,
        quality_reasons: f.quality.reasons(),
        quality: f.quality.metrics.clone(),
    };
    // A result that overflowed (e.g. --um-per-px 1e308) is an error naming it, not "inf".
    crate::json::check_finite(&out).map_err(|e| {
        anyhow!(
            "{}: {e}; with um_per_px = {um} and e = {} px",
            t.name,
            f.e_px
        )
    })?;
    Ok(out)
}
