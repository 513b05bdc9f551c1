//! The station's optics and the detector parameters derived from them.
//!
//! A user describes the camera and the grating ([`Optics`], loadable from TOML by the CLI's
//! `--optics`); everything the stages need — the baseline width d, the structuring elements, the
//! gradient thresholds and the direction range — is derived in [`Params`]. Change the optics, not
//! magic numbers.
//!
//! ```
//! use gonio_vision::Optics;
//! let p = Optics::default().params().unwrap();
//! assert_eq!(p.um_per_px, 0.75);        // 4.5 µm pixels behind a 6× lens
//! assert_eq!(p.baseline_width_px, 11);  // 8 µm ring → 10.7 → 11 px
//! assert_eq!(p.close_radius_px, 11);    // 23×23 disk
//! assert_eq!(p.open_radius_px, 2);      // 5×5 disk
//! ```

use crate::VisionError;
use gonio_core::bound::{Bound, tidy};
use serde::{Deserialize, Serialize};

/// Whether the alignment ring is darker or brighter than its surroundings.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum Polarity {
    /// A dark ring on a bright background (the seed's; a black top-hat keeps it).
    #[default]
    Dark,
    /// A bright ring on a dark background (a white top-hat keeps it).
    Bright,
}

/// The camera, lens and grating as the user knows them. Every field has the seed's default.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Optics {
    /// Sensor width in pixels (1920).
    pub sensor_width_px: u32,
    /// Sensor height in pixels (1080).
    pub sensor_height_px: u32,
    /// Processing window width in pixels, centred on the sensor (1440).
    pub window_width_px: u32,
    /// Processing window height in pixels, centred on the sensor (540).
    pub window_height_px: u32,
    /// Sensor pixel pitch in µm (4.5).
    pub pixel_pitch_um: f64,
    /// Lens magnification (6).
    pub magnification: f64,
    /// Width of the alignment ring on the grating in µm (8).
    pub ring_width_um: f64,
    /// Radius of the alignment ring in µm (4500: gives the seed's ≈ 2 px curvature over the window).
    pub ring_radius_um: f64,
    /// Largest eccentricity the station must see, µm (450); widens the direction range.
    pub max_eccentricity_um: f64,
    /// Dark or bright ring.
    pub polarity: Polarity,
    /// The faintest ring depth (grey levels) that must still be detected (30); sets the thresholds.
    pub min_ring_contrast_grey: f64,
    /// Override of the low gradient threshold (Sobel L1 units); derived when absent.
    pub grad_low: Option<u16>,
    /// Override of the high gradient threshold (Sobel L1 units); derived when absent.
    pub grad_high: Option<u16>,
    /// Override of the baseline filter's half-range around the horizontal gradient, degrees.
    pub direction_tolerance_deg: Option<f64>,
    /// An edge must cover at least this fraction of the window's rows (0.5).
    pub min_edge_fraction: f64,
    /// How much the imaged ring's width may differ from `ring_width_um`, as a fraction (0.35:
    /// a nominal 11 px ring is accepted 8 … 14.9 px wide; the lower end is at least the
    /// opening's diameter + 3 px).
    pub ring_width_tolerance: f64,
    /// The best ring candidate must score this fraction above the runner-up (a different ring
    /// hypothesis), else the frame is ambiguous (0.3).
    pub min_margin: f64,
    /// A frame without a ring and with more than this fraction of pixels at 255 is saturated
    /// (0.01). With a ring, rows where saturation reaches the ring are left out of its fit, and
    /// the frame is saturated when fewer than `min_edge_fraction` of the rows remain.
    pub max_saturated_fraction: f64,
    /// Below this focus measure (mean raw gradient energy, grey²/px², see
    /// `FrameResult::focus`) a frame whose ring is not found is reported out of focus rather than
    /// ring-less (15; sensor noise alone gives ≈ σ²: 8 for 2.9 grey levels RMS).
    pub min_focus: f64,
}

impl Default for Optics {
    fn default() -> Self {
        Optics {
            sensor_width_px: 1920,
            sensor_height_px: 1080,
            window_width_px: 1440,
            window_height_px: 540,
            pixel_pitch_um: 4.5,
            magnification: 6.0,
            ring_width_um: 8.0,
            ring_radius_um: 4500.0,
            max_eccentricity_um: 450.0,
            polarity: Polarity::Dark,
            min_ring_contrast_grey: 30.0,
            grad_low: None,
            grad_high: None,
            direction_tolerance_deg: None,
            min_edge_fraction: 0.5,
            ring_width_tolerance: 0.35,
            min_margin: 0.3,
            max_saturated_fraction: 0.01,
            min_focus: 15.0,
        }
    }
}

/// Everything the stages need, derived from [`Optics`] by [`Optics::params`].
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Params {
    /// Window width (pixels per row).
    pub width: usize,
    /// Window height (rows per frame).
    pub height: usize,
    /// Size of one pixel on the grating, µm.
    pub um_per_px: f64,
    /// Baseline (ring) width d in pixels, rounded.
    pub baseline_width_px: usize,
    /// Radius of the closing disk: d, so its diameter 2d + 1 is odd (23 for d = 11).
    pub close_radius_px: usize,
    /// Radius of the opening disk: ⌊d/4⌋ ≥ 1, diameter ≈ d/2 (5 for d = 11).
    pub open_radius_px: usize,
    /// Low gradient threshold (Sobel L1 magnitude).
    pub grad_low: u16,
    /// High gradient threshold (Sobel L1 magnitude).
    pub grad_high: u16,
    /// Half-range of the baseline filter around 0°/180°, degrees.
    pub direction_tolerance_deg: f64,
    /// `tan(direction_tolerance)` in Q10 fixed point: keep |Gy|·1024 ≤ this·|Gx|.
    pub tan_tolerance_q10: u32,
    /// Minimum pixels of an edge (min_edge_fraction × height).
    pub min_edge_pixels: usize,
    /// Allowed distance between the two edges' columns, px: d·(1 ± `ring_width_tolerance`),
    /// and at least the opening's diameter + 3 px: what the d/2 opening leaves of a thin line
    /// has its edges ≈ the opening's diameter + 1.5 px apart at blur σ = 1.5 px (5.2–6.6 px for
    /// 2–4 px lines, d = 11), a ring's are its width apart.
    pub separation_px: (f64, f64),
    /// Tolerance of the separation band's width fit: `ring_width_tolerance`.
    pub width_tolerance: f64,
    /// Largest change of the separation over the shared rows of two parallel edges, px:
    /// max(1.5, 0.15 d).
    pub parallel_px: f64,
    /// The ring's radius in pixels (its curvature in the window is 1/radius).
    pub ring_radius_px: f64,
    /// Shortest component considered a fragment of an edge, rows: ¾ d, at least 4.
    pub min_fragment_rows: u32,
    /// A track between a candidate's edges, parallel to them, blocks the candidate when its
    /// gradient is at least this fraction of the candidate's weaker edge (0.6: the inner edges
    /// of two neighbouring lines are as strong as their outer ones; what a scratch or a speck
    /// inside the ring leaves after the opening is weaker).
    pub interior_fraction: f64,
    /// See [`Optics::min_margin`].
    pub min_margin: f64,
    /// Largest RMS scatter of a component's pixels about its fitted curve for it to count as
    /// one clean edge, px (0.4: a clean edge's sub-pixel positions scatter ≈ 0.1–0.3 px); a
    /// component scattering more is split into its straight pieces.
    pub max_fragment_rms_px: f64,
    /// Largest RMS scatter of the chosen edges about their curves, px (0.5).
    pub max_edge_rms_px: f64,
    /// Largest change of the ring's width along the window, px (0.5: clean rings change by
    /// ≤ 0.35 px in 99 % of frames, from noise; an edge displaced by half a pixel over part of the
    /// window can move c by a tenth of a pixel).
    pub max_width_change_px: f64,
    /// Most edge pixels a frame keeps for the selection's robust steps (an eighth of the
    /// window's pixels).
    pub max_edge_pixels: usize,
    /// More saturated pixels than this in the whole window make a ring-less frame saturated.
    pub max_saturated_pixels: usize,
    /// Focus threshold (see [`Optics::min_focus`]).
    pub min_focus: f64,
    /// True for a bright ring: the input is inverted before the black top-hat.
    pub invert: bool,
}

/// Largest sensor side, px: a frame of the sensor's size is read whole, so this bounds its memory
/// (256 MiB at most; real sensors are smaller).
pub const MAX_SENSOR_PX: u32 = 16384;

/// Most pixels in the processing window (width × height): the detector keeps several planes of
/// the window per frame (about 20 bytes a pixel), so this bounds a frame's memory to ≈ 330 MB
/// (16 Mpx, e.g. 4096 × 4096; the station's window is 1440 × 540 = 0.8 Mpx).
pub const MAX_WINDOW_PIXELS: u64 = 1 << 24;

/// Widest ring once imaged, px: the morphology's structuring elements grow with it.
pub const MAX_RING_WIDTH_PX: f64 = 512.0;

/// A sensor's pixel pitch ([`Optics::pixel_pitch_um`]).
pub const PIXEL_PITCH_UM: Bound = Bound::new(0.0, 1000.0, "µm").lo_excluded();
/// A lens's magnification ([`Optics::magnification`]).
pub const MAGNIFICATION: Bound = Bound::new(0.0, 1000.0, "").lo_excluded();
/// The ring's width and radius on the grating ([`Optics::ring_width_um`],
/// [`Optics::ring_radius_um`]): up to a metre.
pub const RING_UM: Bound = Bound::new(0.0, 1e6, "µm").lo_excluded();
/// The faintest ring depth ([`Optics::min_ring_contrast_grey`]): an 8-bit frame's range.
pub const RING_CONTRAST_GREY: Bound = Bound::new(0.0, 255.0, "grey levels").lo_excluded();
/// The largest eccentricity to see ([`Optics::max_eccentricity_um`]).
pub const MAX_ECCENTRICITY_UM: Bound = Bound::new(0.0, 1e6, "µm");
/// The focus threshold ([`Optics::min_focus`]): grey²/px², at most the largest a frame of 8-bit
/// grey levels can show.
pub const MIN_FOCUS: Bound = Bound::new(0.0, 1e6, "grey²/px²");

fn bad(name: &'static str, found: impl ToString, expected: &str) -> VisionError {
    VisionError::Optics {
        name,
        found: tidy(&found.to_string()),
        expected: expected.to_string(),
    }
}

impl Optics {
    /// Cuts the processing window out of a frame (row-major, 8-bit): a frame of the window's
    /// size is returned as it is; a frame of the sensor's size gives its centred window, copied
    /// into `scratch` (which keeps its allocation from frame to frame).
    ///
    /// # Errors
    /// [`VisionError::FrameSize`] if `frame` is not `width × height` bytes,
    /// [`VisionError::FrameShape`] if the frame is neither the window nor the sensor in size.
    ///
    /// ```
    /// use gonio_vision::Optics;
    /// let o = Optics { sensor_width_px: 8, sensor_height_px: 4, window_width_px: 4,
    ///                  window_height_px: 2, ..Optics::default() };
    /// let sensor: Vec<u8> = (0..32).collect();
    /// let mut scratch = Vec::new();
    /// assert_eq!(o.crop_window(8, 4, &sensor, &mut scratch).unwrap(), &[10, 11, 12, 13, 18, 19, 20, 21]);
    /// assert!(o.crop_window(5, 5, &[0; 25], &mut scratch).is_err());
    /// ```
    pub fn crop_window<'a>(
        &self,
        width: usize,
        height: usize,
        frame: &'a [u8],
        scratch: &'a mut Vec<u8>,
    ) -> Result<&'a [u8], VisionError> {
        if frame.len() != width * height {
            return Err(VisionError::FrameSize {
                expected: width * height,
                found: frame.len(),
                width,
                height,
            });
        }
        let (ww, wh) = (
            self.window_width_px as usize,
            self.window_height_px as usize,
        );
        let (sw, sh) = (
            self.sensor_width_px as usize,
            self.sensor_height_px as usize,
        );
        if (width, height) == (ww, wh) {
            return Ok(frame);
        }
        if (width, height) == (sw, sh) && ww <= sw && wh <= sh {
            let (x0, y0) = ((sw - ww) / 2, (sh - wh) / 2);
            scratch.clear();
            for row in frame.chunks_exact(sw).skip(y0).take(wh) {
                scratch.extend_from_slice(&row[x0..x0 + ww]);
            }
            return Ok(scratch);
        }
        Err(VisionError::FrameShape {
            width,
            height,
            window_width: ww,
            window_height: wh,
            sensor_width: sw,
            sensor_height: sh,
        })
    }

    /// Derives the detector parameters.
    ///
    /// # Errors
    /// [`VisionError::Optics`] naming the first parameter out of range (non-positive sizes, a
    /// window larger than the sensor, a ring narrower than 2 px or wider than a quarter of the
    /// window, thresholds with low > high, fractions outside 0–1).
    pub fn params(&self) -> Result<Params, VisionError> {
        for (name, v, bound) in [
            ("pixel_pitch_um", self.pixel_pitch_um, PIXEL_PITCH_UM),
            ("magnification", self.magnification, MAGNIFICATION),
            ("ring_width_um", self.ring_width_um, RING_UM),
            ("ring_radius_um", self.ring_radius_um, RING_UM),
            (
                "min_ring_contrast_grey",
                self.min_ring_contrast_grey,
                RING_CONTRAST_GREY,
            ),
            (
                "max_eccentricity_um",
                self.max_eccentricity_um,
                MAX_ECCENTRICITY_UM,
            ),
            ("min_focus", self.min_focus, MIN_FOCUS),
        ] {
            if let Err(e) = bound.check(v) {
                return Err(bad(name, v, &e.to_string()));
            }
        }
        if self.window_width_px < 16
            || self.window_width_px > self.sensor_width_px
            || self.window_width_px > 32768
        {
            return Err(bad(
                "window_width_px",
                self.window_width_px,
                &format!(
                    "16 … sensor_width_px ({}), at most 32768",
                    self.sensor_width_px
                ),
            ));
        }
        if self.window_height_px < 16
            || self.window_height_px > self.sensor_height_px
            || self.window_height_px > 32768
        {
            return Err(bad(
                "window_height_px",
                self.window_height_px,
                &format!(
                    "16 … sensor_height_px ({}), at most 32768",
                    self.sensor_height_px
                ),
            ));
        }
        for (name, v) in [
            ("sensor_width_px", self.sensor_width_px),
            ("sensor_height_px", self.sensor_height_px),
        ] {
            if v > MAX_SENSOR_PX {
                return Err(bad(name, v, "at most 16384 px"));
            }
        }
        let area = u64::from(self.window_width_px) * u64::from(self.window_height_px);
        if area > MAX_WINDOW_PIXELS {
            return Err(bad(
                "window_width_px",
                format!(
                    "{} (× window_height_px {} = {area} px)",
                    self.window_width_px, self.window_height_px
                ),
                &format!("a window of at most {MAX_WINDOW_PIXELS} pixels (e.g. 4096 × 4096)"),
            ));
        }
        for (name, v) in [
            ("min_edge_fraction", self.min_edge_fraction),
            ("max_saturated_fraction", self.max_saturated_fraction),
            ("min_margin", self.min_margin),
        ] {
            if !(0.0..=1.0).contains(&v) {
                return Err(bad(name, v, "a fraction 0 … 1"));
            }
        }
        if !(self.ring_width_tolerance > 0.0 && self.ring_width_tolerance < 0.9) {
            return Err(bad(
                "ring_width_tolerance",
                self.ring_width_tolerance,
                "a fraction > 0 and < 0.9",
            ));
        }
        let um_per_px = self.pixel_pitch_um / self.magnification;
        let width = self.window_width_px as usize;
        let height = self.window_height_px as usize;
        let d = (self.ring_width_um / um_per_px).round();
        if !(2.0..=(width.min(height) as f64 / 4.0).min(MAX_RING_WIDTH_PX)).contains(&d) {
            return Err(bad(
                "ring_width_um",
                self.ring_width_um,
                "a ring 2 px … a quarter of the window (and at most 512 px) wide once imaged",
            ));
        }
        let d = d as usize;
        // Sobel L1 peak on a blurred step of height A is ≈ 8·A/3; the high threshold sits at half
        // of that for the faintest ring accepted, the low one at half the high one.
        let high = self
            .grad_high
            .unwrap_or((self.min_ring_contrast_grey * 4.0 / 3.0).round().max(2.0) as u16);
        let low = self.grad_low.unwrap_or((high / 2).max(1));
        if low > high || low == 0 {
            return Err(bad("grad_low", low, &format!("1 … grad_high ({high})")));
        }
        // The ring's tangent tilts by asin(y/R) at the window's top and bottom rows, and the
        // eccentricity's tangential part moves the visible arc by up to e: keep that plus 10°.
        let tol = match self.direction_tolerance_deg {
            Some(t) => t,
            None => {
                let half_um = height as f64 * um_per_px / 2.0;
                let s = ((half_um + self.max_eccentricity_um) / self.ring_radius_um).min(1.0);
                s.asin().to_degrees() + 10.0
            }
        };
        if !(tol > 0.0 && tol < 45.0) {
            return Err(bad(
                "direction_tolerance_deg",
                tol,
                "0 … 45 (derived from ring_radius_um and max_eccentricity_um when absent)",
            ));
        }
        Ok(Params {
            width,
            height,
            um_per_px,
            baseline_width_px: d,
            close_radius_px: d,
            open_radius_px: (d / 4).max(1),
            grad_low: low,
            grad_high: high,
            direction_tolerance_deg: tol,
            tan_tolerance_q10: (tol.to_radians().tan() * 1024.0).round() as u32,
            min_edge_pixels: (self.min_edge_fraction * height as f64).ceil() as usize,
            separation_px: {
                let (df, t) = (d as f64, self.ring_width_tolerance);
                let open_d = (2 * (d / 4).max(1) + 1) as f64;
                ((df * (1.0 - t)).max(open_d + 3.0), df * (1.0 + t))
            },
            width_tolerance: self.ring_width_tolerance,
            parallel_px: (0.15 * d as f64).max(1.5),
            ring_radius_px: self.ring_radius_um / um_per_px,
            min_fragment_rows: (3 * d as u32 / 4).max(4),
            interior_fraction: 0.6,
            min_margin: self.min_margin,
            max_fragment_rms_px: 0.4,
            max_edge_rms_px: 0.5,
            max_width_change_px: 0.5,
            max_edge_pixels: width * height / 8,
            max_saturated_pixels: (self.max_saturated_fraction * (width * height) as f64) as usize,
            min_focus: self.min_focus,
            invert: self.polarity == Polarity::Bright,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_window_or_ring_that_needs_gigabytes_is_refused_before_any_frame() {
        let big = Optics {
            sensor_width_px: 16384,
            sensor_height_px: 16384,
            window_width_px: 16384,
            window_height_px: 16384,
            ..Optics::default()
        };
        let e = big.params().unwrap_err().to_string();
        assert!(
            e.contains("window_width_px") && e.contains("16777216"),
            "{e}"
        );
        // The largest window allowed is accepted.
        let ok = Optics {
            window_width_px: 4096,
            window_height_px: 4096,
            ..big.clone()
        };
        assert!(ok.params().is_ok(), "{:?}", ok.params().err());
        // A ring 1000 px wide once imaged, in a window that would hold it.
        let wide = Optics {
            ring_width_um: 1000.0 * ok.pixel_pitch_um / ok.magnification,
            ..ok
        };
        let e = wide.params().unwrap_err().to_string();
        assert!(e.contains("ring_width_um") && e.contains("512"), "{e}");
    }
}
