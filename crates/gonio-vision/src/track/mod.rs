//! The tracked ring detector: after a frame measured whole, the next frames are measured in a
//! band of columns around the ring's predicted column, with the whole-frame detector as the
//! fallback whenever the band disagrees ([`Tracker`]).
//!
//! Between two frames at 100 frames/s the ring moves a few pixels, so most of a frame's
//! pixels tell nothing new. The tracker predicts the ring's edges from the last frames (the
//! last column and its change per frame, the edges' extent from the last pair fit), and runs
//! **the detector's own stages** over a band of columns: the predicted edges ±
//! [`TRACK_HALF_WIDTH_PX`] ([`SEARCH_HALF_WIDTH_PX`] before the motion is known),
//! [`GUARD_PX`] more of exact columns for what the ring's refit reads beside an edge, and the
//! stages' reach ([`stage_reach_px`]: 31 px for the station's 11 px ring) on either side,
//! rounded up to 64 columns — 128 of the station's 1440 for a ring at e ≤ 150 µm. What is the
//! same by construction, and what is not:
//!
//! - **The edges** on the band's exact columns are the whole frame's bit for bit (every stage
//!   up to the filling reads a fixed reach of columns, and treats the frame's side alike
//!   wherever it lies), and so is every component on them that a cut side of the band does not
//!   touch. The components' sums and the pixels' columns are moved into the frame's columns in
//!   integers, and the ring is chosen by the same selection ([`crate::select`]) with the whole
//!   frame's parameters: the same edge model (a rising and a falling edge, parallel, a ring's
//!   width apart, flat between), the same refit, sub-pixel estimate and validity checks, the
//!   same saturated rows (from the whole frame's raw rows).
//! - **The raw statistics** (`focus`, `mean_gradient`, `saturated_px`) are taken over the whole
//!   frame, by the detector's own code: the same values (the autofocus reads them).
//! - **What differs**: the frame's curvature (the median of the long clean edges' curvatures)
//!   is taken from the band's edges, which bends only short pieces of an edge and the pixel
//!   gates of the refit's first step, not the fit that gives c; `components` counts the
//!   components wholly on the band's exact columns; and the band cannot see a ring candidate
//!   elsewhere in the frame. `score` and `margin` are therefore the last whole frame's, scaled
//!   by how the ring's own score changed since ([`Tracker`]). A candidate elsewhere is a
//!   concentric edge pair or a defect passing by; the last whole frame saw the concentric ones
//!   (tracking starts only when its margin is [`MARGIN_HEADROOM`] above the optics'
//!   `min_margin`), and the whole frame is measured again at least every [`RECHECK_FRAMES`]
//!   frames.
//!
//! A frame is measured whole instead ([`Fallback`]) when the band cannot vouch for it: no
//! ring is tracked; the frames are not consecutive; the band finds no valid ring (so every
//! invalid frame and its reason are the whole-frame detector's); an edge lies outside the
//! searched columns or a component cut by the band's side reaches into them; a second ring
//! candidate in the band; the ring farther from its prediction than the plausible motion; its
//! score below 80 % of the last whole frame's, or the margin left over that frame's runner-up
//! too small; its edges' gradient (or the frame's focus, from one frame to the next) fallen
//! (blur); saturation in the searched columns; its width changed; so many edge pixels that the
//! whole frame's list could overflow. After a whole frame with a valid ring the band is run on
//! that same frame too, and tracking (re)starts only when it agrees with the whole frame within
//! [`ANCHOR_TOL_PX`].
//! Validity is only ever reported from the band when the band finds the ring valid; every
//! invalid frame is the whole-frame detector's.
//!
//! Cost on the station's window: the band's stages, the selection among the band's few
//! components and the raw statistics of the whole frame, about a sixth of the whole frame's
//! time (BENCHMARKS.md). The frame is read once: row by row, its raw statistics and then its
//! band into the stages, while the row is in the L1 cache (the sums are integers added in row
//! order, the values of a separate pass; the stages get the same rows in the same order). The
//! stages after the morphology (blur, Sobel, segmentation, filling), whose cost on a band two
//! 64-byte steps wide is as much per row as per step, run over five strips of the band's rows
//! side by side (`track::strips`: each strip's seams are cut sides like the band's own, its
//! rows five more than a fifth at either end, its columns the band's exact ones and five more
//! at either side; ≈ 20 % off a tracked frame). The edge list handed to the selection keeps
//! its storage from frame to frame. Written here because it is the detector's product, not a
//! general tracker.
//!
//! Errors: [`VisionError::FrameSize`] for a frame of the wrong size, as the whole detector.
//!
//! ```
//! use gonio_vision::{Detector, Optics, track::Tracker};
//! let optics = Optics { window_width_px: 480, window_height_px: 64, ..Optics::default() };
//! let (mut det, mut tracker) = (Detector::new(&optics).unwrap(), Tracker::new(&optics).unwrap());
//! for k in 0..5u64 {
//!     // A dark 11 px ring moving right by 1.5 px a frame.
//!     let c = 200.0 + 1.5 * k as f64;
//!     let frame: Vec<u8> = (0..480 * 64)
//!         .map(|i| if ((i % 480) as f64 - c).abs() <= 5.5 { 70 } else { 190 })
//!         .collect();
//!     let r = tracker.detect(&frame, k, &mut det, None).unwrap();
//!     assert!((r.c_px.unwrap() - c).abs() < 0.05);
//!     assert_eq!(r.tracked, k > 0); // the first frame is measured whole
//! }
//! ```

mod band;
mod strips;

pub use band::stage_reach_px;

use crate::features::frame_result;
use crate::focus::FrameFocus;
use crate::pipeline::{Detector, LowerHalf, RawSums};
use crate::select::{Candidate, PairFit};
use crate::{FrameResult, Optics, Params, VisionError};
use band::Band;

/// Columns searched on either side of the ring's predicted edges before its motion is known
/// (from two measured frames), px: a ring that stays in the station's window (1440 px: an
/// amplitude of at most 720 px) moves at most 720 px · 1.8° ≈ 22.6 px a frame at 1.8° a frame.
pub const SEARCH_HALF_WIDTH_PX: f64 = 24.0;
/// Columns searched on either side of the ring's predicted edges per frame of gap once its
/// motion is known, px (at most [`SEARCH_HALF_WIDTH_PX`]).
pub const TRACK_HALF_WIDTH_PX: f64 = 8.0;
/// Exact columns beyond the searched ones on either side, px: what the ring's refit reads
/// beside an edge (other edges within 6 px, pixels within 1.5 px of its curve) and a pixel.
pub const GUARD_PX: f64 = 8.0;
/// Most frames from one measured frame to the next for the ring to be tracked across them.
pub const MAX_GAP_FRAMES: u64 = 4;
/// Largest distance of the ring from its predicted column per frame of gap, px, once its
/// motion is known (from two measured frames); before that, [`SEARCH_HALF_WIDTH_PX`].
pub const JUMP_PX: f64 = 4.0;
/// The ring's score in the band must stay at least this fraction of the anchor frame's.
pub const KEEP_SCORE: f64 = 0.8;
/// Tracking starts only when the whole frame's margin is at least the optics' `min_margin`
/// plus this, and goes on while the margin kept over that frame's runner-up is.
pub const MARGIN_HEADROOM: f64 = 0.1;
/// The ring's weaker edge gradient must stay at least this fraction of the anchor frame's.
pub const KEEP_GRADIENT: f64 = 0.7;
/// The frame's focus measure must stay at least this fraction of the last measured frame's: a
/// blur comes from one frame to the next, while the measure also follows what the window
/// shows as the grating turns (by half over a quarter turn of a ring at e = 500 µm).
pub const KEEP_FOCUS: f64 = 0.5;
/// On the anchor frame the band's c must equal the whole frame's within this, px.
pub const ANCHOR_TOL_PX: f64 = 0.01;
/// The whole frame is measured again after at most this many frames measured in the band.
pub const RECHECK_FRAMES: u64 = 256;
/// A band whose edge pixels on its exact columns, spread over the whole frame at their density
/// there, would fill more than this fraction of the whole frame's edge list.
pub const DENSE_FRACTION: f64 = 0.5;

/// Why a frame was measured whole rather than in the band.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[non_exhaustive]
pub enum Fallback {
    /// No ring tracked: the first frame, after a frame without a valid ring, or while the
    /// band has not yet agreed with a whole frame.
    NoTrack,
    /// The whole frame is due again ([`RECHECK_FRAMES`]).
    Recheck,
    /// More than [`MAX_GAP_FRAMES`] frames since the last measured one, or frames out of
    /// order.
    Gap,
    /// The band would be the whole frame's width.
    TooWide,
    /// The band found no valid ring.
    Invalid,
    /// A ring edge outside the searched columns, or a component cut by the band's side
    /// reaching into them.
    AtBorder,
    /// A second ring candidate in the band.
    SecondCandidate,
    /// The ring farther from its predicted column than the plausible motion.
    Jump,
    /// The ring's score below [`KEEP_SCORE`] of the anchor frame's, or the margin kept over
    /// that frame's runner-up below the optics' `min_margin` + [`MARGIN_HEADROOM`].
    Weak,
    /// The ring's edge gradient or the band's focus fallen (blur).
    Blurred,
    /// Saturated pixels in the searched columns.
    Saturated,
    /// The ring's width changed by more than the parallel tolerance.
    Width,
    /// So many edge pixels that the whole frame's list could overflow.
    Dense,
}

impl Fallback {
    /// Every fallback, in the order of [`Tracker::fallbacks`].
    pub const ALL: [Fallback; 13] = [
        Fallback::NoTrack,
        Fallback::Recheck,
        Fallback::Gap,
        Fallback::TooWide,
        Fallback::Invalid,
        Fallback::AtBorder,
        Fallback::SecondCandidate,
        Fallback::Jump,
        Fallback::Weak,
        Fallback::Blurred,
        Fallback::Saturated,
        Fallback::Width,
        Fallback::Dense,
    ];

    /// The fallback's name (`no_track`, `recheck`, `invalid`, …).
    pub fn name(self) -> &'static str {
        match self {
            Fallback::NoTrack => "no_track",
            Fallback::Recheck => "recheck",
            Fallback::Gap => "gap",
            Fallback::TooWide => "too_wide",
            Fallback::Invalid => "invalid",
            Fallback::AtBorder => "at_border",
            Fallback::SecondCandidate => "second_candidate",
            Fallback::Jump => "jump",
            Fallback::Weak => "weak",
            Fallback::Blurred => "blurred",
            Fallback::Saturated => "saturated",
            Fallback::Width => "width",
            Fallback::Dense => "dense",
        }
    }
}

/// A measured ring: its frame, c, and the columns its edges span over the window (left edge's
/// least to right edge's greatest, with the ring's curvature), px; and its frame's focus
/// measure ([`KEEP_FOCUS`]).
#[derive(Debug, Clone, Copy)]
struct Ring {
    index: u64,
    c: f64,
    lo: f64,
    hi: f64,
    focus: f64,
}

impl Ring {
    /// Its motion per frame on to the ring `later`, when this one was measured at most
    /// [`MAX_GAP_FRAMES`] frames before it.
    fn velocity_to(&self, later: &Ring) -> Option<f64> {
        let gap = later.index.checked_sub(self.index)?;
        (1..=MAX_GAP_FRAMES)
            .contains(&gap)
            .then(|| (later.c - self.c) / gap as f64)
    }

    /// From a whole frame's result: its edges' fitted lines, widened by the part of the
    /// ring's curvature a line leaves out.
    fn of(r: &FrameResult, index: u64, p: &Params) -> Option<Ring> {
        let (c, [l, rt]) = (r.c_px?, r.edges.as_slice().try_into().ok()?);
        let h = p.height as f64;
        let at = |e: &crate::EdgeLine, y: f64| e.column_px + e.slope * (y - e.row_px);
        // A line fitted to a parabola departs from it by up to two thirds of its sagitta.
        let s = l.slope.abs().max(rt.slope.abs());
        let sag = 2.0 / 3.0 * h * h / (8.0 * p.ring_radius_px) * (1.0 + s * s).powf(1.5) + 1.0;
        Some(Ring {
            index,
            c,
            lo: at(&l, 0.0).min(at(&l, h - 1.0)) - sag,
            hi: at(&rt, 0.0).max(at(&rt, h - 1.0)) + sag,
            focus: r.focus,
        })
    }

    /// From the ring's pair fit: its edges' curves over the window's rows, and a pixel for
    /// the edge pixels' scatter about them (`focus`: the frame's).
    fn of_fit(f: &PairFit, index: u64, h: usize, focus: f64) -> Ring {
        let um = (h - 1) as f64;
        let extremes = |a: f64| {
            let at = |u: f64| a + f.b * u + f.q * u * u;
            let mut v = [at(-um), at(um), at(-um)];
            if f.q != 0.0 && (f.b / (2.0 * f.q)).abs() <= um {
                v[2] = at(-f.b / (2.0 * f.q));
            }
            v.iter()
                .fold((f64::MAX, f64::MIN), |(lo, hi), &x| (lo.min(x), hi.max(x)))
        };
        Ring {
            index,
            c: f.c_px(h),
            lo: extremes(f.a_left).0 - 1.0,
            hi: extremes(f.a_right).1 + 1.0,
            focus,
        }
    }
}

/// What the band saw of the ring on the frame tracking started from, and the whole frame's
/// score and margin there.
#[derive(Debug, Clone, Copy)]
struct Anchor {
    strength: f64,
    gradient: f64,
    separation: f64,
    score: f64,
    margin: f64,
}

/// The ring candidate's score before the frame-relative normalisation of
/// [`crate::select::select`] (its score times the frame's strongest candidate's gradient):
/// gradient × (½ + ½·strong share) × coverage × width fit × balance. A property of the ring
/// alone, comparable from frame to frame and between the band and the whole frame.
fn strength(c: &Candidate, p: &Params) -> f64 {
    let d = p.baseline_width_px as f64;
    let coverage = (c.shared_rows as f64 / p.height as f64).min(1.0);
    let x = (c.separation_px - d) / (p.width_tolerance * d);
    let width = (1.0 - 0.5 * x * x).max(0.0);
    c.gradient * (0.5 + 0.5 * c.strong_share) * coverage * width * c.balance
}

/// The tracked detector's state (see the module documentation). Frames go through
/// [`Tracker::detect`] in order, with the whole-frame detector for the optics.
#[derive(Debug, Clone)]
pub struct Tracker {
    p: Params,
    band: Band,
    raw: RawSums,
    focus: FrameFocus,
    anchor: Option<Anchor>,
    last: Option<Ring>,
    /// The ring on the measured frame before `last`, whatever its motion.
    prev: Option<Ring>,
    /// The motion from `prev` to `last` is the ring's: the band is placed by it
    /// ([`Tracker::after_whole`] decides).
    motion_known: bool,
    /// Frames measured in the band since the last whole one.
    since_whole: u64,
    /// Whole frames to go before the band is tried on one again, and the failed tries in a
    /// row.
    cooldown: u32,
    failed: u32,
    tracked: u64,
    whole: u64,
    fallbacks: [u64; Fallback::ALL.len()],
    last_fallback: Option<Fallback>,
}

impl Tracker {
    /// A tracker for the optics' window.
    ///
    /// # Errors
    /// [`VisionError::Optics`] if the optics are invalid.
    pub fn new(optics: &Optics) -> Result<Tracker, VisionError> {
        Ok(Tracker::from_params(optics.params()?))
    }

    /// A tracker from already derived parameters (a [`Detector`]'s).
    pub fn from_params(p: Params) -> Tracker {
        Tracker {
            p,
            band: Band::default(),
            raw: RawSums::default(),
            focus: FrameFocus::default(),
            anchor: None,
            last: None,
            prev: None,
            motion_known: false,
            since_whole: 0,
            cooldown: 0,
            failed: 0,
            tracked: 0,
            whole: 0,
            fallbacks: [0; Fallback::ALL.len()],
            last_fallback: None,
        }
    }

    /// Forgets the ring: the next frame is measured whole.
    pub fn reset(&mut self) {
        self.anchor = None;
        self.last = None;
        self.prev = None;
        self.motion_known = false;
        self.cooldown = 0;
        self.failed = 0;
    }

    /// Frames measured in the band so far.
    pub fn tracked_frames(&self) -> u64 {
        self.tracked
    }

    /// Frames measured whole so far.
    pub fn whole_frames(&self) -> u64 {
        self.whole
    }

    /// How many frames fell back for each reason, in the order of [`Fallback::ALL`].
    pub fn fallbacks(&self) -> impl Iterator<Item = (Fallback, u64)> + '_ {
        Fallback::ALL
            .iter()
            .copied()
            .zip(self.fallbacks.iter().copied())
    }

    /// Why the last frame was measured whole (`None`: it was measured in the band).
    pub fn last_fallback(&self) -> Option<Fallback> {
        self.last_fallback
    }

    /// Detects the ring in frame `index` (the window, row-major; indices increase from frame
    /// to frame, a gap for each frame not seen): in the band when it can vouch for the result,
    /// else with `full` (on two threads with `lower`: [`Detector::detect_split`]).
    ///
    /// # Errors
    /// [`VisionError::FrameSize`] if `frame` is not the window's size.
    pub fn detect(
        &mut self,
        frame: &[u8],
        index: u64,
        full: &mut Detector,
        lower: Option<&mut LowerHalf>,
    ) -> Result<FrameResult, VisionError> {
        let fits = frame.len() == self.p.width * self.p.height && *full.params() == self.p;
        if fits {
            match self.in_band(frame, index) {
                Ok(r) => {
                    self.tracked += 1;
                    self.since_whole += 1;
                    self.last_fallback = None;
                    return Ok(r);
                }
                Err(why) => {
                    self.fallbacks[Fallback::ALL.iter().position(|&f| f == why).unwrap_or(0)] += 1;
                    self.last_fallback = Some(why);
                }
            }
        }
        let r = match lower {
            Some(lower) => full.detect_split(frame, lower)?,
            None => full.detect(frame)?,
        };
        self.whole += 1;
        self.since_whole = 0;
        if fits {
            self.after_whole(frame, index, &r);
        }
        Ok(r)
    }

    /// The frame measured in the band, or why not.
    fn in_band(&mut self, frame: &[u8], index: u64) -> Result<FrameResult, Fallback> {
        let (Some(anchor), Some(last)) = (self.anchor, self.last) else {
            return Err(Fallback::NoTrack);
        };
        if self.since_whole >= RECHECK_FRAMES {
            return Err(Fallback::Recheck);
        }
        if index <= last.index || index - last.index > MAX_GAP_FRAMES {
            return Err(Fallback::Gap);
        }
        let gap = (index - last.index) as f64;
        let velocity = self
            .prev
            .filter(|_| self.motion_known)
            .and_then(|q| q.velocity_to(&last));
        let shift = velocity.unwrap_or(0.0) * gap;
        let predicted = last.c + shift;
        let half = velocity.map_or(SEARCH_HALF_WIDTH_PX, |_| {
            (TRACK_HALF_WIDTH_PX * gap).min(SEARCH_HALF_WIDTH_PX)
        });
        let search = (last.lo + shift - half, last.hi + shift + half);
        let p = &self.p;
        let (w, h) = (p.width, p.height);
        let b = self
            .band
            .select(frame, search, GUARD_PX, (&mut self.raw, &mut self.focus), p)
            .ok_or(Fallback::TooWide)?;
        let sel = &b.selection;
        let best = sel.best.as_ref().ok_or(Fallback::Invalid)?;
        if sel.margin.is_some_and(|m| m < 1.0) {
            return Err(Fallback::SecondCandidate);
        }
        if b.cut_in_search
            || (best.fit.left.min_col as f64) < search.0
            || (best.fit.right.max_col as f64) > search.1
        {
            return Err(Fallback::AtBorder);
        }
        let spread = b.pixels as f64 * w as f64 / b.place.exact_width() as f64;
        if spread > DENSE_FRACTION * p.max_edge_pixels as f64 {
            return Err(Fallback::Dense);
        }
        let saturated =
            self.raw.saturated_runs().iter().any(|s| {
                s.last as f64 >= search.0 - GUARD_PX && s.first as f64 <= search.1 + GUARD_PX
            });
        if saturated {
            return Err(Fallback::Saturated);
        }
        let strength = strength(best, p);
        let (gradient, separation) = (best.gradient, best.separation_px);
        let stats = self.raw.stats(w, h);
        let ring = Ring::of_fit(&best.fit, index, h, stats.focus);
        let mut r = frame_result(b.selection, b.components, stats, p);
        let c = match r.c_px {
            Some(c) if r.valid => c,
            _ => return Err(Fallback::Invalid),
        };
        let reach = velocity.map_or(SEARCH_HALF_WIDTH_PX, |_| JUMP_PX * gap);
        if (c - predicted).abs() > reach {
            return Err(Fallback::Jump);
        }
        let margin = 1.0 - (1.0 - anchor.margin) * anchor.strength / strength;
        if strength < KEEP_SCORE * anchor.strength || margin < p.min_margin + MARGIN_HEADROOM {
            return Err(Fallback::Weak);
        }
        if gradient < KEEP_GRADIENT * anchor.gradient || stats.focus < KEEP_FOCUS * last.focus {
            return Err(Fallback::Blurred);
        }
        if (separation - anchor.separation).abs() > p.parallel_px {
            return Err(Fallback::Width);
        }
        r.tracked = true;
        r.score = Some((anchor.score * strength / anchor.strength).min(1.0));
        r.margin = Some(margin.clamp(0.0, 1.0));
        (self.prev, self.motion_known) = (Some(last), true);
        self.last = Some(ring);
        Ok(r)
    }

    /// After a whole frame: tracking (re)starts from it when its ring is valid and the band
    /// on the same frame agrees; a frame without a valid ring ends it.
    fn after_whole(&mut self, frame: &[u8], index: u64, r: &FrameResult) {
        let ring = r.valid.then(|| Ring::of(r, index, &self.p)).flatten();
        let Some(ring) = ring else {
            self.reset();
            return;
        };
        // The motion from the frame before when it is plausible: within the search before the
        // motion is known, or the motion of the two frames before carried on (within JUMP_PX
        // a frame: a ring entering the window faster than SEARCH_HALF_WIDTH_PX a frame). A
        // ring that jumped has no motion to go by.
        let before = self
            .prev
            .zip(self.last)
            .and_then(|(q, l)| q.velocity_to(&l));
        self.motion_known = self
            .last
            .and_then(|l| l.velocity_to(&ring))
            .is_some_and(|v| {
                v.abs() <= SEARCH_HALF_WIDTH_PX || before.is_some_and(|u| (v - u).abs() <= JUMP_PX)
            });
        self.prev = self.last;
        self.last = Some(ring);
        self.anchor = None;
        if self.cooldown > 0 {
            self.cooldown -= 1;
            return;
        }
        self.anchor = self.anchor_on(frame, r, ring);
        if self.anchor.is_some() {
            self.failed = 0;
        } else {
            // Each failed try waits one whole frame more before the next (at most 16).
            self.failed = (self.failed + 1).min(16);
            self.cooldown = self.failed;
        }
    }

    /// The band on the whole frame just measured, centred on its ring: the anchor when it
    /// agrees (the ring's columns then from the band's fit).
    fn anchor_on(&mut self, frame: &[u8], r: &FrameResult, ring: Ring) -> Option<Anchor> {
        let p = &self.p;
        let (score, margin) = (r.score?, r.margin?);
        if margin < p.min_margin + MARGIN_HEADROOM {
            return None;
        }
        let search = (
            ring.lo - SEARCH_HALF_WIDTH_PX,
            ring.hi + SEARCH_HALF_WIDTH_PX,
        );
        let b = self
            .band
            .select(frame, search, GUARD_PX, (&mut self.raw, &mut self.focus), p)?;
        let sel = &b.selection;
        let best = sel.best.as_ref()?;
        if b.cut_in_search || sel.margin.is_none_or(|m| m < 1.0) {
            return None;
        }
        let anchor = Anchor {
            strength: strength(best, p),
            gradient: best.gradient,
            separation: best.separation_px,
            score,
            margin,
        };
        let fitted = Ring::of_fit(&best.fit, ring.index, p.height, ring.focus);
        let banded = frame_result(
            b.selection,
            b.components,
            self.raw.stats(p.width, p.height),
            p,
        );
        let agree = banded.valid
            && banded
                .c_px
                .zip(r.c_px)
                .is_some_and(|(a, c)| (a - c).abs() <= ANCHOR_TOL_PX);
        if !agree {
            return None;
        }
        self.last = Some(Ring {
            c: ring.c,
            ..fitted
        });
        Some(anchor)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const W: usize = 480;

    /// A 480 × 64 frame with dark 11 px rings at columns `rings` (each with its depth below
    /// the 190 background), and a little deterministic noise.
    fn frame(rings: &[(f64, f64)], seed: u64) -> Vec<u8> {
        let mut s = seed.wrapping_mul(0x9e37_79b9_7f4a_7c15) | 1;
        (0..W * 64)
            .map(|i| {
                s ^= s << 13;
                s ^= s >> 7;
                s ^= s << 17;
                let x = (i % W) as f64;
                let depth: f64 = rings
                    .iter()
                    .filter(|(c, _)| (x - c).abs() <= 5.5)
                    .map(|&(_, d)| d)
                    .sum();
                (190.0 - depth) as u8 + (s >> 62) as u8
            })
            .collect()
    }

    fn optics() -> Optics {
        Optics {
            window_width_px: W as u32,
            window_height_px: 64,
            ..Optics::default()
        }
    }

    /// Frames 0 … through the tracker, each also through the whole detector: (tracked
    /// result, whole result) per frame.
    fn run(frames: &[Vec<u8>]) -> (Tracker, Vec<(FrameResult, FrameResult)>) {
        let (mut det, mut whole) = (
            Detector::new(&optics()).unwrap(),
            Detector::new(&optics()).unwrap(),
        );
        let mut t = Tracker::new(&optics()).unwrap();
        let out = frames
            .iter()
            .enumerate()
            .map(|(k, f)| {
                let r = t.detect(f, k as u64, &mut det, None).unwrap();
                (r, whole.detect(f).unwrap())
            })
            .collect();
        (t, out)
    }

    /// 12 frames of a ring moving from column `c0` by `step` px a frame: every frame valid,
    /// measured whole before frame `first_tracked` and in the band from it, with the whole
    /// frame's c and raw statistics.
    fn moving_ring(c0: f64, step: f64, first_tracked: usize) -> Tracker {
        let frames: Vec<Vec<u8>> = (0..12)
            .map(|k| frame(&[(c0 + step * k as f64, 100.0)], k))
            .collect();
        let (t, out) = run(&frames);
        for (k, (r, w)) in out.iter().enumerate() {
            assert_eq!(r.tracked, k >= first_tracked, "frame {k}");
            assert!(r.valid && w.valid);
            assert_eq!(r.c_px, w.c_px, "frame {k}: the same integers, the same c");
            assert_eq!((r.focus, r.saturated_px), (w.focus, w.saturated_px));
        }
        t
    }

    #[test]
    fn a_moving_ring_is_tracked_with_the_whole_frames_column() {
        let t = moving_ring(150.0, 2.5, 1);
        assert_eq!((t.tracked_frames(), t.whole_frames()), (11, 1));
    }

    #[test]
    fn a_ring_faster_than_the_first_search_is_tracked_from_its_third_frame() {
        // 30 px a frame: beyond the search before the motion is known (a ring entering the
        // window at e ≳ 780 µm); two whole frames give the motion, the third confirms it.
        let t = moving_ring(60.0, 30.0, 3);
        assert_eq!((t.tracked_frames(), t.whole_frames()), (9, 3));
    }

    #[test]
    fn a_jump_a_second_ring_and_a_fading_ring_are_measured_whole() {
        let mut frames: Vec<Vec<u8>> = (0..4).map(|k| frame(&[(200.0, 100.0)], k)).collect();
        // Frame 4: the ring 30 px on (a new ring where the old one was not).
        frames.push(frame(&[(230.0, 100.0)], 4));
        // Frames 5–7: back in place; then a second ring beside it: the whole frame is
        // ambiguous.
        frames.extend((5..8).map(|k| frame(&[(230.0, 100.0)], k)));
        frames.push(frame(&[(230.0, 100.0), (250.0, 100.0)], 8));
        frames.extend((9..12).map(|k| frame(&[(230.0, 100.0)], k)));
        // Frame 12: the ring at a third of its depth.
        frames.push(frame(&[(230.0, 35.0)], 12));
        let (t, out) = run(&frames);
        let whole = |k: usize| {
            assert!(!out[k].0.tracked, "frame {k} measured whole");
            assert_eq!(out[k].0, out[k].1, "frame {k}: the whole detector's result");
        };
        whole(4);
        whole(8);
        assert!(!out[8].1.valid, "two rings: {:?}", out[8].1.reason);
        whole(12);
        // Tracking goes on after the jump (from the whole frame 4) and starts again after the
        // frame without a valid ring (frame 9 whole, 10 in the band).
        assert!(out[5].0.tracked && !out[9].0.tracked && out[10].0.tracked);
        let fell: Vec<Fallback> = t.fallbacks().filter(|f| f.1 > 0).map(|f| f.0).collect();
        assert!(fell.contains(&Fallback::NoTrack), "{fell:?}");
        assert!(
            fell.iter()
                .any(|f| matches!(f, Fallback::Jump | Fallback::AtBorder | Fallback::Invalid)),
            "{fell:?}"
        );
        assert!(
            fell.iter()
                .any(|f| matches!(f, Fallback::Weak | Fallback::Blurred)),
            "{fell:?}"
        );
    }

    #[test]
    fn the_whole_frame_is_measured_again_after_the_recheck_interval() {
        let f = frame(&[(240.0, 90.0)], 1);
        let (mut det, mut t) = (
            Detector::new(&optics()).unwrap(),
            Tracker::new(&optics()).unwrap(),
        );
        let tracked: Vec<bool> = (0..RECHECK_FRAMES + 3)
            .map(|k| t.detect(&f, k, &mut det, None).unwrap().tracked)
            .collect();
        assert!(!tracked[0]);
        assert!(tracked[1..=RECHECK_FRAMES as usize].iter().all(|&x| x));
        assert!(!tracked[RECHECK_FRAMES as usize + 1]);
        assert!(tracked[RECHECK_FRAMES as usize + 2]);
        // A gap of more than MAX_GAP_FRAMES frames: whole again.
        let r = t
            .detect(&f, RECHECK_FRAMES + 3 + MAX_GAP_FRAMES, &mut det, None)
            .unwrap();
        assert!(!r.tracked);
        assert_eq!(t.last_fallback(), Some(Fallback::Gap));
    }
}
