//! The `random` scene family: every parameter of a [`GratingScene`] and the grating's pose drawn
//! from documented ranges ([`SceneFamily`]), one scene per seed, for acceptance runs of the
//! detector on what a real grating gives (`docs/scenes.md`).
//!
//! The ranges cover what real frames show (ring 9–14 px wide, 60–160 grey levels deep; thin
//! track-border circles 2–4 px wide at the ring's contrast, 400–500 px from it on both sides, in
//! groups at 16 px pitch; radial incremental lines 3–6 px at ≈ 20 px pitch; wide code bars; blur
//! σ 0.5–1.5 px; noise σ 2–6 grey levels; an illumination gradient and vignetting; dust, also on
//! the ring; a scratch across the ring at any angle; the ring missing over up to 20 % of the
//! rows; a saturated patch; the eccentric motion of the ring in x and y) and go beyond them on
//! purpose: faint rings below the optics' minimum contrast, border lines much closer to the
//! ring, tracks a few pixels from it, ring-less frames, rings leaving the window.
//!
//! ```
//! use gonio_sim::frames::SceneFamily;
//! let f = SceneFamily::default();
//! let a = f.draw(7, 0.75, 1440, 540);
//! let b = f.draw(7, 0.75, 1440, 540);
//! assert_eq!(a, b); // one seed, one scene
//! let w = a.scene.ring_width_px.unwrap();
//! assert!((9.0..=14.0).contains(&w));
//! ```

use super::scene::{
    GratingScene, RadialTrack, RingGap, Roundness, SaturatedPatch, Scratch, TrackBorder,
    psf_sigma_um_for,
};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

/// The ranges every `random` scene is drawn from (uniform within each range unless stated).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SceneFamily {
    /// Probability that the frame has no ring at all.
    pub ring_absent_probability: f64,
    /// Ring width, px.
    pub ring_width_px: [f64; 2],
    /// Ring depth below the background, grey levels (most frames).
    pub ring_contrast_grey: [f64; 2],
    /// Probability of a faint ring instead, drawn from `faint_contrast_grey`.
    pub faint_probability: f64,
    /// Depth of a faint ring, grey levels (straddles the optics' minimum on purpose).
    pub faint_contrast_grey: [f64; 2],
    /// Background grey level.
    pub background_grey: [f64; 2],
    /// Total edge blur σ at best focus, px.
    pub blur_sigma_px: [f64; 2],
    /// Read noise σ, grey levels (plus shot noise at `electrons_per_grey`).
    pub noise_grey: [f64; 2],
    /// Electrons per grey level (shot noise).
    pub electrons_per_grey: [f64; 2],
    /// Illumination gradient across the width (either sign up to this magnitude).
    pub illumination_gradient: f64,
    /// Vignetting at the corners.
    pub vignetting: [f64; 2],
    /// Roundness amplitude of each harmonic 2–4, µm.
    pub roundness_um: [f64; 2],
    /// Track-border groups per side of the ring (inclusive range).
    pub border_groups_per_side: [u32; 2],
    /// Distance of a group's first line from the ring, px.
    pub border_offset_px: [f64; 2],
    /// Probability that a group sits much closer to the ring, at `border_near_offset_px`.
    pub border_near_probability: f64,
    /// Distance of a near group, px.
    pub border_near_offset_px: [f64; 2],
    /// Lines per group (inclusive range).
    pub border_lines: [u32; 2],
    /// Border line width, px.
    pub border_width_px: [f64; 2],
    /// Pitch of the lines in a group, px.
    pub border_pitch_px: f64,
    /// Border depth as a multiple of the ring's.
    pub border_depth_factor: [f64; 2],
    /// Probability of an annulus of incremental lines.
    pub incremental_probability: f64,
    /// Incremental line width, px.
    pub incremental_width_px: [f64; 2],
    /// Incremental line pitch, px.
    pub incremental_pitch_px: [f64; 2],
    /// Probability of an annulus of wide code bars.
    pub code_bar_probability: f64,
    /// Code bar width, px (the period is twice the width).
    pub code_bar_width_px: [f64; 2],
    /// Gap between the ring's band and a radial track's annulus, px.
    pub track_gap_px: [f64; 2],
    /// Radial extent of a radial track's annulus, px.
    pub track_span_px: [f64; 2],
    /// Depth of radial tracks, grey levels.
    pub track_depth_grey: [f64; 2],
    /// Dust specks anywhere in the window (inclusive range).
    pub dust_per_frame: [usize; 2],
    /// Dust specks on the ring (inclusive range).
    pub dust_on_ring: [usize; 2],
    /// Largest dust radius drawn, px (the smallest is 0.5 px).
    pub dust_max_radius_px: [f64; 2],
    /// Probability of a scratch crossing the ring.
    pub scratch_probability: f64,
    /// Scratch width, px.
    pub scratch_width_px: [f64; 2],
    /// Scratch depth, grey levels (a quarter of the scratches are bright instead).
    pub scratch_depth_grey: [f64; 2],
    /// Probability that the ring is interrupted.
    pub gap_probability: f64,
    /// Largest fraction of the rows missing in total (one or two gaps).
    pub gap_max_fraction: f64,
    /// Probability of a saturated patch.
    pub patch_probability: f64,
    /// Saturated patch radius, px.
    pub patch_radius_px: [f64; 2],
    /// Eccentricity of the grating on its shaft, µm (0.75 µm/px: up to 560 µm takes the ring to
    /// and past the window's side).
    pub eccentricity_um: [f64; 2],
}

impl Default for SceneFamily {
    fn default() -> Self {
        SceneFamily {
            ring_absent_probability: 0.08,
            ring_width_px: [9.0, 14.0],
            ring_contrast_grey: [60.0, 160.0],
            faint_probability: 0.15,
            faint_contrast_grey: [20.0, 60.0],
            background_grey: [150.0, 220.0],
            blur_sigma_px: [0.5, 1.5],
            noise_grey: [2.0, 6.0],
            electrons_per_grey: [20.0, 80.0],
            illumination_gradient: 0.25,
            vignetting: [0.0, 0.35],
            roundness_um: [0.0, 0.75],
            border_groups_per_side: [0, 2],
            border_offset_px: [400.0, 500.0],
            border_near_probability: 0.15,
            border_near_offset_px: [25.0, 400.0],
            border_lines: [1, 4],
            border_width_px: [2.0, 4.0],
            border_pitch_px: 16.0,
            border_depth_factor: [0.7, 1.3],
            incremental_probability: 0.7,
            incremental_width_px: [3.0, 6.0],
            incremental_pitch_px: [18.0, 22.0],
            code_bar_probability: 0.6,
            code_bar_width_px: [24.0, 60.0],
            track_gap_px: [6.0, 150.0],
            track_span_px: [80.0, 300.0],
            track_depth_grey: [40.0, 180.0],
            dust_per_frame: [0, 150],
            dust_on_ring: [0, 4],
            dust_max_radius_px: [1.0, 5.0],
            scratch_probability: 0.35,
            scratch_width_px: [1.0, 4.0],
            scratch_depth_grey: [20.0, 150.0],
            gap_probability: 0.3,
            gap_max_fraction: 0.2,
            patch_probability: 0.2,
            patch_radius_px: [5.0, 40.0],
            eccentricity_um: [0.0, 560.0],
        }
    }
}

/// One drawn scene with the grating's pose.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SceneDraw {
    /// The scene.
    pub scene: GratingScene,
    /// Table angle θ, degrees.
    pub theta_deg: f64,
    /// Eccentricity, µm.
    pub eccentricity_um: f64,
    /// Eccentricity angle in the grating's frame, degrees.
    pub ecc_angle_deg: f64,
    /// Focus position (best focus at 0), µm.
    pub focus_um: f64,
}

fn uni(rng: &mut ChaCha8Rng, r: [f64; 2]) -> f64 {
    if r[1] > r[0] {
        rng.random_range(r[0]..r[1])
    } else {
        r[0]
    }
}

fn uni_n<T: Copy + Into<u64> + TryFrom<u64>>(rng: &mut ChaCha8Rng, r: [T; 2]) -> T {
    let (a, b): (u64, u64) = (r[0].into(), r[1].into());
    let v = if b > a { rng.random_range(a..=b) } else { a };
    T::try_from(v).unwrap_or(r[0])
}

impl SceneFamily {
    /// Draws scene `seed` for a window of `width` × `height` px at `um_per_px`.
    pub fn draw(&self, seed: u64, um_per_px: f64, width: usize, height: usize) -> SceneDraw {
        let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0x5CE7_E5EE_D000_0000);
        let rng = &mut rng;
        let (w, h) = (width as f64, height as f64);
        let mut s = GratingScene {
            code_tracks: true,
            radial_tracks: Vec::new(),
            ..GratingScene::default()
        };
        s.ring_present = rng.random::<f64>() >= self.ring_absent_probability;
        let ring_w = uni(rng, self.ring_width_px);
        s.ring_width_px = Some(ring_w);
        let contrast = if rng.random::<f64>() < self.faint_probability {
            uni(rng, self.faint_contrast_grey)
        } else {
            uni(rng, self.ring_contrast_grey)
        };
        s.background_grey = uni(rng, self.background_grey).max(contrast + 10.0);
        s.ring_grey = s.background_grey - contrast;
        let sigma = uni(rng, self.blur_sigma_px);
        s.psf_sigma_um = psf_sigma_um_for(sigma, um_per_px);
        s.read_noise_grey = uni(rng, self.noise_grey);
        s.electrons_per_grey = uni(rng, self.electrons_per_grey);
        s.illumination_gradient = uni(
            rng,
            [-self.illumination_gradient, self.illumination_gradient],
        );
        s.vignetting = uni(rng, self.vignetting);
        s.roundness = (2..=4)
            .map(|order| Roundness {
                order,
                amplitude_um: uni(rng, self.roundness_um),
                phase_rad: rng.random_range(0.0..std::f64::consts::TAU),
            })
            .collect();
        // Track borders: groups on both sides, extending away from the ring; the groups of one
        // side never interleave (a line of one group is at least a pitch from any other's).
        for side in [-1.0, 1.0] {
            let groups = uni_n(rng, self.border_groups_per_side);
            let mut placed: Vec<(f64, f64)> = Vec::new();
            for _ in 0..groups {
                let off = if rng.random::<f64>() < self.border_near_probability {
                    uni(rng, self.border_near_offset_px)
                } else {
                    uni(rng, self.border_offset_px)
                };
                let count = uni_n(rng, self.border_lines);
                let span = (off, off + self.border_pitch_px * (count as f64 - 1.0));
                let p = self.border_pitch_px;
                if placed
                    .iter()
                    .any(|&(a, b)| span.0 < b + p && span.1 > a - p)
                {
                    continue;
                }
                placed.push(span);
                s.track_borders.push(TrackBorder {
                    offset_px: side * off,
                    width_px: uni(rng, self.border_width_px),
                    count,
                    pitch_px: side * p,
                    depth_grey: Some(
                        (contrast * uni(rng, self.border_depth_factor))
                            .min(s.background_grey - 2.0),
                    ),
                });
            }
        }
        // Radial tracks: incremental lines and code bars, each on a random side.
        let half = ring_w / 2.0;
        let bg = s.background_grey;
        let track = |rng: &mut ChaCha8Rng, mark: f64, pitch: f64| {
            let side = if rng.random::<bool>() { 1.0 } else { -1.0 };
            let gap = uni(rng, self.track_gap_px);
            let span = uni(rng, self.track_span_px);
            let (a, b) = (half + gap, half + gap + span);
            let (inner_px, outer_px) = if side > 0.0 { (a, b) } else { (-b, -a) };
            RadialTrack {
                inner_px,
                outer_px,
                pitch_px: pitch,
                mark_px: mark,
                depth_grey: Some(uni(rng, self.track_depth_grey).min(bg - 2.0)),
            }
        };
        if rng.random::<f64>() < self.incremental_probability {
            let mark = uni(rng, self.incremental_width_px);
            let pitch = uni(rng, self.incremental_pitch_px);
            let t = track(rng, mark, pitch);
            s.radial_tracks.push(t);
        }
        if rng.random::<f64>() < self.code_bar_probability {
            let mark = uni(rng, self.code_bar_width_px);
            let t = track(rng, mark, 2.0 * mark);
            s.radial_tracks.push(t);
        }
        s.dust_per_frame = uni_n(rng, self.dust_per_frame.map(|v| v as u64)) as usize;
        s.dust_on_ring_per_frame = uni_n(rng, self.dust_on_ring.map(|v| v as u64)) as usize;
        s.dust_radius_px = [0.5, uni(rng, self.dust_max_radius_px)];
        // The pose: the ring's centre column at the middle row, for placing defects on it.
        let e = uni(rng, self.eccentricity_um);
        let theta: f64 = rng.random_range(0.0..360.0);
        let psi: f64 = rng.random_range(0.0..360.0);
        let a = (theta + psi).to_radians();
        let ring_col = (w - 1.0) / 2.0 + e * a.cos() / um_per_px;
        if rng.random::<f64>() < self.scratch_probability {
            let depth = uni(rng, self.scratch_depth_grey);
            let bright = rng.random::<f64>() < 0.25;
            s.scratches.push(Scratch {
                x_px: ring_col + rng.random_range(-3.0..3.0),
                y_px: rng.random_range(0.1 * h..0.9 * h),
                angle_deg: rng.random_range(0.0..180.0),
                width_px: uni(rng, self.scratch_width_px),
                depth_grey: if bright { -depth } else { depth },
                length_px: None,
            });
        }
        if rng.random::<f64>() < self.gap_probability {
            let total = rng.random_range(0.02..self.gap_max_fraction) * h;
            let n = if rng.random::<bool>() { 1 } else { 2 };
            for _ in 0..n {
                let rows = total / n as f64;
                s.ring_gaps.push(RingGap {
                    start_row: rng.random_range(-0.2 * rows..h - 0.8 * rows),
                    rows,
                });
            }
        }
        if rng.random::<f64>() < self.patch_probability {
            s.saturated_patches.push(SaturatedPatch {
                x_px: rng.random_range(0.0..w),
                y_px: rng.random_range(0.0..h),
                radius_px: uni(rng, self.patch_radius_px),
            });
        }
        SceneDraw {
            scene: s,
            theta_deg: theta,
            eccentricity_um: e,
            ecc_angle_deg: psi,
            focus_um: 0.0,
        }
    }
}
