//! The grating-frame renderer: synthetic 8-bit camera frames of a rotating, eccentric grating
//! seen through the station's optics, with their ground truth.
//!
//! # Geometry
//! Stage coordinates in µm: X radial (toward the camera), Y along the sensor's rows (down). The
//! shaft is at the origin; the camera window is centred on (X₀, 0) with X₀ = the ring's radius, so
//! a centred grating puts the ring in the middle column. A grating with eccentricity e at angle ψ
//! (in the grating's own frame) turned by θ has its centre at G = e·(cos(θ+ψ), sin(θ+ψ)). A stage
//! point P sees the grating point at radius ρ = |P − G| and grating angle φ = arg(P − G) − θ.
//!
//! # What is drawn
//! - the alignment ring: a dark band of the optics' ring width at radius R(φ) = R₀ + Σ A_k cos(kφ +
//!   φ_k) (roundness harmonics);
//! - code tracks concentric with it: wide radial bars (wider than 2d) outside the ring and thin
//!   radial lines (narrower than d/2) inside, each at the right orientation for its radius;
//! - dust specks (small dark blobs at random places in each frame);
//! - an illumination gradient across the window;
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
//! Per row, the column ranges where the ring and the code tracks can darken a pixel are found
//! from the geometry (ρ grows along a row when the window is on the +X side of the grating
//! centre, as always here); only those columns evaluate ρ and the edge profiles. Every pixel
//! then gets illumination and noise in one cheap pass.
//!
//! # Ground truth
//! [`FrameTruth::c_true_px`] is the ring centre line's mean column over the window's rows (the
//! column of the ring's centre line solved per row, roundness included), the quantity the
//! detector's c estimates.
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

use crate::SimError;
use gonio_vision::{Optics, Params};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

/// One roundness harmonic of the ring: `amplitude_um·cos(order·φ + phase_rad)`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Roundness {
    /// Order (cycles per turn).
    pub order: u32,
    /// Amplitude, µm.
    pub amplitude_um: f64,
    /// Phase, rad.
    pub phase_rad: f64,
}

/// What the grating and the imaging look like (everything but the optics and the pose).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct GratingScene {
    /// Draw the alignment ring (false: a frame with no ring).
    pub ring_present: bool,
    /// Background (clear grating) grey level at exposure 1.
    pub background_grey: f64,
    /// Ring grey level at exposure 1.
    pub ring_grey: f64,
    /// Grey level of code bars and lines.
    pub bar_grey: f64,
    /// Roundness harmonics of the ring (default: orders 2–4, 0.375 µm = 0.5 px each).
    pub roundness: Vec<Roundness>,
    /// Draw the code tracks.
    pub code_tracks: bool,
    /// Dust specks per frame.
    pub dust_per_frame: usize,
    /// Relative illumination change across the window's width (0.15: +15 % right to left).
    pub illumination_gradient: f64,
    /// Read noise, grey levels RMS.
    pub read_noise_grey: f64,
    /// Electrons per grey level for shot noise (0: no shot noise).
    pub electrons_per_grey: f64,
    /// Exposure factor multiplying every grey level (saturation above ≈ 1.3).
    pub exposure: f64,
    /// Focus position of best focus, µm.
    pub best_focus_um: f64,
    /// Numerical aperture of the lens (defocus blur σ = NA·|Δz|/2).
    pub numerical_aperture: f64,
    /// In-focus blur σ₀ (lens PSF), µm.
    pub psf_sigma_um: f64,
}

impl Default for GratingScene {
    fn default() -> Self {
        GratingScene {
            ring_present: true,
            background_grey: 185.0,
            ring_grey: 55.0,
            bar_grey: 60.0,
            roundness: vec![
                Roundness {
                    order: 2,
                    amplitude_um: 0.375,
                    phase_rad: 0.4,
                },
                Roundness {
                    order: 3,
                    amplitude_um: 0.375,
                    phase_rad: 2.1,
                },
                Roundness {
                    order: 4,
                    amplitude_um: 0.375,
                    phase_rad: 4.0,
                },
            ],
            code_tracks: true,
            dust_per_frame: 12,
            illumination_gradient: 0.15,
            read_noise_grey: 2.0,
            electrons_per_grey: 40.0,
            exposure: 1.0,
            best_focus_um: 0.0,
            numerical_aperture: 0.1,
            psf_sigma_um: 0.5,
        }
    }
}

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
}

const CDF_STEPS: f64 = 64.0;
const CDF_RANGE: f64 = 6.0;

/// The renderer: optics + scene, with its lookup tables. Cheap to share (`&self` renders).
#[derive(Debug, Clone)]
pub struct GratingRenderer {
    optics: Optics,
    p: Params,
    scene: GratingScene,
    cdf: Vec<f32>,
    /// Standard normal quantiles at (i + ½)/4096: 12 random bits → one normal deviate.
    normal: Vec<f32>,
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

/// Track layout relative to the ring radius (µm): (inner, outer, period, mark width).
const WIDE_BARS: (f64, f64, f64, f64) = (120.0, 330.0, 60.0, 30.0);
const THIN_LINES: (f64, f64, f64, f64) = (-330.0, -120.0, 12.0, 2.0);

impl GratingRenderer {
    /// A renderer for the optics' window.
    ///
    /// # Errors
    /// [`SimError::Parameter`] for invalid optics or scene values.
    pub fn new(optics: &Optics, scene: GratingScene) -> Result<Self, SimError> {
        let p = optics
            .params()
            .map_err(|e| SimError::parameter("optics", e, "valid optics"))?;
        for (name, v) in [
            ("psf_sigma_um", scene.psf_sigma_um),
            ("exposure", scene.exposure),
        ] {
            if !(v.is_finite() && v > 0.0) {
                return Err(SimError::parameter(name, v, "a finite number > 0"));
            }
        }
        for (name, v) in [
            ("read_noise_grey", scene.read_noise_grey),
            ("electrons_per_grey", scene.electrons_per_grey),
            ("numerical_aperture", scene.numerical_aperture),
            ("background_grey", scene.background_grey),
            ("ring_grey", scene.ring_grey),
            ("bar_grey", scene.bar_grey),
        ] {
            if !(v.is_finite() && v >= 0.0) {
                return Err(SimError::parameter(name, v, "a finite number ≥ 0"));
            }
        }
        if !scene.illumination_gradient.is_finite() || scene.illumination_gradient.abs() >= 1.0 {
            return Err(SimError::parameter(
                "illumination_gradient",
                scene.illumination_gradient,
                "−1 … 1",
            ));
        }
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

    /// Fraction covered by a band [a, b] (µm) blurred by σ, at position s.
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
            if !v.is_finite() {
                return Err(SimError::parameter(name, v, "a finite number"));
            }
        }
        let sc = &self.scene;
        let s = self.p.um_per_px;
        let x0 = self.optics.ring_radius_um;
        let theta = theta_deg.to_radians();
        let a = theta + ecc_angle_deg.to_radians();
        let g = (eccentricity_um * a.cos(), eccentricity_um * a.sin());
        let sigma = self.blur_sigma_um(focus_um);
        let inv_sigma = 1.0 / sigma;
        let half_w = self.optics.ring_width_um / 2.0;
        let r0 = self.optics.ring_radius_um;
        let col_of = |x: f64| (x - x0) / s + (w as f64 - 1.0) / 2.0;
        let stage_x = |u: usize| x0 + (u as f64 - (w as f64 - 1.0) / 2.0) * s;
        let stage_y = |v: usize| (v as f64 - (h as f64 - 1.0) / 2.0) * s;

        // Ring centre line per row (shared by the truth and the drawing).
        let ring_xs: Vec<Option<f64>> = (0..h).map(|v| self.ring_x(g, theta, stage_y(v))).collect();

        // Truth.
        let mut sum = 0.0;
        let mut all_rows = true;
        let mut inside = sc.ring_present;
        let d_half_px = half_w / s;
        for rx in &ring_xs {
            match *rx {
                Some(x) => {
                    let c = col_of(x);
                    sum += c;
                    if c - d_half_px < 0.0 || c + d_half_px > w as f64 - 1.0 {
                        inside = false;
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

        let gain = sc.exposure;
        let (bg, ring_depth, bar_depth) = (
            sc.background_grey,
            (sc.background_grey - sc.ring_grey) as f32,
            (sc.background_grey - sc.bar_grey) as f32,
        );
        let reach = 4.5 * sigma;
        let tau = std::f64::consts::TAU;
        // Illumination's column term, and the noise model's constants.
        let illum_col: Vec<f64> = (0..w)
            .map(|u| -sc.illumination_gradient * (u as f64 / w as f64 - 0.5))
            .collect();
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
                if sc.ring_present {
                    let (lo, hi) = cols(qy, rr - half_w - reach, rr + half_w + reach);
                    for (u, d) in dark.iter_mut().enumerate().take(hi).skip(lo) {
                        let (_, rho) = rho_at(u);
                        let dr = rho - rr;
                        if dr.abs() < half_w + reach {
                            *d += ring_depth * self.band(dr, -half_w, half_w, inv_sigma);
                        }
                    }
                }
                if sc.code_tracks {
                    // Unit vector toward the window centre's grating point, for the track angles.
                    let qxc = x0 - g.0;
                    let nrm = (qxc * qxc + qy * qy).sqrt();
                    let (cx, cy) = (qxc / nrm, qy / nrm);
                    let phi_c = qy.atan2(qxc) - theta;
                    for (lo, hi, period, mark) in [WIDE_BARS, THIN_LINES] {
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
                                *d += bar_depth * radial * ang;
                            }
                        }
                    }
                }
                let illum_row = 1.0 + 0.5 * sc.illumination_gradient * (v as f64 / h as f64 - 0.5);
                let mut state = rng_seed ^ (v as u64 + 1).wrapping_mul(0xD1B5_4A32_D192_ED03);
                let mut bits = 0u64;
                let mut left = 0u32;
                for ((o, &d), &ic) in row.iter_mut().zip(dark.iter()).zip(&illum_col) {
                    let r = bg as f32 - d;
                    let val = r as f64 * (illum_row + ic) * gain;
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
        let bg = sc.background_grey;
        // Dust specks: small dark blurred blobs.
        for _ in 0..sc.dust_per_frame {
            let cu = rng.random_range(0.0..w as f64);
            let cv = rng.random_range(0.0..h as f64);
            let rad_um: f64 = rng.random_range(0.5..1.6);
            let depth: f64 = rng.random_range(0.3..0.8) * (bg - sc.ring_grey) * gain;
            let sd = (rad_um * rad_um / 2.0 + sigma * sigma).sqrt() / s;
            let amp = depth * (rad_um * rad_um / 2.0) / (rad_um * rad_um / 2.0 + sigma * sigma);
            let ext = (3.0 * sd).ceil() as isize;
            for dv in -ext..=ext {
                let vv = cv as isize + dv;
                if vv < 0 || vv >= h as isize {
                    continue;
                }
                for du in -ext..=ext {
                    let uu = cu as isize + du;
                    if uu < 0 || uu >= w as isize {
                        continue;
                    }
                    let (fu, fv) = (uu as f64 - cu, vv as f64 - cv);
                    let k = amp * (-(fu * fu + fv * fv) / (2.0 * sd * sd)).exp();
                    let o = &mut out[vv as usize * w + uu as usize];
                    *o = ((*o as f64 - k).clamp(0.0, 255.0) + 0.5) as u8;
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
        })
    }
}
