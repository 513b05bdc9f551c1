//! What a rendered frame shows: the grating's features, the imaging, the defects
//! ([`GratingScene`]), and the named scenes `clean`, `realistic` and `dense` ([`ScenePreset`]).
//!
//! Sizes of the features a real grating carries near its alignment ring are given in pixels of
//! the optics' window (the way they are seen and specified, `docs/scenes.md`); the older
//! grating-level quantities (roundness, focus, PSF) keep their micrometres.
//!
//! ```
//! use gonio_sim::frames::{GratingScene, ScenePreset};
//! let s = GratingScene::preset(ScenePreset::Realistic);
//! assert!(!s.track_borders.is_empty());
//! let text = toml::to_string(&s).unwrap();
//! let back: GratingScene = toml::from_str(&text).unwrap();
//! assert_eq!(back, s);
//! ```

use gonio_core::bound::Bound;
use serde::{Deserialize, Serialize};

/// One roundness harmonic of the ring: `amplitude_um·cos(order·φ + phase_rad)`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Roundness {
    /// Order (cycles per turn).
    pub order: u32,
    /// Amplitude, µm.
    pub amplitude_um: f64,
    /// Phase, rad.
    pub phase_rad: f64,
}

/// A group of thin concentric track-border circles (dark lines parallel to the ring).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TrackBorder {
    /// Radial distance of the group's first line from the ring's centre line, px (negative:
    /// inside the ring, toward the grating's centre, i.e. to the left in the window).
    pub offset_px: f64,
    /// Width of each line, px.
    pub width_px: f64,
    /// Lines in the group.
    pub count: u32,
    /// Distance between neighbouring lines, px (away from the ring).
    pub pitch_px: f64,
    /// Depth below the background, grey levels; `None`: the ring's depth.
    pub depth_grey: Option<f64>,
}

/// An annulus of radial marks: incremental lines (thin) or code bars (wide). Radial marks cross
/// the window as near-horizontal lines.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RadialTrack {
    /// Inner edge of the annulus relative to the ring's centre line, px (negative: inside).
    pub inner_px: f64,
    /// Outer edge of the annulus relative to the ring's centre line, px (> `inner_px`).
    pub outer_px: f64,
    /// Period of the marks along the ring's circle, px.
    pub pitch_px: f64,
    /// Width of each mark, px.
    pub mark_px: f64,
    /// Depth below the background, grey levels; `None`: background − `bar_grey`.
    pub depth_grey: Option<f64>,
}

/// A straight scratch across the window, drawn in window pixels.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Scratch {
    /// A point of the scratch's centre line: column, px.
    pub x_px: f64,
    /// … and row, px.
    pub y_px: f64,
    /// Direction from the window's vertical (0: along the columns, like the ring; 90: along a
    /// row), degrees.
    pub angle_deg: f64,
    /// Width, px.
    pub width_px: f64,
    /// Darkening, grey levels (negative: a bright scratch).
    pub depth_grey: f64,
    /// Length centred on (x, y), px; `None`: across the whole window.
    pub length_px: Option<f64>,
}

/// A stretch of rows over which the ring is missing (a damaged or unprinted part of the ring).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RingGap {
    /// First missing row.
    pub start_row: f64,
    /// Missing rows.
    pub rows: f64,
}

/// A round patch of light bright enough to saturate the sensor (a reflection).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SaturatedPatch {
    /// Centre column, px.
    pub x_px: f64,
    /// Centre row, px.
    pub y_px: f64,
    /// Radius, px.
    pub radius_px: f64,
}

/// What the grating and the imaging look like (everything but the optics and the pose).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct GratingScene {
    /// Draw the alignment ring (false: a frame with no ring).
    pub ring_present: bool,
    /// Width of the drawn ring, px; `None`: the optics' `ring_width_um` (the ring as designed).
    pub ring_width_px: Option<f64>,
    /// Background (clear grating) grey level at exposure 1.
    pub background_grey: f64,
    /// Ring grey level at exposure 1.
    pub ring_grey: f64,
    /// Grey level of code bars and lines (for radial tracks without their own depth).
    pub bar_grey: f64,
    /// Roundness harmonics of the ring (default: orders 2–4, 0.375 µm = 0.5 px each).
    pub roundness: Vec<Roundness>,
    /// Draw the radial tracks (`radial_tracks`).
    pub code_tracks: bool,
    /// Radial tracks: code bars and incremental lines (default: wide bars outside the ring,
    /// thin lines inside).
    pub radial_tracks: Vec<RadialTrack>,
    /// Concentric track-border line groups.
    pub track_borders: Vec<TrackBorder>,
    /// Dust specks per frame, anywhere in the window.
    pub dust_per_frame: usize,
    /// Dust specks per frame placed on the ring (its band ± 2 px).
    pub dust_on_ring_per_frame: usize,
    /// Radius range of a dust speck, px.
    pub dust_radius_px: [f64; 2],
    /// Depth range of a dust speck as a fraction of the ring's depth.
    pub dust_depth: [f64; 2],
    /// Scratches.
    pub scratches: Vec<Scratch>,
    /// Rows where the ring is missing.
    pub ring_gaps: Vec<RingGap>,
    /// Saturated patches.
    pub saturated_patches: Vec<SaturatedPatch>,
    /// Relative illumination change across the window's width (0.15: +15 % right to left); half
    /// of it applies down the rows.
    pub illumination_gradient: f64,
    /// Vignetting: relative illumination loss at the window's corners (0.2: the corners get 80 %),
    /// falling off with the square of the distance from the window's centre.
    pub vignetting: f64,
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

/// The lens's in-focus blur σ₀ ([`GratingScene::psf_sigma_um`]): up to a millimetre, the size
/// of the whole window (a blur that wide leaves a flat frame, `ring_contrast_grey` 0).
pub const PSF_SIGMA_UM: Bound = Bound::new(0.0, 1000.0, "µm").lo_excluded();
/// The exposure factor ([`GratingScene::exposure`]): above ≈ 1.3 the background saturates.
pub const EXPOSURE: Bound = Bound::new(0.0, 100.0, "").lo_excluded();
/// Read noise ([`GratingScene::read_noise_grey`]), grey levels RMS.
pub const READ_NOISE_GREY: Bound = Bound::new(0.0, 1000.0, "grey levels");
/// A grey level of the scene (background, ring, bars), before exposure.
pub const GREY: Bound = Bound::new(0.0, 10_000.0, "grey levels");
/// Electrons per grey level for shot noise ([`GratingScene::electrons_per_grey`]).
pub const ELECTRONS_PER_GREY: Bound = Bound::new(0.0, 1e6, "e⁻ per grey level");
/// The lens's numerical aperture ([`GratingScene::numerical_aperture`]).
pub const NUMERICAL_APERTURE: Bound = Bound::new(0.0, 1.5, "");
/// A focus position ([`GratingScene::best_focus_um`], the frame's focus), µm.
pub const FOCUS_UM: Bound = Bound::new(-1e6, 1e6, "µm");

/// Wide code bars outside the ring (the renderer's basic scene): 160–440 px out, 80 px period.
const BASIC_BARS: RadialTrack = RadialTrack {
    inner_px: 160.0,
    outer_px: 440.0,
    pitch_px: 80.0,
    mark_px: 40.0,
    depth_grey: None,
};
/// Thin lines inside the ring (the renderer's basic scene): 2.7 px at 16 px.
const BASIC_LINES: RadialTrack = RadialTrack {
    inner_px: -440.0,
    outer_px: -160.0,
    pitch_px: 16.0,
    mark_px: 8.0 / 3.0,
    depth_grey: None,
};

impl Default for GratingScene {
    /// The renderer's basic scene: the ring (11 px, 130 grey deep), wide code bars outside it,
    /// thin radial lines inside it, 12 dust specks, a 15 % illumination gradient, 2 grey levels
    /// of read noise plus shot noise.
    fn default() -> Self {
        GratingScene {
            ring_present: true,
            ring_width_px: None,
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
            radial_tracks: vec![BASIC_BARS, BASIC_LINES],
            track_borders: Vec::new(),
            dust_per_frame: 12,
            dust_on_ring_per_frame: 0,
            dust_radius_px: [2.0 / 3.0, 1.6 / 0.75],
            dust_depth: [0.3, 0.8],
            scratches: Vec::new(),
            ring_gaps: Vec::new(),
            saturated_patches: Vec::new(),
            illumination_gradient: 0.15,
            vignetting: 0.0,
            read_noise_grey: 2.0,
            electrons_per_grey: 40.0,
            exposure: 1.0,
            best_focus_um: 0.0,
            numerical_aperture: 0.1,
            psf_sigma_um: 0.5,
        }
    }
}

/// The named scenes (`gonio simulate frames --scene`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ScenePreset {
    /// The ring alone on a clear grating: noise and blur only.
    Clean,
    /// A typical grating near its ring: track-border groups on both sides, incremental lines,
    /// code bars, dust (some on the ring), vignetting and an illumination gradient.
    Realistic,
    /// Everything at once and close to the ring: several hundred edge components a frame.
    Dense,
}

/// Blur σ of the lens in µm giving a total edge blur of `sigma_px` at best focus (the renderer
/// adds the pixel's own box blur, pixel²/12).
pub fn psf_sigma_um_for(sigma_px: f64, um_per_px: f64) -> f64 {
    (sigma_px * sigma_px - 1.0 / 12.0).max(0.01).sqrt() * um_per_px
}

impl GratingScene {
    /// One of the named scenes, for the seed's optics (0.75 µm per px).
    pub fn preset(p: ScenePreset) -> Self {
        let base = GratingScene::default();
        let um = 0.75;
        match p {
            ScenePreset::Clean => GratingScene {
                code_tracks: false,
                radial_tracks: Vec::new(),
                dust_per_frame: 0,
                illumination_gradient: 0.0,
                psf_sigma_um: psf_sigma_um_for(0.7, um),
                ..base
            },
            ScenePreset::Realistic => GratingScene {
                ring_grey: 75.0,
                background_grey: 190.0,
                bar_grey: 70.0,
                track_borders: vec![
                    TrackBorder {
                        offset_px: -470.0,
                        width_px: 3.0,
                        count: 2,
                        pitch_px: 16.0,
                        depth_grey: None,
                    },
                    TrackBorder {
                        offset_px: 430.0,
                        width_px: 3.0,
                        count: 1,
                        pitch_px: 16.0,
                        depth_grey: None,
                    },
                    TrackBorder {
                        offset_px: 480.0,
                        width_px: 2.5,
                        count: 3,
                        pitch_px: 16.0,
                        depth_grey: None,
                    },
                ],
                radial_tracks: vec![
                    // Incremental lines between the inner border group and the ring.
                    RadialTrack {
                        inner_px: -400.0,
                        outer_px: -120.0,
                        pitch_px: 20.0,
                        mark_px: 4.0,
                        depth_grey: None,
                    },
                    // Code bars outside the ring.
                    RadialTrack {
                        inner_px: 120.0,
                        outer_px: 380.0,
                        pitch_px: 96.0,
                        mark_px: 48.0,
                        depth_grey: None,
                    },
                ],
                dust_per_frame: 20,
                dust_on_ring_per_frame: 2,
                dust_radius_px: [0.7, 3.0],
                illumination_gradient: 0.12,
                vignetting: 0.2,
                read_noise_grey: 3.0,
                psf_sigma_um: psf_sigma_um_for(0.8, um),
                ..base
            },
            ScenePreset::Dense => GratingScene {
                ring_grey: 95.0,
                background_grey: 185.0,
                bar_grey: 80.0,
                track_borders: vec![
                    TrackBorder {
                        offset_px: -500.0,
                        width_px: 4.0,
                        count: 4,
                        pitch_px: 16.0,
                        depth_grey: None,
                    },
                    TrackBorder {
                        offset_px: -410.0,
                        width_px: 3.0,
                        count: 3,
                        pitch_px: 16.0,
                        depth_grey: None,
                    },
                    TrackBorder {
                        offset_px: 400.0,
                        width_px: 3.0,
                        count: 4,
                        pitch_px: 16.0,
                        depth_grey: None,
                    },
                    TrackBorder {
                        offset_px: 480.0,
                        width_px: 2.0,
                        count: 3,
                        pitch_px: 16.0,
                        depth_grey: None,
                    },
                ],
                radial_tracks: vec![
                    RadialTrack {
                        inner_px: -360.0,
                        outer_px: -25.0,
                        pitch_px: 20.0,
                        mark_px: 5.0,
                        depth_grey: None,
                    },
                    RadialTrack {
                        inner_px: 25.0,
                        outer_px: 200.0,
                        pitch_px: 20.0,
                        mark_px: 3.0,
                        depth_grey: None,
                    },
                    RadialTrack {
                        inner_px: 215.0,
                        outer_px: 385.0,
                        pitch_px: 64.0,
                        mark_px: 32.0,
                        depth_grey: None,
                    },
                ],
                dust_per_frame: 150,
                dust_on_ring_per_frame: 4,
                dust_radius_px: [0.7, 4.0],
                scratches: vec![Scratch {
                    x_px: 600.0,
                    y_px: 270.0,
                    angle_deg: 35.0,
                    width_px: 3.0,
                    depth_grey: 70.0,
                    length_px: None,
                }],
                illumination_gradient: 0.2,
                vignetting: 0.3,
                read_noise_grey: 5.0,
                psf_sigma_um: psf_sigma_um_for(1.2, um),
                ..base
            },
        }
    }

    /// Depth of the ring below the background, grey levels (at exposure 1, before
    /// illumination).
    pub fn ring_depth_grey(&self) -> f64 {
        self.background_grey - self.ring_grey
    }
}
