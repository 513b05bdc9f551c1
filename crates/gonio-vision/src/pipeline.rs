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
use crate::focus::{FrameFocus, RowFocus, RowStats};
use crate::gradient::GradRow;
use crate::label::{Component, EdgeList, Labeller};
use crate::morphology::{BlackTopHat, Disk, Opening};
use crate::optics::{Optics, Params};
use crate::rows::{LastSink, RowBuf, RowSink, StageObserver, Then};
use crate::segment::{FILLED, SegmentParams, Segmenter, SparseEdgeRow};
use std::sync::Arc;

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

/// The row-local stages, from camera rows to segmented edges, chained to `N`.
type Front<N> = Morphology<EdgeStages<N>>;
/// The morphology: the black top-hat and the opening of it, chained to `N`.
pub(crate) type Morphology<N> = Then<BlackTopHat, Then<Opening, N>>;
/// The row-local stages from the morphology's output to segmented edges, chained to `N`.
pub(crate) type EdgeStages<N> = Then<BlurSobel, Then<Segmenter, N>>;
/// The stages that see the whole frame's edges in order: filling and labelling.
type Back = Then<EdgeFill, Labeller>;
/// The detector's stages, chained.
type Cascade = Front<Back>;

/// The row-local stages of a detector with parameters `p`, chained to `next`.
fn front<N>(p: &Params, next: N) -> Front<N> {
    morphology(p, edge_stages(p, next))
}

/// The top-hat and opening of a detector with parameters `p`, chained to `next`.
pub(crate) fn morphology<N>(p: &Params, next: N) -> Morphology<N> {
    let w = p.width;
    Then {
        stage: BlackTopHat::new(w, Disk::new(p.close_radius_px)),
        next: Then {
            stage: Opening::new(w, Disk::new(p.open_radius_px)),
            next,
        },
    }
}

/// The blur, Sobel and segmentation of a detector with parameters `p`, chained to `next`.
pub(crate) fn edge_stages<N>(p: &Params, next: N) -> EdgeStages<N> {
    let w = p.width;
    let seg = SegmentParams {
        low: p.grad_low,
        high: p.grad_high,
        tan_q10: p.tan_tolerance_q10,
    };
    Then {
        stage: BlurSobel::new(w),
        next: Then {
            stage: Segmenter::new(w, seg),
            next,
        },
    }
}

/// The streaming baseline detector.
#[derive(Debug, Clone)]
pub struct Detector {
    p: Params,
    line: Cascade,
    /// Raw rows y−2, y−1 for the focus measure.
    raw_prev: [Vec<u8>; 2],
    rows: usize,
    /// The raw statistics of the rows so far.
    raw: RawSums,
    /// The per-row focus sums' state.
    focus: RowFocus,
    dump: Option<Box<StageImages>>,
}

/// A frame's raw statistics (saturation and focus sums), added up row by row: integer sums
/// and runs in row order, so two threads' shares of a frame add up to one thread's.
#[derive(Debug, Clone, Default)]
pub(crate) struct RawSums {
    saturated: u64,
    /// Runs of saturated pixels, row by row.
    sat_runs: Vec<SaturatedRun>,
    focus_sum: u64,
    grad_sum: u64,
}

impl RawSums {
    fn clear(&mut self) {
        self.saturated = 0;
        self.sat_runs.clear();
        self.focus_sum = 0;
        self.grad_sum = 0;
    }

    /// Adds row `y` (its pixels `row`, its sums `s`).
    #[inline(always)]
    fn add(&mut self, s: RowStats, row: &[u8], y: usize) {
        self.add_saturated(s.saturated, row, y);
        self.grad_sum += s.abs_sum;
        self.focus_sum += s.sq_sum;
    }

    /// Adds row `y`'s `n` pixels at 255 and, when there are any, its saturated runs.
    #[inline(always)]
    fn add_saturated(&mut self, n: u32, row: &[u8], y: usize) {
        if n > 0 {
            self.saturated += u64::from(n);
            saturated_runs(row, y, &mut self.sat_runs);
        }
    }

    /// Adds the rows of `below`, all of them after these.
    fn append(&mut self, below: &RawSums) {
        self.saturated += below.saturated;
        self.sat_runs.extend_from_slice(&below.sat_runs);
        self.focus_sum += below.focus_sum;
        self.grad_sum += below.grad_sum;
    }

    /// Row `y` of a whole frame of rows `w` wide, `h` high, into the sums, as the detector
    /// takes them (`focus` carries the focus sums' lanes from row to row, reduced once, at
    /// row h − 1): rows go in order, row 0 starting the frame's sums afresh.
    #[inline]
    pub(crate) fn add_row(
        &mut self,
        focus: &mut FrameFocus,
        frame: &[u8],
        (w, h): (usize, usize),
        y: usize,
    ) {
        if y == 0 {
            self.clear();
        }
        let row = &frame[y * w..(y + 1) * w];
        // The next row is read next, a row's work from now.
        if let Some(next) = frame.get((y + 1) * w..(y + 2) * w) {
            crate::simd::prefetch(next);
        }
        let n = focus.push((y, h), row, rows_above(frame, w, y));
        self.add_saturated(n, row, y);
        if y + 1 == h {
            let t = focus.finish();
            self.grad_sum = t.abs_sum;
            self.focus_sum = t.sq_sum;
        }
    }

    /// The frame's statistics from its sums (a window `w` × `h`).
    pub(crate) fn stats(&self, w: usize, h: usize) -> RawStats {
        let interior = ((w - 2) * (h - 2)) as f64;
        RawStats {
            saturated_px: self.saturated,
            focus: self.focus_sum as f64 / interior / 4.0,
            mean_gradient: self.grad_sum as f64 / interior / 2.0,
        }
    }

    /// The saturated runs, in row order.
    pub(crate) fn saturated_runs(&self) -> &[SaturatedRun] {
        &self.sat_runs
    }
}

/// What a finished frame's result is computed from ([`Detector::finish_parts`]).
pub(crate) struct FrameParts<'a> {
    /// The candidate components.
    pub cands: &'a [Component],
    /// Every connected component.
    pub components: usize,
    /// The frame's edge pixels.
    pub edges: &'a mut EdgeList,
}

impl<'a> FrameParts<'a> {
    /// What a labeller that has taken a whole frame's rows holds.
    pub(crate) fn of(label: &'a mut Labeller) -> FrameParts<'a> {
        let components = label.component_count();
        let (cands, edges) = label.candidates_and_edges();
        FrameParts {
            cands,
            components,
            edges,
        }
    }
}

/// Rows y − 2 and y − 1 of a whole frame of rows `w` wide (what the focus measure of row y
/// reads), `None` for the first two rows.
#[inline(always)]
fn rows_above(frame: &[u8], w: usize, y: usize) -> Option<(&[u8], &[u8])> {
    (y >= 2).then(|| (&frame[(y - 2) * w..(y - 1) * w], &frame[(y - 1) * w..y * w]))
}

pub(crate) fn labeller(p: &Params, record_all: bool) -> Labeller {
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
        let line = front(
            &p,
            Then {
                stage: EdgeFill::new(w),
                next: labeller(&p, false),
            },
        );
        Detector {
            line,
            raw_prev: [vec![0; w], vec![0; w]],
            rows: 0,
            raw: RawSums {
                sat_runs: Vec::with_capacity(64),
                ..RawSums::default()
            },
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
        self.raw.clear();
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

    /// Pushes the frame's next row (window width pixels) through the stages alone, without
    /// the raw statistics (the frame's result then has none: the tracked detector's band
    /// takes them from the whole frame). The first row of a frame starts it.
    ///
    /// # Errors
    /// As [`Detector::push_row`].
    pub(crate) fn push_stages(&mut self, row: &[u8]) -> Result<(), VisionError> {
        if row.len() != self.p.width || self.rows >= self.p.height {
            return self.push_row(row);
        }
        if self.rows == 0 {
            self.begin_frame();
        }
        self.cascade_row(row);
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
        self.cascade_row(row);
    }

    /// A row into the cascade (inverted for a bright ring), counted.
    #[inline(always)]
    fn cascade_row(&mut self, row: &[u8]) {
        self.rows += 1;
        take_row(self.line.input(), row, self.p.invert);
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
        self.raw.add(s, row, self.rows);
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
        Ok(self.result())
    }

    /// Ends the frame like [`Detector::finish_frame`], without computing its result: what
    /// the result is computed from, but the raw statistics (stage dumps are not kept).
    pub(crate) fn finish_parts(&mut self) -> Result<FrameParts<'_>, VisionError> {
        if self.rows != self.p.height {
            let found = self.rows;
            self.rows = 0;
            return Err(VisionError::FrameHeight {
                expected: self.p.height,
                found,
            });
        }
        self.line.finish(&mut ());
        self.rows = 0;
        Ok(FrameParts::of(self.line.last_sink()))
    }

    /// The frame's result once every row has reached the labeller.
    fn result(&mut self) -> FrameResult {
        let stats = self.raw.stats(self.p.width, self.p.height);
        let label = self.line.last_sink();
        if let Some(d) = self.dump.as_deref_mut() {
            d.components = label.all().to_vec();
        }
        let count = label.component_count();
        let (cands, edges) = label.candidates_and_edges();
        let res = baseline_features(cands, count, edges, &self.raw.sat_runs, stats, &self.p);
        self.rows = 0;
        res
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
            let prev = rows_above(frame, w, y);
            // The next row is read first by the raw statistics, a whole row's work from now.
            if let Some(next) = frame.get((y + 1) * w..(y + 2) * w) {
                crate::simd::prefetch(next);
            }
            self.feed(row, prev);
        }
        self.finish_frame()
    }

    /// Rows between a row's arrival and its edges leaving the segmentation: at least the
    /// reach, above and below, of the row-local stages (a stage's output row y reads its input
    /// rows y ± its kernel's half-height, never more than its lag).
    fn front_lag(&self) -> usize {
        self.line.lag() - self.line.next.next.next.next.lag()
    }

    /// The first row [`Detector::detect_split`] leaves to its second thread; `None` when it
    /// detects on one thread: stage dumps on, or a window shorter than six times the
    /// row-local stages' lag (the two threads' rows overlap by twice the lag: more than a
    /// third of the window would be done twice; 60 rows for the station's 11 px ring, whose
    /// closing batches 16 rows).
    pub fn seam_row(&self) -> Option<usize> {
        let (h, lag) = (self.p.height, self.front_lag());
        let seam = (h as f64 * SEAM_FRACTION).round() as usize;
        (self.dump.is_none() && 6 * lag <= h && seam >= lag + 2 && seam + lag <= h).then_some(seam)
    }

    /// The second thread's share of [`Detector::detect_split`], for this detector's window.
    pub fn lower_half(&self) -> LowerHalf {
        LowerHalf {
            front: front(
                &self.p,
                EdgeRows {
                    rows: Vec::new(),
                    scratch: SparseEdgeRow::new(self.p.width),
                    width: self.p.width,
                    n: 0,
                    skip: 0,
                },
            ),
            focus: RowFocus::default(),
            raw: RawSums::default(),
            p: self.p.clone(),
            pool: rayon::ThreadPoolBuilder::new()
                .num_threads(1)
                .thread_name(|_| "gonio-detect-lower".into())
                .build()
                .ok()
                .map(Arc::new),
        }
    }

    /// [`Detector::detect`] on two threads, the same result bit for bit: while this thread runs
    /// the whole cascade over the rows above a seam ([`SEAM_FRACTION`] of the height),
    /// `lower`'s own thread runs the row-local stages (top-hat to segmentation) and the raw
    /// statistics over the rows below it, starting one lag of those stages above the seam so
    /// that its rows are exactly a single thread's; its edge rows then go on through filling
    /// and labelling here, in order. With a second core free it takes about three quarters
    /// of the time (≈ 20 % more work in all). A frame too short to split (or with stage dumps
    /// on) is detected on this thread alone.
    ///
    /// # Errors
    /// [`VisionError::FrameSize`] if `frame` is not width × height bytes.
    pub fn detect_split(
        &mut self,
        frame: &[u8],
        lower: &mut LowerHalf,
    ) -> Result<FrameResult, VisionError> {
        let (w, h) = (self.p.width, self.p.height);
        let (Some(seam), Some(pool)) = (self.seam_row(), lower.pool.clone()) else {
            return self.detect(frame);
        };
        // A lower half made for other parameters, or a frame of the wrong size (the error).
        if frame.len() != w * h || lower.p != self.p {
            return self.detect(frame);
        }
        let lag = self.front_lag();
        self.begin_frame();
        let mut below = false;
        pool.in_place_scope(|scope| {
            let done = &mut below;
            let lower = &mut *lower;
            scope.spawn(move |_| {
                let run = || lower.run(frame, seam, seam - lag);
                *done = std::panic::catch_unwind(std::panic::AssertUnwindSafe(run)).is_ok();
            });
            // Rows above the seam: statistics and the cascade; then the rows the front stages
            // need to finish the seam's row, through the cascade only.
            for (y, row) in frame.chunks_exact(w).enumerate().take(seam + lag) {
                if y < seam {
                    crate::simd::dispatch(
                        #[inline(always)]
                        || self.raw_stats(row, rows_above(frame, w, y)),
                    );
                }
                self.cascade_row(row);
            }
        });
        if !below {
            // The lower half panicked (it does not, on any frame of the right size): the frame
            // again on this thread alone.
            return self.detect(frame);
        }
        let back = &mut self.line.next.next.next.next;
        for row in &lower.front.last_sink().rows[..h - seam] {
            back.input().copy_row(row);
            back.pushed(&mut ());
        }
        back.finish(&mut ());
        self.raw.append(&lower.raw);
        self.rows = h;
        Ok(self.result())
    }
}

/// Where [`Detector::detect_split`] splits a frame, as a fraction of its height from the top:
/// the upper rows get the whole cascade, the lower ones only the row-local stages (about
/// seven tenths of the work) on the second thread, so that the two threads finish at about
/// the same time on the station's window.
pub const SEAM_FRACTION: f64 = 0.43;

/// Copies a camera row into a cascade's input, inverted for a bright ring.
#[inline(always)]
pub(crate) fn take_row(input: &mut [u8], row: &[u8], invert: bool) {
    if invert {
        for (o, &v) in input.iter_mut().zip(row) {
            *o = 255 - v;
        }
    } else {
        input.copy_from_slice(row);
    }
}

/// The share of a frame a second thread detects in [`Detector::detect_split`]: the row-local
/// stages (top-hat to segmentation) and the raw statistics of the rows below the seam, and the
/// thread (one of its own, kept between frames). Made by [`Detector::lower_half`]; allocates
/// only on its first frame. A clone shares the thread.
#[derive(Debug, Clone)]
pub struct LowerHalf {
    front: Front<EdgeRows>,
    focus: RowFocus,
    raw: RawSums,
    /// The detector's parameters it was made for.
    p: Params,
    /// The second thread, waiting between frames (`None`: none could be started; frames are
    /// then detected on the calling thread alone).
    pool: Option<Arc<rayon::ThreadPool>>,
}

impl LowerHalf {
    /// Rows `start..` of `frame` through the row-local stages, keeping the edge rows from
    /// `seam` on; the raw statistics of the rows from `seam` on.
    fn run(&mut self, frame: &[u8], seam: usize, start: usize) {
        let w = self.p.width;
        self.front.reset();
        let edges = self.front.last_sink();
        edges.skip = seam - start;
        for row in frame.chunks_exact(w).skip(start) {
            take_row(self.front.input(), row, self.p.invert);
            self.front.pushed(&mut ());
        }
        self.front.finish(&mut ());
        // The focus sums' state starts two rows above the seam (as at a frame's top: rows
        // 0 and 1 have no sums of their own); from the seam on, the sums are a whole frame's.
        self.raw.clear();
        let from = seam - 2;
        for (y, row) in frame.chunks_exact(w).enumerate().skip(from) {
            let prev = (y >= seam).then(|| rows_above(frame, w, y)).flatten();
            let s = crate::simd::dispatch(
                #[inline(always)]
                || self.focus.push(y - from, row, prev),
            );
            if y >= seam {
                self.raw.add(s, row, y);
            }
        }
    }
}

/// The edge rows a [`LowerHalf`] keeps: those from the seam down. Each pixel's `row` is the
/// lower half's own count, not the frame's; nothing after reads it (the filling numbers the
/// rows it makes, and the labeller the rows it takes).
#[derive(Debug, Clone)]
struct EdgeRows {
    rows: Vec<SparseEdgeRow>,
    scratch: SparseEdgeRow,
    width: usize,
    /// Rows received in this frame.
    n: usize,
    /// Rows received before the first kept one (the reach above the seam).
    skip: usize,
}

impl LastSink for EdgeRows {
    type Sink = EdgeRows;
    fn last_sink(&mut self) -> &mut EdgeRows {
        self
    }
}

impl RowSink for EdgeRows {
    type Row = SparseEdgeRow;
    fn input(&mut self) -> &mut SparseEdgeRow {
        match self.n.checked_sub(self.skip) {
            None => &mut self.scratch,
            Some(k) => {
                if k == self.rows.len() {
                    self.rows.push(SparseEdgeRow::new(self.width));
                }
                &mut self.rows[k]
            }
        }
    }
    fn pushed<O: StageObserver + ?Sized>(&mut self, _: &mut O) {
        self.n += 1;
    }
    fn finish<O: StageObserver + ?Sized>(&mut self, _: &mut O) {}
    fn reset(&mut self) {
        self.n = 0;
    }
    fn lag(&self) -> usize {
        0
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
