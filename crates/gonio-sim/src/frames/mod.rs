//! The grating-frame renderer: synthetic 8-bit camera frames of a rotating, eccentric grating
//! seen through the station's optics, with their ground truth; the scenes it draws
//! ([`scene`]: named presets and every feature as data, [`family`]: the `random` family) and a
//! [`FrameSource`](gonio_vision::FrameSource) over rendered frames ([`source`]).
//!
//! # Geometry
//! Stage coordinates in µm: X radial (toward the camera), Y along the sensor's rows (down). The
//! shaft is at the origin; the camera window is centred on (X₀, 0) with X₀ = the ring's radius, so
//! a centred grating puts the ring in the middle column. A grating with eccentricity e at angle ψ
//! (in the grating's own frame) turned by θ has its centre at G = e·(cos(θ+ψ), sin(θ+ψ)): the
//! ring moves in x and in y as the table turns. A stage point P sees the grating point at radius
//! ρ = |P − G| and grating angle φ = arg(P − G) − θ.
//!
//! # What is drawn
//! - the alignment ring: a dark band (the optics' width, or the scene's) at radius
//!   R(φ) = R₀ + Σ A_k cos(kφ + φ_k) (roundness harmonics), missing over the scene's ring gaps;
//! - track-border circles: thin dark lines concentric with the grating, in groups;
//! - radial tracks: marks (code bars, incremental lines) in annuli concentric with the ring,
//!   each at the right orientation for its radius;
//! - scratches (straight dark or bright lines at any angle), saturated patches;
//! - dust specks (small dark blobs at random places in each frame, some on the ring);
//! - an illumination gradient across the window and vignetting;
//! - defocus: every edge is blurred by a Gaussian of σ² = σ₀² + (NA·Δz/2)² + pixel²/12, Δz the
//!   focus position's distance from best focus (edge profiles are drawn analytically with the
//!   normal CDF, bars as separable rectangles in (ρ, arc length));
//! - shot noise (variance = grey / electrons-per-grey) and read noise; an exposure factor
//!   (above ≈ 1.3 the background saturates at 255).
//!
//! Noise is normal, drawn from a table of 4096 normal quantiles indexed by 12 random bits
//! (SplitMix64, one stream per row): the same seed gives the same bytes, whatever the number of
//! threads.
//!
//! # Speed
//! Per row, the column ranges where the ring, the borders, the tracks and the scratches can
//! darken a pixel are found from the geometry (ρ grows along a row when the window is on the +X
//! side of the grating centre, as always here); only those columns evaluate ρ and the edge
//! profiles. Every pixel then gets illumination and noise in one cheap pass.
//!
//! # Ground truth
//! [`FrameTruth::c_true_px`] is the ring centre line's mean column over the window's rows (the
//! column of the ring's centre line solved per row, roundness included), the quantity the
//! detector's c estimates. The truth also gives the ring's drawn width, its visible contrast
//! and how close a saturated patch comes to it.
//!
//! ```
//! use gonio_sim::frames::{GratingRenderer, GratingScene};
//! use gonio_vision::{Detector, Optics};
//! let optics = Optics::default();
//! let r = GratingRenderer::new(&optics, GratingScene::default()).unwrap();
//! let mut frame = vec![0u8; r.frame_len()];
//! let truth = r.render(30.0, 100.0, 45.0, 0.0, 7, &mut frame).unwrap();
//! let res = Detector::new(&optics).unwrap().detect(&frame).unwrap();
//! assert!((res.c_px.unwrap() - truth.c_true_px).abs() < 0.1);
//! ```

pub mod family;
pub mod scene;
pub mod source;

pub use family::{SceneDraw, SceneFamily};
pub use scene::{
    GratingScene, RadialTrack, RingGap, Roundness, SaturatedPatch, ScenePreset, Scratch,
    TrackBorder, psf_sigma_um_for,
};
pub use source::{RenderedFrames, SceneChoice, Turn, frame_seed};

use crate::SimError;
use gonio_core::bound::{Bound, Num};
use gonio_vision::{Optics, Params};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::sync::Arc;

/// The ground truth of one rendered frame.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct FrameTruth {
    /// Table angle θ, degrees.
    pub theta_deg: f64,
    /// Eccentricity, µm.
    pub eccentricity_um: f64,
    /// Eccentricity angle ψ in the grating's frame, degrees.
    pub ecc_angle_deg: f64,
    /// Focus position, µm.
    pub focus_um: f64,
    /// Ring centre line's mean column over the window's rows, px (NaN when the ring does not
    /// cross every row).
    pub c_true_px: f64,
    /// Ring centre line's column at the window's middle row, px.
    pub c_mid_row_px: f64,
    /// Total blur σ of the frame's edges, px.
    pub blur_sigma_px: f64,
    /// True when the ring is drawn and fully inside the window (its whole width, every row).
    pub ring_in_window: bool,
    /// Width of the drawn ring, px.
    pub ring_width_px: f64,
    /// The ring's visible contrast: the smallest difference between background and ring grey
    /// levels over the rows where the ring is drawn, after illumination, vignetting, exposure,
    /// the blur (a blur wider than the ring leaves less of its depth; a frame blurred flat has
    /// none) and clipping at 255, grey levels (0 without a ring).
    pub ring_contrast_grey: f64,
    /// Rows where the ring is missing (ring gaps), of the window's.
    pub ring_gap_rows: u32,
    /// Distance from the nearest saturated patch to the ring's band, px (negative: the patch
    /// covers part of the ring; infinite: no patch or no ring).
    pub patch_distance_px: f64,
}

const CDF_STEPS: f64 = 64.0;
const CDF_RANGE: f64 = 6.0;

/// The renderer: optics + scene, with its lookup tables. Cheap to share (`&self` renders).
#[derive(Debug, Clone)]
pub struct GratingRenderer {
    optics: Optics,
    p: Params,
    scene: GratingScene,
    cdf: Arc<[f32]>,
    /// Standard normal quantiles at (i + ½)/4096: 12 random bits → one normal deviate.
    normal: Arc<[f32]>,
}

/// Bits per normal deviate drawn from the table (five per 64-bit random word).
const NORMAL_BITS: u32 = 12;

/// SplitMix64: a cheap, well-mixed 64-bit generator (one per row, seeded from the frame's seed).
#[inline(always)]
fn splitmix64(state: &mut u64) -> u64 {
    *state = state.wrapping_add(0x9E37_79B9_7F4A_7C15);
    let mut z = *state;
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// Round half away from zero without a libm call (the baseline x86-64 target has no `roundsd`).
#[inline(always)]
fn round_fast(x: f64) -> f64 {
    if x >= 0.0 {
        (x + 0.5) as i64 as f64
    } else {
        (x - 0.5) as i64 as f64
    }
}

/// Inverse of [`norm_cdf`] by bisection (table construction only).
fn norm_quantile(p: f64) -> f64 {
    let (mut lo, mut hi) = (-8.0f64, 8.0f64);
    for _ in 0..60 {
        let mid = 0.5 * (lo + hi);
        if norm_cdf(mid) < p {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    0.5 * (lo + hi)
}

/// Normal CDF via erf (Abramowitz–Stegun 7.1.26, |ε| < 1.5e-7), for the table.
fn norm_cdf(x: f64) -> f64 {
    let z = x.abs() / std::f64::consts::SQRT_2;
    let t = 1.0 / (1.0 + 0.327_591_1 * z);
    let y = 1.0
        - (((((1.061_405_429 * t - 1.453_152_027) * t) + 1.421_413_741) * t - 0.284_496_736) * t
            + 0.254_829_592)
            * t
            * (-z * z).exp();
    if x >= 0.0 {
        0.5 * (1.0 + y)
    } else {
        0.5 * (1.0 - y)
    }
}

/// Brightness added inside a saturated patch (before exposure), grey levels: far above 255.
const PATCH_GREY: f64 = 400.0;

fn check_finite(name: &str, v: f64) -> Result<(), SimError> {
    if v.is_finite() {
        Ok(())
    } else {
        Err(SimError::parameter(name, v, "a finite number"))
    }
}

fn check_positive(name: &str, v: f64) -> Result<(), SimError> {
    if v.is_finite() && v > 0.0 {
        Ok(())
    } else {
        Err(SimError::parameter(name, v, "a finite number > 0"))
    }
}

fn check_range(name: &str, r: [f64; 2], lo: f64) -> Result<(), SimError> {
    if r[0].is_finite() && r[1].is_finite() && r[0] >= lo && r[1] >= r[0] {
        Ok(())
    } else {
        Err(SimError::parameter(
            name,
            format!("[{}, {}]", r[0], r[1]),
            &format!("[low, high] with {lo} ≤ low ≤ high"),
        ))
    }
}

/// Vignetting: a relative loss, below all of the light.
const VIGNETTING: Bound = Bound::new(0.0, 1.0, "").hi_excluded();

/// Most features of one kind in a scene (dust specks per frame, scratches, tracks, …).
pub const MAX_FEATURES: usize = 10_000;

/// Checks every value of a scene (names as in the scene TOML).
fn validate(scene: &GratingScene) -> Result<(), SimError> {
    let sc = scene;
    for (name, v, bound) in [
        ("psf_sigma_um", sc.psf_sigma_um, scene::PSF_SIGMA_UM),
        ("exposure", sc.exposure, scene::EXPOSURE),
        (
            "read_noise_grey",
            sc.read_noise_grey,
            scene::READ_NOISE_GREY,
        ),
        (
            "electrons_per_grey",
            sc.electrons_per_grey,
            scene::ELECTRONS_PER_GREY,
        ),
        (
            "numerical_aperture",
            sc.numerical_aperture,
            scene::NUMERICAL_APERTURE,
        ),
        ("background_grey", sc.background_grey, scene::GREY),
        ("ring_grey", sc.ring_grey, scene::GREY),
        ("bar_grey", sc.bar_grey, scene::GREY),
        ("vignetting", sc.vignetting, VIGNETTING),
        ("best_focus_um", sc.best_focus_um, scene::FOCUS_UM),
    ] {
        if let Err(e) = bound.check(v) {
            return Err(SimError::parameter(name, Num(v), &e.to_string()));
        }
    }
    if !sc.illumination_gradient.is_finite() || sc.illumination_gradient.abs() >= 1.0 {
        return Err(SimError::parameter(
            "illumination_gradient",
            sc.illumination_gradient,
            "−1 … 1",
        ));
    }
    if let Some(w) = sc.ring_width_px {
        check_positive("ring_width_px", w)?;
    }
    for r in &sc.roundness {
        check_finite("roundness.amplitude_um", r.amplitude_um)?;
        check_finite("roundness.phase_rad", r.phase_rad)?;
    }
    for (name, n) in [
        ("dust_per_frame", sc.dust_per_frame),
        ("dust_on_ring_per_frame", sc.dust_on_ring_per_frame),
        ("track_borders", sc.track_borders.len()),
        ("radial_tracks", sc.radial_tracks.len()),
        ("scratches", sc.scratches.len()),
        ("ring_gaps", sc.ring_gaps.len()),
        ("saturated_patches", sc.saturated_patches.len()),
        ("roundness", sc.roundness.len()),
        (
            "track_borders.count (lines in all groups)",
            sc.track_borders
                .iter()
                .map(|b| b.count as usize)
                .fold(0usize, usize::saturating_add),
        ),
    ] {
        if n > MAX_FEATURES {
            return Err(SimError::parameter(
                name,
                n,
                &format!("at most {MAX_FEATURES} (each is drawn on every frame)"),
            ));
        }
    }
    check_range("dust_radius_px", sc.dust_radius_px, 0.01)?;
    check_range("dust_depth", sc.dust_depth, 0.0)?;
    for b in &sc.track_borders {
        check_finite("track_borders.offset_px", b.offset_px)?;
        check_positive("track_borders.width_px", b.width_px)?;
        check_finite("track_borders.pitch_px", b.pitch_px)?;
        if let Some(d) = b.depth_grey {
            check_finite("track_borders.depth_grey", d)?;
        }
    }
    for t in &sc.radial_tracks {
        check_finite("radial_tracks.inner_px", t.inner_px)?;
        check_finite("radial_tracks.outer_px", t.outer_px)?;
        if t.outer_px <= t.inner_px {
            return Err(SimError::parameter(
                "radial_tracks.outer_px",
                t.outer_px,
                &format!("> inner_px ({})", t.inner_px),
            ));
        }
        check_positive("radial_tracks.pitch_px", t.pitch_px)?;
        check_positive("radial_tracks.mark_px", t.mark_px)?;
        if t.mark_px >= t.pitch_px {
            return Err(SimError::parameter(
                "radial_tracks.mark_px",
                t.mark_px,
                &format!("< pitch_px ({})", t.pitch_px),
            ));
        }
        if let Some(d) = t.depth_grey {
            check_finite("radial_tracks.depth_grey", d)?;
        }
    }
    for s in &sc.scratches {
        check_finite("scratches.x_px", s.x_px)?;
        check_finite("scratches.y_px", s.y_px)?;
        check_finite("scratches.angle_deg", s.angle_deg)?;
        check_positive("scratches.width_px", s.width_px)?;
        check_finite("scratches.depth_grey", s.depth_grey)?;
        if let Some(l) = s.length_px {
            check_positive("scratches.length_px", l)?;
        }
    }
    for g in &sc.ring_gaps {
        check_finite("ring_gaps.start_row", g.start_row)?;
        check_positive("ring_gaps.rows", g.rows)?;
    }
    for p in &sc.saturated_patches {
        check_finite("saturated_patches.x_px", p.x_px)?;
        check_finite("saturated_patches.y_px", p.y_px)?;
        check_positive("saturated_patches.radius_px", p.radius_px)?;
    }
    Ok(())
}

/// Most pixel visits the scene's features may cost a frame, per pixel of the window: dust
/// specks, scratches, saturated patches and track-border lines each visit the pixels they cover
/// (at ≈ 1 ns a visit, 64 a pixel is ≈ 50 ms a frame of the station's 1440 × 540 window).
pub const MAX_FEATURE_VISITS_PER_PIXEL: f64 = 64.0;

/// Checks that the scene's features cost at most [`MAX_FEATURE_VISITS_PER_PIXEL`] pixel visits
/// per window pixel and frame (an estimate from their counts and sizes, before any frame), so
/// that a scene at the stated limits of its counts and sizes cannot take seconds a frame.
fn check_cost(sc: &GratingScene, w: usize, h: usize) -> Result<(), SimError> {
    let (wf, hf) = (w as f64, h as f64);
    let area = wf * hf;
    let speck = {
        let r = sc.dust_radius_px[1].max(sc.dust_radius_px[0]);
        let side = 2.0 * (2.2 * r + 4.0) + 1.0;
        (side * side).min(area)
    };
    let dust = (sc.dust_per_frame as f64 + sc.dust_on_ring_per_frame as f64) * speck;
    let scratches: f64 = sc
        .scratches
        .iter()
        .map(|k| hf * (k.width_px + 8.0).min(wf))
        .sum();
    let patches: f64 = sc
        .saturated_patches
        .iter()
        .map(|p| (std::f64::consts::PI * (p.radius_px + 4.0).powi(2)).min(area))
        .sum();
    let lines: f64 = sc
        .track_borders
        .iter()
        .map(|b| f64::from(b.count) * hf * (b.width_px + 8.0).min(wf))
        .sum();
    let total = dust + scratches + patches + lines;
    let budget = MAX_FEATURE_VISITS_PER_PIXEL * area;
    if total > budget {
        let (name, part) = [
            ("dust_per_frame", dust),
            ("scratches", scratches),
            ("saturated_patches", patches),
            ("track_borders", lines),
        ]
        .into_iter()
        .fold(("", f64::MIN), |a, b| if b.1 > a.1 { b } else { a });
        return Err(SimError::parameter(
            name,
            format!(
                "{:.0} pixel visits a frame ({:.0} by all features)",
                part, total
            ),
            &format!(
                "features costing at most {MAX_FEATURE_VISITS_PER_PIXEL} pixel visits per window pixel ({budget:.0} for {w} × {h}): fewer or smaller dust specks, scratches, patches or lines"
            ),
        ));
    }
    Ok(())
}

/// One concentric dark line or band: radius (µm), half width (µm), depth (grey).
#[derive(Debug, Clone, Copy)]
struct Circle {
    radius_um: f64,
    half_um: f64,
    depth: f32,
}

impl GratingRenderer {
    /// A renderer for the optics' window.
    ///
    /// # Errors
    /// [`SimError::Parameter`] for invalid optics or scene values (named as in the scene TOML).
    pub fn new(optics: &Optics, scene: GratingScene) -> Result<Self, SimError> {
        let p = optics
            .params()
            .map_err(|e| SimError::parameter("optics", e, "valid optics"))?;
        validate(&scene)?;
        check_cost(&scene, p.width, p.height)?;
        let n = (2.0 * CDF_RANGE * CDF_STEPS) as usize + 2;
        let cdf = (0..n)
            .map(|i| norm_cdf(i as f64 / CDF_STEPS - CDF_RANGE) as f32)
            .collect();
        let nn = 1usize << NORMAL_BITS;
        let normal = (0..nn)
            .map(|i| norm_quantile((i as f64 + 0.5) / nn as f64) as f32)
            .collect();
        Ok(GratingRenderer {
            optics: optics.clone(),
            p,
            scene,
            cdf,
            normal,
        })
    }

    /// A renderer for the same optics and another scene, sharing this one's tables (cheap: for
    /// a new scene every frame).
    ///
    /// # Errors
    /// [`SimError::Parameter`] for invalid scene values.
    pub fn with_scene(&self, scene: GratingScene) -> Result<Self, SimError> {
        validate(&scene)?;
        check_cost(&scene, self.p.width, self.p.height)?;
        Ok(GratingRenderer {
            optics: self.optics.clone(),
            p: self.p.clone(),
            scene,
            cdf: self.cdf.clone(),
            normal: self.normal.clone(),
        })
    }

    /// Bytes of one frame (window width × height).
    pub fn frame_len(&self) -> usize {
        self.p.width * self.p.height
    }

    /// Window width and height in pixels.
    pub fn size(&self) -> (usize, usize) {
        (self.p.width, self.p.height)
    }

    /// The scene.
    pub fn scene(&self) -> &GratingScene {
        &self.scene
    }

    /// The optics.
    pub fn optics(&self) -> &Optics {
        &self.optics
    }

    #[inline]
    fn phi(&self, x: f64) -> f32 {
        let t = ((x + CDF_RANGE) * CDF_STEPS).clamp(0.0, 2.0 * CDF_RANGE * CDF_STEPS);
        let i = t as usize;
        let f = (t - i as f64) as f32;
        self.cdf[i] + (self.cdf[i + 1] - self.cdf[i]) * f
    }

    /// Fraction covered by a band [a, b] blurred by σ, at position s (any consistent unit).
    #[inline]
    fn band(&self, s: f64, a: f64, b: f64, inv_sigma: f64) -> f32 {
        self.phi((s - a) * inv_sigma) - self.phi((s - b) * inv_sigma)
    }

    fn ring_radius(&self, phi_g: f64) -> f64 {
        self.optics.ring_radius_um
            + self
                .scene
                .roundness
                .iter()
                .map(|h| h.amplitude_um * (h.order as f64 * phi_g + h.phase_rad).cos())
                .sum::<f64>()
    }

    /// Total blur σ in µm at a focus position.
    pub fn blur_sigma_um(&self, focus_um: f64) -> f64 {
        let dz = focus_um - self.scene.best_focus_um;
        let s = self.p.um_per_px;
        (self.scene.psf_sigma_um.powi(2)
            + (self.scene.numerical_aperture * dz / 2.0).powi(2)
            + s * s / 12.0)
            .sqrt()
    }

    /// The drawn ring's width, µm.
    fn ring_width_um(&self) -> f64 {
        self.scene
            .ring_width_px
            .map_or(self.optics.ring_width_um, |w| w * self.p.um_per_px)
    }

    /// Stage X of the ring centre line at stage Y, or None if the ring does not reach that Y.
    fn ring_x(&self, g: (f64, f64), theta: f64, y: f64) -> Option<f64> {
        let dy = y - g.1;
        let mut r = self.optics.ring_radius_um;
        let mut x = None;
        for _ in 0..3 {
            let q = r * r - dy * dy;
            if q <= 0.0 {
                return None;
            }
            let qx = q.sqrt();
            x = Some(g.0 + qx);
            r = self.ring_radius(dy.atan2(qx) - theta);
        }
        let q = r * r - dy * dy;
        if q <= 0.0 {
            x.map(|_| g.0)
        } else {
            Some(g.0 + q.sqrt())
        }
    }

    /// Fraction of the ring missing at row `v` (gaps with their ends blurred like any edge).
    fn gap_fraction(&self, v: usize, inv_sigma_px: f64) -> f32 {
        let y = v as f64;
        let mut f = 0.0f32;
        for g in &self.scene.ring_gaps {
            f += self.band(
                y,
                g.start_row - 0.5,
                g.start_row + g.rows - 0.5,
                inv_sigma_px,
            );
        }
        f.min(1.0)
    }

    /// Renders one frame into `out` (window width × height bytes, row-major) and returns its truth.
    ///
    /// `theta_deg`: the table angle; `eccentricity_um`, `ecc_angle_deg`: the grating centre's
    /// offset from the shaft and its angle in the grating's frame; `focus_um`: the focus
    /// position (best focus at [`GratingScene::best_focus_um`]); `rng_seed`: noise and dust.
    ///
    /// # Errors
    /// [`SimError::Parameter`] if `out` has the wrong length or an argument is not finite.
    pub fn render(
        &self,
        theta_deg: f64,
        eccentricity_um: f64,
        ecc_angle_deg: f64,
        focus_um: f64,
        rng_seed: u64,
        out: &mut [u8],
    ) -> Result<FrameTruth, SimError> {
        let (w, h) = (self.p.width, self.p.height);
        if out.len() != w * h {
            return Err(SimError::parameter(
                "frame buffer",
                out.len(),
                &format!("{} bytes ({w}×{h})", w * h),
            ));
        }
        for (name, v) in [
            ("theta_deg", theta_deg),
            ("eccentricity_um", eccentricity_um),
            ("ecc_angle_deg", ecc_angle_deg),
            ("focus_um", focus_um),
        ] {
            check_finite(name, v)?;
        }
        let sc = &self.scene;
        let s = self.p.um_per_px;
        let x0 = self.optics.ring_radius_um;
        let theta = theta_deg.to_radians();
        let a = theta + ecc_angle_deg.to_radians();
        let g = (eccentricity_um * a.cos(), eccentricity_um * a.sin());
        let sigma = self.blur_sigma_um(focus_um);
        let inv_sigma = 1.0 / sigma;
        let inv_sigma_px = s / sigma;
        let half_w = self.ring_width_um() / 2.0;
        let r0 = self.optics.ring_radius_um;
        let col_of = |x: f64| (x - x0) / s + (w as f64 - 1.0) / 2.0;
        let stage_x = |u: usize| x0 + (u as f64 - (w as f64 - 1.0) / 2.0) * s;
        let stage_y = |v: usize| (v as f64 - (h as f64 - 1.0) / 2.0) * s;

        // Ring centre line per row (shared by the truth and the drawing).
        let ring_xs: Vec<Option<f64>> = (0..h).map(|v| self.ring_x(g, theta, stage_y(v))).collect();
        let gaps: Vec<f32> = (0..h).map(|v| self.gap_fraction(v, inv_sigma_px)).collect();

        let gain = sc.exposure;
        let bg = sc.background_grey;
        let ring_depth = sc.ring_depth_grey() as f32;
        let bar_depth = sc.background_grey - sc.bar_grey;
        let reach = 4.5 * sigma;
        let reach_px = reach / s;
        let tau = std::f64::consts::TAU;
        // Illumination: the column and row terms (additive, as a relative change), and the
        // vignetting's quadratic falloff from the window's centre.
        let illum_col: Vec<f64> = (0..w)
            .map(|u| -sc.illumination_gradient * (u as f64 / w as f64 - 0.5))
            .collect();
        let illum_row =
            |v: usize| 1.0 + 0.5 * sc.illumination_gradient * (v as f64 / h as f64 - 0.5);
        let (cu, cv) = ((w as f64 - 1.0) / 2.0, (h as f64 - 1.0) / 2.0);
        let corner2 = cu * cu + cv * cv;
        let vig_col: Vec<f64> = (0..w)
            .map(|u| sc.vignetting * (u as f64 - cu).powi(2) / corner2)
            .collect();
        let vig_row = |v: usize| sc.vignetting * (v as f64 - cv).powi(2) / corner2;
        let illum =
            |u: usize, v: usize| (illum_row(v) + illum_col[u]) * (1.0 - vig_row(v) - vig_col[u]);

        // Truth.
        let mut sum = 0.0;
        let mut all_rows = true;
        let mut inside = sc.ring_present;
        let d_half_px = half_w / s;
        let mut contrast = f64::INFINITY;
        // The blur keeps this share of the ring's depth at its centre line: a band of width 2h
        // blurred by σ dips by erf(h / (σ√2)) of its depth.
        let kept = 2.0 * norm_cdf(half_w / sigma) - 1.0;
        let mut gap_rows = 0u32;
        for (v, rx) in ring_xs.iter().enumerate() {
            match *rx {
                Some(x) => {
                    let c = col_of(x);
                    sum += c;
                    if c - d_half_px < 0.0 || c + d_half_px > w as f64 - 1.0 {
                        inside = false;
                    }
                    if gaps[v] > 0.5 {
                        gap_rows += 1;
                    } else if sc.ring_present {
                        let u = (c.round().max(0.0) as usize).min(w - 1);
                        let k = illum(u, v) * gain;
                        let dip = (bg - sc.ring_grey) * k * kept;
                        let vis = (bg * k).min(255.0) - (bg * k - dip).clamp(0.0, 255.0);
                        contrast = contrast.min(vis);
                    }
                }
                None => {
                    all_rows = false;
                    inside = false;
                }
            }
        }
        let c_true_px = if all_rows { sum / h as f64 } else { f64::NAN };
        let c_mid_row_px = ring_xs[h / 2].map_or(f64::NAN, col_of);
        let mut patch_distance_px = f64::INFINITY;
        if sc.ring_present {
            for p in &sc.saturated_patches {
                for (v, rx) in ring_xs.iter().enumerate() {
                    if let Some(x) = *rx {
                        let d =
                            (col_of(x) - p.x_px).hypot(v as f64 - p.y_px) - p.radius_px - d_half_px;
                        patch_distance_px = patch_distance_px.min(d);
                    }
                }
            }
        }

        // Concentric lines: the track borders.
        let circles: Vec<Circle> = sc
            .track_borders
            .iter()
            .flat_map(|b| {
                (0..b.count).map(move |k| Circle {
                    radius_um: r0 + (b.offset_px + k as f64 * b.pitch_px) * s,
                    half_um: b.width_px * s / 2.0,
                    depth: b.depth_grey.unwrap_or(sc.ring_depth_grey()) as f32,
                })
            })
            .collect();
        // Radial tracks in µm: (inner, outer, period, mark, depth).
        let tracks: Vec<(f64, f64, f64, f64, f32)> = if sc.code_tracks {
            sc.radial_tracks
                .iter()
                .map(|t| {
                    (
                        t.inner_px * s,
                        t.outer_px * s,
                        t.pitch_px * s,
                        t.mark_px * s,
                        t.depth_grey.unwrap_or(bar_depth) as f32,
                    )
                })
                .collect()
        } else {
            Vec::new()
        };

        let rn2 = (sc.read_noise_grey * sc.read_noise_grey) as f32;
        let inv_e = if sc.electrons_per_grey > 0.0 {
            (1.0 / sc.electrons_per_grey) as f32
        } else {
            0.0
        };
        let qx_first = stage_x(0) - g.0;
        // Columns [lo, hi) whose ρ can lie in [r_lo, r_hi] on a row with offset qy (ρ increases
        // with u when the whole row is at qx > 0; otherwise every column).
        let cols = |qy: f64, r_lo: f64, r_hi: f64| -> (usize, usize) {
            if qx_first <= 0.0 {
                return (0, w);
            }
            let u_of = |r: f64| {
                let q = r * r - qy * qy;
                if q <= 0.0 {
                    f64::NEG_INFINITY
                } else {
                    (q.sqrt() - qx_first) / s
                }
            };
            let lo = (u_of(r_lo).floor() - 1.0).clamp(0.0, w as f64) as usize;
            let hi = (u_of(r_hi).ceil() + 2.0).clamp(0.0, w as f64) as usize;
            (lo, hi.max(lo))
        };
        // A band seen from deep inside (both profiles at the table's ends).
        let deep_band = self.cdf[self.cdf.len() - 2] - self.cdf[0];
        let normal = &self.normal[..];
        let mask = (1u64 << NORMAL_BITS) - 1;
        let any_vignetting = sc.vignetting > 0.0;
        // Rows in parallel; each row has its own noise stream, so the bytes do not depend on
        // the number of threads.
        out.par_chunks_mut(w).enumerate().for_each_init(
            || vec![0f32; w],
            |dark, (v, row)| {
                dark.fill(0.0);
                let y = stage_y(v);
                let qy = y - g.1;
                // Ring radius for this row (roundness varies slowly along the ring).
                let rr = match ring_xs[v] {
                    Some(x) => ((x - g.0).powi(2) + qy * qy).sqrt(),
                    None => r0,
                };
                let rho_at = |u: usize| {
                    let qx = stage_x(u) - g.0;
                    (qx, (qx * qx + qy * qy).sqrt())
                };
                let ring_here = ring_depth * (1.0 - gaps[v]);
                let draw_circle = |c: Circle, dark: &mut [f32]| {
                    let (lo, hi) = cols(
                        qy,
                        c.radius_um - c.half_um - reach,
                        c.radius_um + c.half_um + reach,
                    );
                    for (u, d) in dark.iter_mut().enumerate().take(hi).skip(lo) {
                        let (_, rho) = rho_at(u);
                        let dr = rho - c.radius_um;
                        if dr.abs() < c.half_um + reach {
                            *d += c.depth * self.band(dr, -c.half_um, c.half_um, inv_sigma);
                        }
                    }
                };
                if sc.ring_present && ring_here > 0.01 {
                    draw_circle(
                        Circle {
                            radius_um: rr,
                            half_um: half_w,
                            depth: ring_here,
                        },
                        dark,
                    );
                }
                for &c in &circles {
                    draw_circle(c, dark);
                }
                if !tracks.is_empty() {
                    // Unit vector toward the window centre's grating point, for the track angles.
                    let qxc = x0 - g.0;
                    let nrm = (qxc * qxc + qy * qy).sqrt();
                    let (cx, cy) = (qxc / nrm, qy / nrm);
                    let phi_c = qy.atan2(qxc) - theta;
                    for &(lo, hi, period, mark, depth) in &tracks {
                        let (ulo, uhi) = cols(qy, r0 + lo - reach, r0 + hi + reach);
                        let n = tau * r0 / period;
                        let n_tau = n / tau;
                        let tau_n = tau / n;
                        // Where both edge profiles are beyond the table's range the bands are
                        // table constants: radial = 1 (deep inside the track), and the
                        // neighbouring mark's band is 0 when half a period is wider than the
                        // mark plus the table's reach (|arc| ≤ local/2 always).
                        let table_reach = CDF_RANGE * sigma;
                        let local_min = tau_n * (r0 + lo - reach).max(0.0);
                        let neighbour = mark / 2.0 - local_min / 2.0 > -table_reach;
                        for (u, d) in dark.iter_mut().enumerate().take(uhi).skip(ulo) {
                            let (qx, rho) = rho_at(u);
                            let dt = rho - r0;
                            if dt > lo - reach && dt < hi + reach {
                                // Angle from the centre direction (small: series of atan).
                                let t = (qy * cx - qx * cy) / (qx * cx + qy * cy);
                                let t2 = t * t;
                                let dphi = t * (1.0 - t2 * (1.0 / 3.0 - t2 * (0.2 - t2 / 7.0)));
                                let phi_g = phi_c + dphi;
                                let k = round_fast(phi_g * n_tau);
                                let arc = (phi_g - k * tau_n) * rho;
                                let local = tau_n * rho;
                                let near = arc.abs().min(local - arc.abs());
                                if near > mark / 2.0 + reach {
                                    continue;
                                }
                                let radial = if dt - lo >= table_reach && hi - dt >= table_reach {
                                    deep_band
                                } else {
                                    self.band(dt, lo, hi, inv_sigma)
                                };
                                let mut ang = self.band(arc, -mark / 2.0, mark / 2.0, inv_sigma);
                                if neighbour {
                                    ang += self.band(
                                        arc.abs() - local,
                                        -mark / 2.0,
                                        mark / 2.0,
                                        inv_sigma,
                                    );
                                }
                                *d += depth * radial * ang;
                            }
                        }
                    }
                }
                // Scratches (window pixels): perpendicular distance to the centre line.
                let vf = v as f64;
                for sk in &sc.scratches {
                    let (sn, cs) = sk.angle_deg.to_radians().sin_cos();
                    let hw = sk.width_px / 2.0;
                    let r = hw + reach_px;
                    let along0 = (vf - sk.y_px) * sn;
                    let (ulo, uhi) = if cs.abs() > 1e-9 {
                        let a = sk.x_px + (along0 - r) / cs;
                        let b = sk.x_px + (along0 + r) / cs;
                        let (a, b) = (a.min(b), a.max(b));
                        (
                            a.floor().clamp(0.0, w as f64) as usize,
                            (b.ceil() + 1.0).clamp(0.0, w as f64) as usize,
                        )
                    } else if along0.abs() <= r {
                        (0, w)
                    } else {
                        (0, 0)
                    };
                    for (u, d) in dark.iter_mut().enumerate().take(uhi).skip(ulo) {
                        let du = u as f64 - sk.x_px;
                        let perp = du * cs - (vf - sk.y_px) * sn;
                        let mut f = self.band(perp, -hw, hw, inv_sigma_px);
                        if let Some(l) = sk.length_px {
                            let t = du * sn + (vf - sk.y_px) * cs;
                            f *= self.band(t, -l / 2.0, l / 2.0, inv_sigma_px);
                        }
                        *d += sk.depth_grey as f32 * f;
                    }
                }
                // Saturated patches: light added, far above what the sensor can hold.
                for p in &sc.saturated_patches {
                    let dy = vf - p.y_px;
                    let r = p.radius_px + reach_px;
                    if dy.abs() > r {
                        continue;
                    }
                    let half = (r * r - dy * dy).sqrt();
                    let ulo = (p.x_px - half).floor().clamp(0.0, w as f64) as usize;
                    let uhi = (p.x_px + half + 2.0).clamp(0.0, w as f64) as usize;
                    for (u, d) in dark.iter_mut().enumerate().take(uhi).skip(ulo) {
                        let dist = (u as f64 - p.x_px).hypot(dy);
                        *d -= PATCH_GREY as f32 * self.phi((p.radius_px - dist) * inv_sigma_px);
                    }
                }
                let il_row = illum_row(v);
                let vr = vig_row(v);
                let mut state = rng_seed ^ (v as u64 + 1).wrapping_mul(0xD1B5_4A32_D192_ED03);
                let mut bits = 0u64;
                let mut left = 0u32;
                for (u, ((o, &d), &ic)) in
                    row.iter_mut().zip(dark.iter()).zip(&illum_col).enumerate()
                {
                    let r = bg as f32 - d;
                    let mut val = r as f64 * (il_row + ic) * gain;
                    if any_vignetting {
                        val *= 1.0 - vr - vig_col[u];
                    }
                    let var = rn2 + (val as f32).max(0.0) * inv_e;
                    if left == 0 {
                        bits = splitmix64(&mut state);
                        left = 64 / NORMAL_BITS;
                    }
                    let z = normal[(bits & mask) as usize];
                    bits >>= NORMAL_BITS;
                    left -= 1;
                    let x = val + (var.sqrt() * z) as f64;
                    *o = (x.clamp(0.0, 255.0) + 0.5) as u8;
                }
            },
        );
        let mut rng = ChaCha8Rng::seed_from_u64(rng_seed);
        let depth_ref = sc.ring_depth_grey().max(1.0);
        let speck = |out: &mut [u8], rng: &mut ChaCha8Rng, cu: f64, cv: f64| {
            let [r_lo, r_hi] = sc.dust_radius_px;
            let rad_um = if r_hi > r_lo {
                rng.random_range(r_lo..r_hi)
            } else {
                r_lo
            } * s;
            let [k_lo, k_hi] = sc.dust_depth;
            let depth = if k_hi > k_lo {
                rng.random_range(k_lo..k_hi)
            } else {
                k_lo
            } * depth_ref
                * gain;
            let sd = (rad_um * rad_um / 2.0 + sigma * sigma).sqrt() / s;
            let amp = depth * (rad_um * rad_um / 2.0) / (rad_um * rad_um / 2.0 + sigma * sigma);
            // Only the part of the speck inside the frame is visited (a blur far wider than the
            // frame, at a huge defocus, costs one frame, not the speck's whole extent).
            let ext = (3.0 * sd).ceil().min((w + h) as f64) as isize;
            let (ci, ri) = (cu as isize, cv as isize);
            for vv in (ri - ext).max(0)..=(ri + ext).min(h as isize - 1) {
                for uu in (ci - ext).max(0)..=(ci + ext).min(w as isize - 1) {
                    let (fu, fv) = (uu as f64 - cu, vv as f64 - cv);
                    let k = amp * (-(fu * fu + fv * fv) / (2.0 * sd * sd)).exp();
                    let o = &mut out[vv as usize * w + uu as usize];
                    *o = ((*o as f64 - k).clamp(0.0, 255.0) + 0.5) as u8;
                }
            }
        };
        // Dust specks: small dark blurred blobs, anywhere …
        for _ in 0..sc.dust_per_frame {
            let cu = rng.random_range(0.0..w as f64);
            let cv = rng.random_range(0.0..h as f64);
            speck(out, &mut rng, cu, cv);
        }
        // … and on the ring (its band ± 2 px).
        if sc.ring_present {
            for _ in 0..sc.dust_on_ring_per_frame {
                let v = rng.random_range(0..h);
                let off = rng.random_range(-(d_half_px + 2.0)..(d_half_px + 2.0));
                if let Some(x) = ring_xs[v] {
                    speck(out, &mut rng, col_of(x) + off, v as f64);
                }
            }
        }
        Ok(FrameTruth {
            theta_deg,
            eccentricity_um,
            ecc_angle_deg,
            focus_um,
            c_true_px,
            c_mid_row_px,
            blur_sigma_px: sigma / s,
            ring_in_window: inside && all_rows,
            ring_width_px: 2.0 * d_half_px,
            ring_contrast_grey: if sc.ring_present && contrast.is_finite() {
                contrast.max(0.0)
            } else {
                0.0
            },
            ring_gap_rows: gap_rows,
            patch_distance_px,
        })
    }
}
