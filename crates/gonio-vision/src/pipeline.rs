//! The detector: every stage chained row by row, from camera rows to the frame's result.
//!
//! The stages form one cascade ([`Then`]: top-hat → opening → blur and Sobel → segmentation →
//! filling → labelling), each stage writing its output row straight into the next one's ring.
//! `push_row` drives a row through it as far as each stage's lag allows; `finish_frame` flushes
//! the last rows and computes the baseline features. Stage dumps are a [`StageObserver`]
//! ([`StageImages`]) the cascade shows every row to; without dumps the cascade runs with the
//! observer that keeps nothing, compiled away. All memory is allocated in [`Detector::new`]:
//! the working set is a few dozen rows (O(width × (4d + 12))), independent of the frame's
//! height, and nothing is allocated per frame (apart from the result's two edge lines) unless
//! stage dumps are enabled.
//!
//! ```
//! use gonio_vision::{Detector, Optics};
//! let optics = Optics { window_width_px: 96, window_height_px: 48, ..Optics::default() };
//! let mut det = Detector::new(&optics).unwrap();
//! // A dark 11 px ring, vertical, centred on column 30, on a grey background.
//! let mut frame = vec![200u8; 96 * 48];
//! for row in frame.chunks_mut(96) {
//!     for x in 25..=35 { row[x] = 60; }
//! }
//! let r = det.detect(&frame).unwrap();
//! assert!(r.valid, "{:?}", r.reason);
//! assert!((r.c_px.unwrap() - 30.0).abs() < 0.05);
//! ```

use crate::VisionError;
use crate::blur_sobel::BlurSobel;
use crate::features::{FrameResult, RawStats, SaturatedRun, baseline_features, saturated_runs};
use crate::fill::EdgeFill;
use crate::focus::RowFocus;
use crate::gradient::GradRow;
use crate::label::{Component, Labeller};
use crate::morphology::{BlackTopHat, Disk, Opening};
use crate::optics::{Optics, Params};
use crate::rows::{LastSink, RowSink, StageObserver, Then};
use crate::segment::{FILLED, SegmentParams, Segmenter, SparseEdgeRow};

/// Every stage's output for one frame, whole (filled only when dumps are enabled).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct StageImages {
    /// Width in pixels.
    pub width: usize,
    /// Height in rows.
    pub height: usize,
    /// The input as processed (inverted for a bright ring).
    pub input: Vec<u8>,
    /// Black top-hat: closing − input.
    pub tophat: Vec<u8>,
    /// Opening of the top-hat.
    pub opened: Vec<u8>,
    /// Gaussian blur of the opening.
    pub blurred: Vec<u8>,
    /// Sobel Gx.
    pub gx: Vec<i16>,
    /// Sobel Gy.
    pub gy: Vec<i16>,
    /// |Gx| + |Gy|.
    pub mag: Vec<u16>,
    /// Segmented edges (class 0/1/2), directions, sub-pixel offsets.
    pub edges: EdgeRowsImage,
    /// Edges after filling.
    pub filled: EdgeRowsImage,
    /// Every connected component (completion order).
    pub components: Vec<Component>,
}

/// A whole-frame edge image.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct EdgeRowsImage {
    /// Class per pixel.
    pub class: Vec<u8>,
    /// Direction per pixel (binary angle).
    pub dir: Vec<u8>,
    /// Sub-pixel offset per pixel.
    pub sub: Vec<i8>,
    /// Gradient magnitude of edge pixels with a position of their own (0 elsewhere).
    pub mag: Vec<u16>,
}

impl EdgeRowsImage {
    fn push(&mut self, r: &SparseEdgeRow, width: usize) {
        let n = self.class.len();
        self.class.resize(n + width, 0);
        self.dir.resize(n + width, 0);
        self.sub.resize(n + width, 0);
        self.mag.resize(n + width, 0);
        for p in &r.pixels {
            let i = n + p.col as usize;
            self.class[i] = p.class;
            self.dir[i] = p.dir;
            self.sub[i] = p.sub;
            self.mag[i] = if p.sub == FILLED { 0 } else { p.mag };
        }
    }
}

impl StageObserver for StageImages {
    fn input(&mut self, row: &[u8]) {
        self.input.extend_from_slice(row);
    }
    fn tophat(&mut self, row: &[u8]) {
        self.tophat.extend_from_slice(row);
    }
    fn opened(&mut self, row: &[u8]) {
        self.opened.extend_from_slice(row);
    }
    fn blurred(&mut self, row: &[u8]) {
        self.blurred.extend_from_slice(row);
    }
    fn gradient(&mut self, row: &GradRow) {
        self.gx.extend_from_slice(&row.gx);
        self.gy.extend_from_slice(&row.gy);
        self.mag.extend_from_slice(&row.mag);
    }
    fn edges(&mut self, row: &SparseEdgeRow) {
        self.edges.push(row, self.width);
    }
    fn filled(&mut self, row: &SparseEdgeRow) {
        self.filled.push(row, self.width);
    }
}

/// The detector's stages, chained.
type Cascade =
    Then<BlackTopHat, Then<Opening, Then<BlurSobel, Then<Segmenter, Then<EdgeFill, Labeller>>>>>;

/// The streaming baseline detector.
#[derive(Debug, Clone)]
pub struct Detector {
    p: Params,
    line: Cascade,
    /// Raw rows y−2, y−1 for the focus measure.
    raw_prev: [Vec<u8>; 2],
    rows: usize,
    saturated: u64,
    /// Runs of saturated pixels, row by row.
    sat_runs: Vec<SaturatedRun>,
    focus_sum: u64,
    grad_sum: u64,
    /// The per-row focus sums' state.
    focus: RowFocus,
    dump: Option<Box<StageImages>>,
}

fn labeller(p: &Params, record_all: bool) -> Labeller {
    Labeller::new(p.width, p.height, record_all)
        .min_rows(p.min_fragment_rows)
        .keep_pixels(p.max_edge_pixels)
}

impl Detector {
    /// A detector for the optics' window.
    ///
    /// # Errors
    /// [`VisionError::Optics`] if the optics are invalid (see [`Optics::params`]).
    pub fn new(optics: &Optics) -> Result<Self, VisionError> {
        Ok(Self::from_params(optics.params()?))
    }

    /// A detector from already derived parameters.
    pub fn from_params(p: Params) -> Self {
        let w = p.width;
        let seg = SegmentParams {
            low: p.grad_low,
            high: p.grad_high,
            tan_q10: p.tan_tolerance_q10,
        };
        fn then<S, N>(stage: S, next: N) -> Then<S, N> {
            Then { stage, next }
        }
        let line = then(
            BlackTopHat::new(w, Disk::new(p.close_radius_px)),
            then(
                Opening::new(w, Disk::new(p.open_radius_px)),
                then(
                    BlurSobel::new(w),
                    then(
                        Segmenter::new(w, seg),
                        then(EdgeFill::new(w), labeller(&p, false)),
                    ),
                ),
            ),
        );
        Detector {
            line,
            raw_prev: [vec![0; w], vec![0; w]],
            rows: 0,
            saturated: 0,
            sat_runs: Vec::with_capacity(64),
            focus_sum: 0,
            grad_sum: 0,
            focus: RowFocus::default(),
            dump: None,
            p,
        }
    }

    /// The derived parameters.
    pub fn params(&self) -> &Params {
        &self.p
    }

    /// Rows between a row's arrival and its edges reaching the labeller.
    pub fn lag_rows(&self) -> usize {
        self.line.lag()
    }

    /// The last stage of the cascade.
    fn labeller(&mut self) -> &mut Labeller {
        self.line.last_sink()
    }

    /// Keeps every stage's output of the following frames (for test vectors); allocates.
    pub fn set_dump(&mut self, on: bool) {
        if on == self.dump.is_some() {
            return;
        }
        *self.labeller() = labeller(&self.p, on);
        self.dump = if on { Some(Box::default()) } else { None };
    }

    /// The stage images of the last finished frame (with [`Detector::set_dump`]).
    pub fn dump(&self) -> Option<&StageImages> {
        self.dump.as_deref()
    }

    /// Starts a new frame, dropping any rows pushed so far.
    pub fn begin_frame(&mut self) {
        self.line.reset();
        self.rows = 0;
        self.sat_runs.clear();
        self.saturated = 0;
        self.focus_sum = 0;
        self.grad_sum = 0;
        if let Some(d) = self.dump.as_deref_mut() {
            *d = StageImages {
                width: self.p.width,
                height: self.p.height,
                ..Default::default()
            };
        }
    }

    /// Pushes the frame's next row (window width pixels). The first row of a frame starts it.
    ///
    /// # Errors
    /// [`VisionError::RowLength`] for a row of the wrong length, [`VisionError::FrameHeight`]
    /// for more rows than the window has.
    pub fn push_row(&mut self, row: &[u8]) -> Result<(), VisionError> {
        let w = self.p.width;
        if row.len() != w {
            return Err(VisionError::RowLength {
                row: self.rows,
                expected: w,
                found: row.len(),
            });
        }
        if self.rows >= self.p.height {
            return Err(VisionError::FrameHeight {
                expected: self.p.height,
                found: self.rows + 1,
            });
        }
        if self.rows == 0 {
            self.begin_frame();
        }
        // Rows y − 2 and y − 1 are kept here only for the streaming caller; `detect` reads them
        // from the frame.
        let mut prev = std::mem::take(&mut self.raw_prev);
        let k = self.rows % 2;
        self.feed(
            row,
            (self.rows >= 2).then(|| (&prev[k][..], &prev[1 - k][..])),
        );
        prev[k].copy_from_slice(row);
        self.raw_prev = prev;
        Ok(())
    }

    /// One checked row into the detector: its raw statistics (with rows y − 2 and y − 1 from
    /// `prev`, absent for the first two rows), then the cascade.
    #[inline(always)]
    fn feed(&mut self, row: &[u8], prev: Option<(&[u8], &[u8])>) {
        crate::simd::dispatch(
            #[inline(always)]
            || self.raw_stats(row, prev),
        );
        self.rows += 1;
        let input = self.line.input();
        if self.p.invert {
            for (o, &v) in input.iter_mut().zip(row) {
                *o = 255 - v;
            }
        } else {
            input.copy_from_slice(row);
        }
        match self.dump.as_deref_mut() {
            Some(d) => {
                d.input(self.line.input());
                self.line.pushed(d);
            }
            None => self.line.pushed(&mut ()),
        }
    }

    /// Saturation count and focus sums for the row just arrived; `prev` = rows y − 2, y − 1.
    #[inline(always)]
    fn raw_stats(&mut self, row: &[u8], prev: Option<(&[u8], &[u8])>) {
        let s = self.focus.push(self.rows, row, prev);
        if s.saturated > 0 {
            self.saturated += u64::from(s.saturated);
            saturated_runs(row, self.rows, &mut self.sat_runs);
        }
        self.grad_sum += s.abs_sum;
        self.focus_sum += s.sq_sum;
    }

    /// Ends the frame: flushes the stages and computes the result.
    ///
    /// # Errors
    /// [`VisionError::FrameHeight`] if fewer rows than the window's height were pushed.
    pub fn finish_frame(&mut self) -> Result<FrameResult, VisionError> {
        if self.rows != self.p.height {
            let found = self.rows;
            self.rows = 0;
            return Err(VisionError::FrameHeight {
                expected: self.p.height,
                found,
            });
        }
        match self.dump.as_deref_mut() {
            Some(d) => self.line.finish(d),
            None => self.line.finish(&mut ()),
        }
        let (w, h) = (self.p.width, self.p.height);
        let interior = ((w - 2) * (h - 2)) as f64;
        let stats = RawStats {
            saturated_px: self.saturated,
            focus: self.focus_sum as f64 / interior / 4.0,
            mean_gradient: self.grad_sum as f64 / interior / 2.0,
        };
        let label = self.line.last_sink();
        if let Some(d) = self.dump.as_deref_mut() {
            d.components = label.all().to_vec();
        }
        let count = label.component_count();
        let (cands, edges) = label.candidates_and_edges();
        let res = baseline_features(cands, count, edges, &self.sat_runs, stats, &self.p);
        self.rows = 0;
        Ok(res)
    }

    /// Runs a whole frame (row-major, window size) through the detector.
    ///
    /// # Errors
    /// [`VisionError::FrameSize`] if `frame` is not width × height bytes.
    pub fn detect(&mut self, frame: &[u8]) -> Result<FrameResult, VisionError> {
        let (w, h) = (self.p.width, self.p.height);
        if frame.len() != w * h {
            return Err(VisionError::FrameSize {
                expected: w * h,
                found: frame.len(),
                width: w,
                height: h,
            });
        }
        // The rows are checked by the frame's size: fed straight in, the focus measure's rows
        // y − 2 and y − 1 read from the frame (no copy), the frame started once.
        self.begin_frame();
        for (y, row) in frame.chunks_exact(w).enumerate() {
            let prev =
                (y >= 2).then(|| (&frame[(y - 2) * w..(y - 1) * w], &frame[(y - 1) * w..y * w]));
            // The next row is read first by the raw statistics, a whole row's work from now.
            if let Some(next) = frame.get((y + 1) * w..(y + 2) * w) {
                crate::simd::prefetch(next);
            }
            self.feed(row, prev);
        }
        self.finish_frame()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `detect` (rows y − 2, y − 1 read from the frame) and row-by-row `push_row` (rows kept in
    /// the detector) give the same result, the raw statistics included, on frames with a ring,
    /// noise and a saturated patch, inverted or not; and after a frame abandoned half-way.
    #[test]
    fn detect_equals_pushing_rows() {
        let optics = Optics {
            window_width_px: 160,
            window_height_px: 48,
            ..Optics::default()
        };
        let (w, h) = (160usize, 48usize);
        let mut s = 0x2545_f491_4f6c_dd1du64;
        for invert in [false, true] {
            let mut p = optics.params().unwrap();
            p.invert = invert;
            let mut streamed = Detector::from_params(p.clone());
            let mut whole = Detector::from_params(p);
            for f in 0..4 {
                let frame: Vec<u8> = (0..w * h)
                    .map(|i| {
                        let (x, y) = (i % w, i / w);
                        s ^= s << 13;
                        s ^= s >> 7;
                        s ^= s << 17;
                        let noise = (s >> 61) as u8;
                        match x {
                            _ if f == 2 && (100..110).contains(&x) && (5..9).contains(&y) => 255,
                            50..=60 => 40 + noise,
                            _ => 200 + noise,
                        }
                    })
                    .collect();
                if f == 1 {
                    // Half a frame, then a new one: the new frame starts from scratch.
                    streamed.push_row(&frame[..w]).unwrap();
                    streamed.begin_frame();
                }
                for row in frame.chunks_exact(w) {
                    streamed.push_row(row).unwrap();
                }
                let a = streamed.finish_frame().unwrap();
                let b = whole.detect(&frame).unwrap();
                assert_eq!(a, b, "frame {f}, invert {invert}");
                assert!(a.focus > 0.0, "frame {f}: the focus sums were taken");
                assert_eq!(a.saturated_px > 0, f == 2, "frame {f}: the saturated patch");
            }
        }
    }
}
