//! Ring selection: which two edges are the alignment ring's, chosen by the ring's model rather
//! than by component size (spec `eccentricity-detector.md`, "Scenes the detector must survive").
//!
//! A grating shows many long, near-vertical edges besides the ring's: the residues that thin
//! concentric track-border lines leave after the d/2 opening (10–50 % of their depth once the
//! optics blur them), scratches, the ends of radial marks. The selection uses what only the ring
//! has:
//!
//! 1. **Fragments.** Every component spanning at least `min_fragment_rows` rows whose pixels
//!    share one gradient polarity (≥ 90 %): rising (Gx > 0: the left edge of the bright band the
//!    top-hat makes of a dark ring) or falling. Each gets its least-squares curve (column as a
//!    parabola, or a line when short, of the row), the scatter of its pixels about it, and its
//!    mean gradient magnitude.
//! 2. **Tracks.** Fragments of one edge cut apart by dust, a scratch, marks touching the ring or a
//!    gap in the ring are linked top to bottom when each continues the other's curve (within
//!    1.5 px plus 1 % of the rows between them); their sums are added.
//! 3. **Candidates.** A rising track L and a falling track R to its right form a ring candidate
//!    when, over the rows they share (at least `min_edge_fraction` of the window's): their
//!    separation stays within the band derived from the ring width in the optics, they are
//!    parallel (the separation changes by at most `parallel_px`), their gradients are alike (the
//!    weaker at least half the stronger: both edges of one band), and no track at least
//!    `interior_fraction` as strong as their weaker edge runs between them, parallel to them,
//!    over 30 % of those rows (a ring's inside is flat; two neighbouring lines have edges as
//!    strong as their outer ones between them; a scratch crossing the ring at an angle, or what
//!    the opening leaves of one inside it, does not count).
//! 4. **Score.** Strength × coverage × width fit × balance, each 0 … 1: strength is the weaker
//!    edge's mean gradient relative to the strongest candidate's (the frame-relative threshold:
//!    a faint ring in a faint frame scores as well as a strong one in a strong frame) with half
//!    weight on its strong-pixel share; coverage the shared rows over the window's; width fit
//!    1 − ½·((sep − d)/(tolerance·d))²; balance the weaker edge's gradient over the stronger's.
//! 5. **Margin.** (best − runner-up)/best, the runner-up being the best candidate whose c lies
//!    more than d/2 from the best's (a different ring hypothesis). Below `min_margin` the frame
//!    is [`InvalidReason::Ambiguous`](crate::InvalidReason::Ambiguous): never guess.
//!
//! Each candidate's edges are re-fitted from the frame's own edge pixels near their curves, the
//! two together as parallel curves with the pixels that stray from them dropped
//! ([`refit_pair`]): pixels that only crossed an edge, or a scratch or speck running along one,
//! drop out, and c is the fitted centre line's mean column over the window's rows.
//!
//! Thresholds are the optics' (the minimum ring contrast sets the segmentation's floor) and the
//! frame's own (relative to its best candidate); no fixed count of largest components.
//!
//! Cost (the `dense` frame: ≈ 155 candidate components of which ≈ 20 are split, ≈ 34 tracks,
//! 15 × 15 pairs of long tracks, ≈ 1 pair re-fitted): the selection is written by hand because
//! it is the product, and kept allocation-free per component and per pair: the pixel, RANSAC
//! and refit buffers live for one frame (`Scratch`, `RefitScratch`) and are reused from
//! component to component and pair to pair. A fragment is a plain record until it starts a
//! track (no row list per fragment; fragments sorted by index, not moved); a track's rows are
//! kept as disjoint intervals in row order, so every pair of tracks intersects them in one
//! sweep without sorting; a curve or a joint fit is computed once per set of pixels (a clean
//! fragment's, a long component's fitted for the frame's curvature, a piece's or an edge's
//! whose re-fit kept the same pixels); a split component's pixels are looked up within its own
//! columns; a pair whose tracks' row ranges cannot share enough rows is dropped before their
//! rows are intersected; the refit gathers both edges in one pass over the rows, each row
//! searched linearly from where the row above's search ended; RANSAC stops counting a line
//! once it can no longer win, and skips the tries that cannot (a pair of pixels already
//! tried, or any try once every pixel is an inlier); when a re-fit or a dropped row changes
//! an edge's pixels, its sums follow by the sums of the pixels that went and came (`resum`)
//! instead of being summed afresh; the buffers are kept per thread from frame to frame; the
//! linking scan reads one compact list of the open tracks per polarity (last row, mean row,
//! curve, its column at the last row) instead of the tracks; the moments' exact integer
//! expansion runs in i64 when a guard proves it cannot overflow (i128 otherwise); the refit's
//! row means are computed once for both edges, the rows it drops marked; its kept sets are
//! also flags over the gathered pixels (each pixel's column and u computed once), so that a
//! re-fit's filter and its comparison with the pixels kept before are one pass whose steps do
//! not wait on each other (a walk along the old list did, pixel by pixel); the clean
//! majority reads RANSAC's reduced columns. None of this changes a value: the
//! same sums (integers) and the same floating-point expressions in the same order
//! (the passes over the selection in BENCHMARKS.md's git history).
//!
//! ```
//! use gonio_vision::{Detector, InvalidReason, Optics};
//! let optics = Optics { window_width_px: 200, window_height_px: 64, ..Optics::default() };
//! let mut det = Detector::new(&optics).unwrap();
//! // A dark 11 px ring at column 100 and, 40 px to its left, a thin 3 px line of the same depth.
//! let mut frame = vec![190u8; 200 * 64];
//! for row in frame.chunks_mut(200) {
//!     for x in 95..=105 { row[x] = 70; }
//!     for x in 59..=61 { row[x] = 70; }
//! }
//! let r = det.detect(&frame).unwrap();
//! assert!(r.valid, "{:?}", r.reason);
//! assert!((r.c_px.unwrap() - 100.0).abs() < 0.05);
//! assert_eq!(r.margin, Some(1.0)); // nothing else looks like a ring
//! ```

mod candidate;
mod line;
mod pair;
mod score;
#[cfg(test)]
mod tests;
mod tracks;

pub use candidate::{Candidate, Selection};
pub(crate) use line::moments;
pub use line::{Curve, curve, curve_with, window_mean};
pub use pair::{PairFit, refit_pair};
pub use score::select;
pub use tracks::{Track, tracks};
