//! The shape every streaming stage shares: row bookkeeping ([`RowLag`]: rows received, rows
//! emitted, the fixed lag, which ring slot holds a row), the [`RowStage`] trait with the default
//! `push_row`/`flush_row` over it, the [`StageObserver`] that sees every stage's rows (stage dumps,
//! test vectors), and [`Then`], which chains stages into one cascade.
//!
//! Every stage with a vertical kernel of half-height `lag` keeps the last 2·lag + 1 input rows in
//! a ring and emits output row y once row y + lag has arrived (or, after the frame's last row,
//! while [`RowLag::pending`]). A producer writes its output row straight into the next stage's
//! ring slot ([`RowStage::input`]), so rows are handed on without copies; a producer that makes
//! its rows in batches (the morphology's register chain, 16 rows at once) writes a whole batch
//! into the next stage's slots ([`RowStage::input_block`], [`RowStage::emit_to`]) when that
//! stage's ring has room for it ([`RowLag::with_depth`]).
//!
//! ```
//! use gonio_vision::rows::RowLag;
//! let mut r = RowLag::new(1);
//! assert!(!r.pushed());            // row 0 in: row 0 still needs row 1
//! assert!(r.pushed());             // row 1 in: row 0 is ready
//! assert_eq!(r.neighbour(-1), None); // above row 0: outside the frame
//! assert_eq!(r.neighbour(1), Some(1));
//! r.advance();
//! assert!(r.pending());            // row 1 can still be flushed after the last row
//! ```

pub use crate::buffer::{Aligned, RowBuf, line, next_set};
use crate::row_types::{GradRow, SparseEdgeRow};

/// Counters of a streaming stage with a fixed lag.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct RowLag {
    lag: usize,
    depth: usize,
    n_in: usize,
    n_out: usize,
}

impl RowLag {
    /// Bookkeeping for a stage whose output row y needs input rows up to y + `lag`.
    pub const fn new(lag: usize) -> Self {
        Self::with_depth(lag, 2 * lag + 1)
    }

    /// The same with a deeper ring of `depth` (≥ 2·lag + 1) rows: room for rows written ahead
    /// ([`RowStage::input_block`]).
    pub const fn with_depth(lag: usize, depth: usize) -> Self {
        assert!(depth > 2 * lag, "a ring shallower than the kernel");
        RowLag {
            lag,
            depth,
            n_in: 0,
            n_out: 0,
        }
    }

    /// The lag in rows.
    #[inline]
    pub fn lag(&self) -> usize {
        self.lag
    }

    /// Rows in the ring: 2·lag + 1, or more ([`RowLag::with_depth`]).
    #[inline]
    pub fn depth(&self) -> usize {
        self.depth
    }

    /// The ring slots of the next `n` input rows as one run of slots (the first one), when
    /// they do not wrap the ring and writing them now overwrites no row still needed (the
    /// last 2·lag + 1 rows stay): what a stage's [`RowStage::input_block`] offers.
    #[inline]
    pub fn block(&self, n: usize) -> Option<usize> {
        let s = self.input_slot();
        (n + 2 * self.lag < self.depth && s + n <= self.depth).then_some(s)
    }

    /// Starts a new frame.
    #[inline]
    pub fn reset(&mut self) {
        self.n_in = 0;
        self.n_out = 0;
    }

    /// Rows received in this frame.
    #[inline]
    pub fn received(&self) -> usize {
        self.n_in
    }

    /// Index of the next output row.
    #[inline]
    pub fn output_row(&self) -> usize {
        self.n_out
    }

    /// Ring slot the next input row goes to.
    #[inline]
    pub fn input_slot(&self) -> usize {
        self.n_in % self.depth()
    }

    /// Counts one input row; true when an output row is ready to be emitted.
    #[inline]
    pub fn pushed(&mut self) -> bool {
        self.n_in += 1;
        self.n_in > self.lag
    }

    /// Whether output rows remain (after the frame's last row: flush them).
    #[inline]
    pub fn pending(&self) -> bool {
        self.n_out < self.n_in
    }

    /// Ring slot of row `output_row + dy`, clamped to the rows received (border replication).
    #[inline]
    pub fn clamped(&self, dy: isize) -> usize {
        let last = self.n_in as isize - 1;
        (self.n_out as isize + dy).clamp(0, last) as usize % self.depth()
    }

    /// Ring slots of rows `output_row + first_dy` … `output_row + first_dy + N − 1`, each
    /// clamped as [`RowLag::clamped`]: the same slots, one division for all (a clamped row is
    /// the one before it or the next, so its slot is that one's or the next, wrapped).
    #[inline]
    pub fn clamped_run<const N: usize>(&self, first_dy: isize) -> [usize; N] {
        let last = self.n_in as isize - 1;
        let row = |k: usize| (self.n_out as isize + first_dy + k as isize).clamp(0, last);
        let mut slots = [self.clamped(first_dy); N];
        for k in 1..N {
            let step = (row(k) != row(k - 1)) as usize;
            let next = slots[k - 1] + step;
            slots[k] = if next == self.depth { 0 } else { next };
        }
        slots
    }

    /// [`RowLag::neighbour`]`(-1)`, [`RowLag::clamped`]`(0)` and [`RowLag::neighbour`]`(1)`:
    /// the run of clamped slots around the output row, each neighbour where it is a row
    /// received (there it is not clamped).
    #[inline(always)]
    pub fn around(&self) -> (Option<usize>, usize, Option<usize>) {
        let [up, c, down] = self.clamped_run::<3>(-1);
        let y = self.n_out;
        (
            (y > 0 && y <= self.n_in).then_some(up),
            c,
            (y + 1 < self.n_in).then_some(down),
        )
    }

    /// Ring slot of row `output_row + dy`, or `None` when that row is outside the frame.
    #[inline]
    pub fn neighbour(&self, dy: isize) -> Option<usize> {
        let r = self.n_out as isize + dy;
        (r >= 0 && r < self.n_in as isize).then(|| r as usize % self.depth())
    }

    /// Marks the output row emitted.
    #[inline]
    pub fn advance(&mut self) {
        self.n_out += 1;
    }
}

/// Sees the rows the stages make, in order (for stage dumps and test vectors). Every method
/// defaults to doing nothing; `()` is the observer that keeps nothing, and the detector's
/// cascade compiled for it carries no observation code at all.
#[allow(unused_variables)]
pub trait StageObserver {
    /// The input row as processed (inverted for a bright ring).
    fn input(&mut self, row: &[u8]) {}
    /// A row of the black top-hat.
    fn tophat(&mut self, row: &[u8]) {}
    /// A row of the opening.
    fn opened(&mut self, row: &[u8]) {}
    /// A row of the Gaussian blur.
    fn blurred(&mut self, row: &[u8]) {}
    /// A row of Sobel gradients and magnitudes.
    fn gradient(&mut self, row: &GradRow) {}
    /// A row of segmented edges (NMS, thresholds, baseline filter).
    fn edges(&mut self, row: &SparseEdgeRow) {}
    /// A row of edges after filling.
    fn filled(&mut self, row: &SparseEdgeRow) {}
    /// Whether the observer looks at rows at all (default true); when false, a stage may skip
    /// making a row only the observer would see (the fused blur + Sobel's blurred `u8` row).
    fn observes(&self) -> bool {
        true
    }
}

impl StageObserver for () {
    fn observes(&self) -> bool {
        false
    }
}

/// A streaming stage: input rows in, output rows out after a fixed lag, with the row counting
/// of [`RowLag`]. A stage implements where an input row goes ([`RowStage::input`], its ring
/// slot), what it computes once a row is in ([`RowStage::accept`]) and how it makes an output
/// row ([`RowStage::emit`]); pushing and flushing come with the trait.
///
/// ```
/// use gonio_vision::gaussian::Gaussian5;
/// use gonio_vision::rows::RowStage;
/// let mut g = Gaussian5::new(6);
/// let mut out = [0u8; 6];
/// let mut rows = Vec::new();
/// for _ in 0..4 {
///     if g.push_row(&[50; 6], &mut out) { rows.push(out); }
/// }
/// while g.flush_row(&mut out) { rows.push(out); }
/// assert_eq!(rows, vec![[50u8; 6]; 4]); // every row out, a flat image stays flat
/// ```
pub trait RowStage {
    /// One input row.
    type In: RowBuf + ?Sized;
    /// One output row.
    type Out: ?Sized;

    /// The stage's row counters.
    fn rows(&self) -> &RowLag;
    /// The stage's row counters, mutably.
    fn rows_mut(&mut self) -> &mut RowLag;
    /// Where the next input row goes (its ring slot): a producer writes it there, then calls
    /// [`RowStage::pushed`].
    fn input(&mut self) -> &mut Self::In;
    /// What the stage computes once an input row is in [`RowStage::input`] (default: nothing).
    fn accept(&mut self) {}
    /// Writes output row [`RowLag::output_row`] into `out`, showing `obs` the rows it made.
    fn emit<O: StageObserver + ?Sized>(&mut self, out: &mut Self::Out, obs: &mut O);

    /// Writes output row [`RowLag::output_row`] into `next`'s input, showing `obs` the rows it
    /// made (default: [`RowStage::emit`] into [`RowSink::input`]). A stage that makes its rows
    /// in batches may write a whole batch straight into `next`'s input slots at once
    /// ([`RowSink::input_block`]) and later only show the rows that are already there.
    fn emit_to<N, O>(&mut self, next: &mut N, obs: &mut O)
    where
        N: RowSink<Row = Self::Out> + ?Sized,
        O: StageObserver + ?Sized,
    {
        self.emit(next.input(), obs);
    }
    /// The ring slots of the next `n` input rows at once (rows [`RowLag::received`] + k, k < n),
    /// for a producer that makes rows in batches and writes them straight in; `None` when the
    /// ring cannot take them as one [`RowBlock`] (the default: rows come one at a time). The
    /// stage leaves those slots alone until each row is pushed, in order ([`RowStage::input`] is
    /// then that slot).
    fn input_block(&mut self, n: usize) -> Option<RowBlock<'_>> {
        let _ = n;
        None
    }

    /// Lag in rows between an input row and the output row of the same index.
    fn lag(&self) -> usize {
        self.rows().lag()
    }
    /// Starts a new frame.
    fn reset(&mut self) {
        self.rows_mut().reset();
    }
    /// An input row has been written into [`RowStage::input`]: writes the next output row into
    /// `out` and returns true once enough rows have arrived.
    fn pushed<O: StageObserver + ?Sized>(&mut self, out: &mut Self::Out, obs: &mut O) -> bool {
        self.pushed_to(&mut Slot(out), obs)
    }
    /// After the frame's last row: writes the next pending output row into `out`, false when
    /// none is left.
    fn flushed<O: StageObserver + ?Sized>(&mut self, out: &mut Self::Out, obs: &mut O) -> bool {
        self.flushed_to(&mut Slot(out), obs)
    }
    /// [`RowStage::pushed`] with the next output row written into `next`'s input
    /// ([`RowStage::emit_to`]); `next` is not told (the caller pushes it).
    fn pushed_to<N, O>(&mut self, next: &mut N, obs: &mut O) -> bool
    where
        N: RowSink<Row = Self::Out> + ?Sized,
        O: StageObserver + ?Sized,
    {
        self.accept();
        if !self.rows_mut().pushed() {
            return false;
        }
        self.emit_to(next, obs);
        self.rows_mut().advance();
        true
    }
    /// [`RowStage::flushed`] with the row written into `next`'s input.
    fn flushed_to<N, O>(&mut self, next: &mut N, obs: &mut O) -> bool
    where
        N: RowSink<Row = Self::Out> + ?Sized,
        O: StageObserver + ?Sized,
    {
        if !self.rows().pending() {
            return false;
        }
        self.emit_to(next, obs);
        self.rows_mut().advance();
        true
    }
    /// Pushes one input row (copied in); true when `out` holds the next output row.
    fn push_row(&mut self, row: &Self::In, out: &mut Self::Out) -> bool {
        self.input().copy_row(row);
        self.pushed(out, &mut ())
    }
    /// After the frame's last row: the next pending output row, false when none is left.
    fn flush_row(&mut self, out: &mut Self::Out) -> bool {
        self.flushed(out, &mut ())
    }
}

/// The receiving end of a stage: the next stage of a cascade, or the last consumer.
pub trait RowSink {
    /// The row it takes.
    type Row: ?Sized;
    /// Where the next row goes (written there by the producer).
    fn input(&mut self) -> &mut Self::Row;
    /// A row has been written into [`RowSink::input`].
    fn pushed<O: StageObserver + ?Sized>(&mut self, obs: &mut O);
    /// The frame's last row has been pushed: flush everything.
    fn finish<O: StageObserver + ?Sized>(&mut self, obs: &mut O);
    /// Starts a new frame.
    fn reset(&mut self);
    /// Rows between a row's arrival and its reaching the last consumer.
    fn lag(&self) -> usize;
    /// The slots of the next `n` rows at once (see [`RowStage::input_block`]); default `None`.
    fn input_block(&mut self, n: usize) -> Option<RowBlock<'_>> {
        let _ = n;
        None
    }
}

/// Input slots of several byte rows at once ([`RowStage::input_block`]): row k at
/// `buf[first + k·stride ..][.. width]`, 64-byte aligned, the buffer long enough for the whole
/// 64-byte vectors that cover each row.
#[derive(Debug)]
pub struct RowBlock<'a> {
    /// The stage's ring.
    pub buf: &'a mut [u8],
    /// Offset of the first row.
    pub first: usize,
    /// Bytes from one row to the next.
    pub stride: usize,
}

/// A single output row as a [`RowSink`] (what [`RowStage::pushed`] writes into): it takes one
/// row, does nothing with it, and has no slots ahead.
struct Slot<'a, T: ?Sized>(&'a mut T);

impl<T: ?Sized> RowSink for Slot<'_, T> {
    type Row = T;
    #[inline]
    fn input(&mut self) -> &mut T {
        self.0
    }
    #[inline]
    fn pushed<O: StageObserver + ?Sized>(&mut self, _: &mut O) {}
    fn finish<O: StageObserver + ?Sized>(&mut self, _: &mut O) {}
    fn reset(&mut self) {}
    fn lag(&self) -> usize {
        0
    }
}

/// A stage followed by the rest of the cascade: each output row of `stage` is written straight
/// into `next`'s input.
#[derive(Debug, Clone)]
pub struct Then<S, N> {
    /// The stage.
    pub stage: S,
    /// What takes its rows.
    pub next: N,
}

/// The end of a chain of stages ([`Then`]): its last sink, reached through every link by its
/// type (the detector's labeller: `cascade.last_sink()`, not `cascade.next.next…`).
pub trait LastSink {
    /// The chain's last sink.
    type Sink;
    /// The chain's last sink.
    fn last_sink(&mut self) -> &mut Self::Sink;
}

impl<S, N: LastSink> LastSink for Then<S, N> {
    type Sink = N::Sink;
    #[inline]
    fn last_sink(&mut self) -> &mut N::Sink {
        self.next.last_sink()
    }
}

impl<S: RowStage, N: RowSink<Row = S::Out>> RowSink for Then<S, N> {
    type Row = S::In;
    #[inline]
    fn input(&mut self) -> &mut S::In {
        self.stage.input()
    }
    #[inline]
    fn pushed<O: StageObserver + ?Sized>(&mut self, obs: &mut O) {
        if self.stage.pushed_to(&mut self.next, obs) {
            self.next.pushed(obs);
        }
    }
    fn finish<O: StageObserver + ?Sized>(&mut self, obs: &mut O) {
        while self.stage.flushed_to(&mut self.next, obs) {
            self.next.pushed(obs);
        }
        self.next.finish(obs);
    }
    #[inline]
    fn input_block(&mut self, n: usize) -> Option<RowBlock<'_>> {
        self.stage.input_block(n)
    }
    fn reset(&mut self) {
        self.stage.reset();
        self.next.reset();
    }
    fn lag(&self) -> usize {
        self.stage.lag() + self.next.lag()
    }
}

#[cfg(test)]
mod tests {
    use super::RowLag;

    /// The slots of a run and of a row's neighbours are [`RowLag::clamped`]'s and
    /// [`RowLag::neighbour`]'s, at every point of a frame, for rings of every depth.
    #[test]
    fn runs_and_neighbours_are_the_single_slots() {
        for lag in 0..4usize {
            for depth in 2 * lag + 1..2 * lag + 6 {
                for n_in in 0..3 * depth + 4 {
                    for n_out in 0..=n_in + 2 {
                        let r = RowLag {
                            n_in,
                            n_out,
                            ..RowLag::with_depth(lag, depth)
                        };
                        if n_in > 0 {
                            for first in -3..=2isize {
                                let want: [usize; 5] =
                                    std::array::from_fn(|k| r.clamped(first + k as isize));
                                assert_eq!(r.clamped_run::<5>(first), want, "{r:?} from {first}");
                            }
                            let want = (r.neighbour(-1), r.clamped(0), r.neighbour(1));
                            assert_eq!(r.around(), want, "{r:?}");
                        }
                    }
                }
            }
        }
    }
}
