//! Single-pass streaming connected-component labelling with 8-connectivity and per-component
//! sums (Yu et al., 2024, Algorithm 2 and the component feature buffer).
//!
//! The algorithm is the product here, so it is hand-written. Each row is cut into runs of edge
//! pixels; a run takes the label of the previous row's runs it touches (8-connected: overlapping
//! columns widened by one), and when it touches several, their components are merged on the spot
//! (union–find with path halving; the sums are added). After each row the runs hold root labels
//! only, so labels merged away are recycled at once and a component whose runs stop is complete:
//! it is handed to the result with its sums and its label is recycled (the previous row is
//! walked pixel by pixel: its columns kept from the row before, each pixel's root read from the
//! per-column label row as the walk clears it; no run record). Memory: two rows of pixel
//! columns, one of pixel labels, two per-column label rows and a label pool of width + 4
//! entries, whatever the frame's height or content.
//!
//! Most runs are one pixel (98 % on a dense frame), so those take a path of their own. The
//! previous row's labels are kept per column (0 = no pixel), so a pixel's three upper
//! neighbours are three loads, not a walk over the previous row's runs; straight above wins
//! (its diagonal neighbours are in its run), else either diagonal one, without a branch on
//! which: the only test is "both diagonals present" (a join, rare on one-pixel-wide edges).
//! Until a row's first merge every previous label is a root and is used without `find`.
//!
//! A row takes two passes. The first labels the runs and notes each pixel's label; the
//! second adds each pixel to its component's sums and writes the kept edge pixels. In one
//! pass, each pixel's sums waited on a chain of loads (the pixel, the labels above it, the
//! component's record): 32 straight vertical lines (`stage/labelling synthetic`, no branch
//! ever mispredicted) took ≈ 47 cycles a pixel, as many as the `dense` frame. In the second
//! pass every record is known up front. The sums go into a hot record of two aligned cache lines
//! (`Acc`) in arrays of four added together (one vector read-modify-write each where the
//! target has them; [`Labeller::push_sparse`] runs an AVX-512 compilation of the same code
//! where the CPU has it), the row's powers computed once per row; the first row and first
//! pixel are kept apart (set when the component opens, and at merges), the last row and the
//! weak count derived when it completes. A kept edge pixel is written by index and kept by
//! advancing the index (a filled one is overwritten), the cap checked once per row. All of it
//! gives the same integers as [`Component::add_pixel`].
//!
//! The positioned pixels can also be kept ([`Labeller::keep_pixels`]) for the ring selection's
//! robust steps: each with its provisional label, resolved to its component afterwards from
//! a log of merges and completions, backwards row by row ([`EdgeList`]); the selection reads
//! them row by row ([`EdgeRows`]) or one component's within its columns
//! ([`EdgeList::component_pixels_into`]).
//!
//! ```
//! use gonio_vision::label::Labeller;
//! use gonio_vision::segment::{EdgeRow, STRONG};
//! let mut l = Labeller::new(5, 4, true);
//! let mut row = EdgeRow::new(5);
//! for y in 0..3 {
//!     row.clear();
//!     row.class[y] = STRONG;      // a diagonal: one 8-connected component
//!     row.class[4] = STRONG;      // and a vertical line at x = 4
//!     l.push_row(&row);
//! }
//! l.finish();
//! assert_eq!(l.component_count(), 2);
//! assert_eq!(l.candidates()[0].pixels, 3);
//! ```

pub use crate::row_types::EdgePixel;
use crate::row_types::{EdgeRow, FILLED, STRONG, SparseEdgeRow, axial_deviation};
use crate::rows::{LastSink, RowSink, StageObserver};
use crate::simd::Avx512;

/// Applies `op` (`+=` or `-=`) to the counts and integer sums of two [`Component`]s, field by
/// field (`b`'s onto `a`): the one list of those fields.
macro_rules! each_sum {
    ($a:expr, $b:expr, $op:tt) => {{
        let (a, b) = ($a, $b);
        a.pixels $op b.pixels;
        a.strong $op b.strong;
        a.pos_n $op b.pos_n;
        a.gx_pos $op b.gx_pos;
        a.sum_dev $op b.sum_dev;
        a.sum_row $op b.sum_row;
        a.sum_row2 $op b.sum_row2;
        a.sum_row3 $op b.sum_row3;
        a.sum_row4 $op b.sum_row4;
        a.sum_col32 $op b.sum_col32;
        a.sum_row_col32 $op b.sum_row_col32;
        a.sum_row2_col32 $op b.sum_row2_col32;
        a.sum_col32_sq $op b.sum_col32_sq;
        a.sum_mag $op b.sum_mag;
    }};
}

/// Adds a [`Component`]'s sums to another's (`b`'s into `a`; the columns' range widened).
macro_rules! add_sums {
    ($a:expr, $b:expr) => {{
        let (a, b) = ($a, $b);
        each_sum!(&mut *a, b, +=);
        a.min_col = a.min_col.min(b.min_col);
        a.max_col = a.max_col.max(b.max_col);
    }};
}

/// The sums of one connected component. Position sums use only pixels with their own sub-pixel
/// position (not filled ones); columns are in 1/32 px.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Component {
    /// All pixels.
    pub pixels: u64,
    /// Strong pixels.
    pub strong: u64,
    /// Weak pixels (including filled ones).
    pub weak: u64,
    /// Pixels contributing to the position sums.
    pub pos_n: u64,
    /// Σ row.
    pub sum_row: i64,
    /// Σ row².
    pub sum_row2: i64,
    /// Σ row³.
    pub sum_row3: i64,
    /// Σ row⁴.
    pub sum_row4: i64,
    /// Σ column (1/32 px).
    pub sum_col32: i64,
    /// Σ row·column (1/32 px).
    pub sum_row_col32: i64,
    /// Σ row²·column (1/32 px).
    pub sum_row2_col32: i64,
    /// Σ column² (1/1024 px²), for the scatter of the pixels about their fitted curve.
    pub sum_col32_sq: i128,
    /// Σ gradient magnitude |Gx| + |Gy| (positioned pixels).
    pub sum_mag: u64,
    /// Σ direction deviation from the horizontal axis (binary angle units, all pixels).
    pub sum_dev: i64,
    /// Pixels whose gradient points to +x (|direction| < 90°).
    pub gx_pos: u64,
    /// Smallest column.
    pub min_col: u32,
    /// Largest column.
    pub max_col: u32,
    /// First row.
    pub min_row: u32,
    /// Last row.
    pub max_row: u32,
    /// row·width + column of the first pixel in raster order (a unique, order-free id).
    pub first_index: u64,
}

impl Component {
    pub(crate) fn empty() -> Self {
        Component {
            min_col: u32::MAX,
            min_row: u32::MAX,
            first_index: u64::MAX,
            ..Default::default()
        }
    }

    /// Adds one pixel.
    #[inline]
    #[allow(clippy::too_many_arguments)]
    pub fn add_pixel(
        &mut self,
        row: u32,
        col: u32,
        width: usize,
        class: u8,
        dir: u8,
        sub: i8,
        mag: u16,
    ) {
        self.pixels += 1;
        if class == STRONG {
            self.strong += 1;
        } else {
            self.weak += 1;
        }
        self.sum_dev += axial_deviation(dir) as i64;
        if dir.wrapping_add(64) < 128 {
            self.gx_pos += 1;
        }
        if sub != FILLED {
            let r = row as i64;
            let c = col as i64 * 32 + sub as i64;
            self.pos_n += 1;
            self.sum_row += r;
            self.sum_row2 += r * r;
            self.sum_row3 += r * r * r;
            self.sum_row4 += r * r * r * r;
            self.sum_col32 += c;
            self.sum_row_col32 += r * c;
            self.sum_row2_col32 += r * r * c;
            self.sum_col32_sq += (c * c) as i128;
            self.sum_mag += mag as u64;
        }
        self.min_col = self.min_col.min(col);
        self.max_col = self.max_col.max(col);
        self.min_row = self.min_row.min(row);
        self.max_row = self.max_row.max(row);
        self.first_index = self.first_index.min(row as u64 * width as u64 + col as u64);
    }

    /// Adds another component's sums (a merge).
    pub fn merge(&mut self, o: &Component) {
        add_sums!(&mut *self, o);
        self.weak += o.weak;
        self.min_row = self.min_row.min(o.min_row);
        self.max_row = self.max_row.max(o.max_row);
        self.first_index = self.first_index.min(o.first_index);
    }

    /// Takes away the counts and sums of `o`, a subset of this component's pixels (integers:
    /// exactly the sums of the pixels left). The row and column ranges and the first pixel are
    /// left as they are: only the pixels left can tell them.
    pub fn remove(&mut self, o: &Component) {
        each_sum!(&mut *self, o, -=);
        self.weak -= o.weak;
    }

    /// The ranking of components: more pixels first, then earlier first pixel.
    pub fn rank_key(&self) -> (std::cmp::Reverse<u64>, u64) {
        (std::cmp::Reverse(self.pixels), self.first_index)
    }

    /// Rows from the first to the last, inclusive.
    pub fn row_span(&self) -> u32 {
        row_span(self.min_row, self.max_row)
    }

    /// A ring-edge candidate: a strong pixel (hysteresis) and at least `min_rows` rows.
    pub fn is_candidate(&self, min_rows: u32) -> bool {
        candidate(self.strong, self.min_row, self.max_row, min_rows)
    }
}

/// Rows from `min_row` to `max_row` ([`Component::row_span`]).
#[inline(always)]
fn row_span(min_row: u32, max_row: u32) -> u32 {
    max_row.saturating_sub(min_row) + 1
}

/// The candidate rule of [`Component::is_candidate`] from the counts it reads: a strong pixel
/// and at least `min_rows` rows from `min_row` to `max_row`.
#[inline(always)]
fn candidate(strong: u64, min_row: u32, max_row: u32, min_rows: u32) -> bool {
    strong > 0 && row_span(min_row, max_row) >= min_rows
}

#[derive(Debug, Clone, Copy)]
enum Event {
    /// Label `from` merged into `to` during row `row`.
    Merge { from: u32, to: u32, row: u32 },
    /// Root `root` completed at row `row` as the component with this first index.
    Complete {
        root: u32,
        row: u32,
        first_index: u32,
    },
}

impl Event {
    fn row(&self) -> u32 {
        match *self {
            Event::Merge { row, .. } | Event::Complete { row, .. } => row,
        }
    }
}

/// Every positioned edge pixel of a frame in raster order, each with the `first_index` of its
/// component, and where each row's pixels start. Kept by the labeller for the ring selection's
/// robust steps (splitting an edge that took in a scratch, re-fitting the chosen edges); the
/// components are resolved from a log of merges and completions only when first asked for.
#[derive(Debug, Clone, Default)]
pub struct EdgeList {
    /// The pixels are `pixels[..len]`; the storage only grows (the labeller writes a row's
    /// pixels by index, each store kept or overwritten by the next: no branch per pixel).
    pixels: Vec<EdgePixel>,
    len: usize,
    row_start: Vec<u32>,
    events: Vec<Event>,
    resolved: bool,
    overflow: bool,
    cap: usize,
    labels: usize,
    fin: Vec<u32>,
}

impl EdgeList {
    /// An empty list holding at most `cap` pixels (more: the list is marked incomplete), for a
    /// labeller with `labels` labels.
    fn with_capacity(cap: usize, labels: usize) -> Self {
        EdgeList {
            cap,
            labels,
            ..Default::default()
        }
    }

    /// An incomplete list: no pixels (the selection then uses the components' sums only).
    pub fn none() -> Self {
        EdgeList {
            resolved: true,
            overflow: true,
            ..Default::default()
        }
    }

    /// A list from pixels already resolved to their components, in raster order (the
    /// reference's; more than `cap` pixels: incomplete).
    pub fn from_resolved(pixels: Vec<EdgePixel>, height: usize, cap: usize) -> Self {
        let mut list = EdgeList {
            pixels,
            ..Default::default()
        };
        list.resolve_pixels(height, cap);
        list
    }

    /// The list emptied for [`EdgeList::resolve_pixels`]: its pixel storage (kept from frame to
    /// frame, so a caller that lists every frame's pixels allocates nothing).
    pub(crate) fn refill(&mut self) -> &mut Vec<EdgePixel> {
        self.pixels.clear();
        &mut self.pixels
    }

    /// Makes the list [`EdgeList::from_resolved`] makes of the pixels now in its storage
    /// ([`EdgeList::refill`]).
    pub(crate) fn resolve_pixels(&mut self, height: usize, cap: usize) {
        self.overflow = self.pixels.len() > cap;
        if self.overflow {
            self.pixels.clear();
        }
        let pixels = &self.pixels;
        self.row_start.clear();
        self.row_start.reserve(height + 1);
        let mut k = 0;
        for y in 0..=height {
            while k < pixels.len() && (pixels[k].row as usize) < y {
                k += 1;
            }
            self.row_start.push(k as u32);
        }
        self.len = pixels.len();
        self.events.clear();
        self.resolved = true;
        self.cap = cap;
        self.labels = 0;
        self.fin.clear();
    }

    fn reset(&mut self) {
        self.len = 0;
        self.row_start.clear();
        self.events.clear();
        self.resolved = false;
        self.overflow = false;
    }

    /// Resolves every pixel's component (once per frame). Row by row, backwards: the events
    /// are checked once per row, not once per pixel.
    fn resolve(&mut self) {
        if self.resolved {
            return;
        }
        self.resolved = true;
        // An incomplete list is never read.
        if self.overflow {
            return;
        }
        self.fin.clear();
        self.fin.resize(self.labels, u32::MAX);
        let mut e = self.events.len();
        // Backwards in time: a pixel recorded at row y carries its root at the end of row y;
        // the merges and completions after that row decide its component. Row y's pixels are
        // row_start[y] .. b, b the next row's start (the last row pushed: to the end).
        let mut b = self.len;
        for y in (0..self.row_start.len()).rev() {
            while e > 0 && self.events[e - 1].row() > y as u32 {
                e -= 1;
                match self.events[e] {
                    Event::Merge { from, to, .. } => {
                        self.fin[from as usize] = self.fin[to as usize]
                    }
                    Event::Complete {
                        root, first_index, ..
                    } => self.fin[root as usize] = first_index,
                }
            }
            let a = self.row_start[y] as usize;
            for px in &mut self.pixels[a..b] {
                px.comp = self.fin[px.comp as usize];
            }
            b = a;
        }
    }

    /// The pixels (resolved), or `None` when the frame had more than the list holds.
    pub fn pixels(&mut self) -> Option<&[EdgePixel]> {
        self.resolve();
        (!self.overflow).then_some(&self.pixels[..self.len])
    }

    /// The pixels of row `y`, sorted by column (empty when the list is incomplete or `y` is
    /// outside the frame).
    pub fn row(&mut self, y: usize) -> &[EdgePixel] {
        self.rows().map_or(&[], |r| r.row(y))
    }

    /// The pixels of the component with this `first_index` within rows `first ..= last`, in
    /// raster order (empty when the list is incomplete).
    pub fn component(&mut self, first_index: u64, first: u32, last: u32) -> Vec<EdgePixel> {
        let first_index = first_index as u32;
        self.resolve();
        if self.overflow || self.row_start.is_empty() {
            return Vec::new();
        }
        let n = self.row_start.len() - 1;
        let a = self.row_start[(first as usize).min(n)] as usize;
        let b = self.row_start[(last as usize + 1).min(n)] as usize;
        self.pixels[a..b]
            .iter()
            .filter(|p| p.comp == first_index)
            .copied()
            .collect()
    }

    /// The pixels of component `c` (by its `first_index`), in raster order, into `out`
    /// (cleared first; empty when the list is incomplete): as [`EdgeList::component`] over
    /// its rows, but each row looked at only between its first and last column (found by
    /// binary search), not whole.
    pub fn component_pixels_into(&mut self, c: &Component, out: &mut Vec<EdgePixel>) {
        out.clear();
        let first_index = c.first_index as u32;
        let Some(rows) = self.rows() else {
            return;
        };
        for y in c.min_row as usize..=c.max_row as usize {
            let row = rows.row(y);
            let lo = row.partition_point(|p| (p.col as u32) < c.min_col);
            for p in &row[lo..] {
                if p.col as u32 > c.max_col {
                    break;
                }
                if p.comp == first_index {
                    out.push(*p);
                }
            }
        }
    }

    /// The pixels row by row (resolved), or `None` when the frame had more than the list
    /// holds: a view without the per-call checks of [`EdgeList::row`].
    pub fn rows(&mut self) -> Option<EdgeRows<'_>> {
        self.resolve();
        (!self.overflow).then_some(EdgeRows {
            pixels: &self.pixels[..self.len],
            row_start: &self.row_start,
        })
    }
}

/// A complete [`EdgeList`]'s pixels, row by row (see [`EdgeList::rows`]).
#[derive(Debug, Clone, Copy)]
pub struct EdgeRows<'a> {
    pixels: &'a [EdgePixel],
    row_start: &'a [u32],
}

impl<'a> EdgeRows<'a> {
    /// The pixels of row `y`, sorted by column (empty outside the frame).
    #[inline]
    pub fn row(&self, y: usize) -> &'a [EdgePixel] {
        if y + 1 >= self.row_start.len() {
            return &[];
        }
        &self.pixels[self.row_start[y] as usize..self.row_start[y + 1] as usize]
    }
}

/// A component's sums from its pixels.
pub fn component_of(pixels: &[EdgePixel], width: usize) -> Component {
    let mut c = Component::empty();
    for p in pixels {
        c.add_pixel(
            p.row as u32,
            p.col as u32,
            width,
            p.class,
            p.dir,
            p.sub,
            p.mag,
        );
    }
    c
}

/// A row's index and its powers, computed once per row.
struct RowPowers {
    /// r, r², r³, r⁴.
    pow: [i64; 4],
    /// row · width.
    first: u64,
}

/// The sums the labeller adds pixel by pixel: the hot part of a [`Component`], two cache
/// lines aligned. The first row and first pixel are kept apart ([`Origin`], set when the
/// component opens and at merges), the last row and the weak pixels are derived when the
/// component completes ([`Acc::component`]): no store per pixel for them. The sums a pixel
/// adds together are kept in arrays of four, so that each array is one vector
/// read-modify-write (about half the stores of one per field).
#[derive(Debug, Clone, Copy)]
#[repr(C, align(64))]
struct Acc {
    /// Pixels, strong pixels, positioned pixels, pixels with a gradient toward +x.
    counts: [u64; 4],
    /// Σ r, Σ r², Σ r³, Σ r⁴ over the positioned pixels.
    rows: [i64; 4],
    /// Σ c, Σ r·c, Σ r²·c (c the column in 1/32 px) and Σ |G| over the positioned pixels.
    cols: [i64; 4],
    sum_col32_sq: i128,
    sum_dev: i64,
    min_col: u32,
    max_col: u32,
}

impl Acc {
    const EMPTY: Acc = Acc {
        counts: [0; 4],
        rows: [0; 4],
        cols: [0; 4],
        sum_col32_sq: 0,
        sum_dev: 0,
        min_col: u32::MAX,
        max_col: 0,
    };

    /// Adds one positioned pixel of row `rp.pow[0]` (its powers `rp`), as
    /// [`Component::add_pixel`].
    #[inline(always)]
    fn add_positioned(&mut self, rp: &RowPowers, p: &EdgePixel) {
        let c = p.col as i64 * 32 + p.sub as i64;
        self.add_counts(p, 1);
        add4(&mut self.rows, rp.pow);
        add4(
            &mut self.cols,
            [c, rp.pow[0] * c, rp.pow[1] * c, p.mag as i64],
        );
        self.sum_col32_sq += (c * c) as i128;
    }

    /// Adds one filled pixel (no sub-pixel position: only the counts, the direction and the
    /// column range).
    #[cold]
    #[inline(never)]
    fn add_filled(&mut self, p: &EdgePixel) {
        self.add_counts(p, 0);
    }

    /// What every pixel adds, positioned (`pos` 1) or filled (0): the counts, the direction's
    /// deviation and the column range.
    #[inline(always)]
    fn add_counts(&mut self, p: &EdgePixel, pos: u64) {
        let col = p.col as u32;
        let counts = [
            1,
            (p.class == STRONG) as u64,
            pos,
            (p.dir.wrapping_add(64) < 128) as u64,
        ];
        add4(&mut self.counts, counts);
        self.sum_dev += axial_deviation(p.dir) as i64;
        self.min_col = self.min_col.min(col);
        self.max_col = self.max_col.max(col);
    }

    /// Adds another component's sums (a merge).
    fn merge(&mut self, o: &Acc) {
        add4(&mut self.counts, o.counts);
        add4(&mut self.rows, o.rows);
        add4(&mut self.cols, o.cols);
        self.sum_col32_sq += o.sum_col32_sq;
        self.sum_dev += o.sum_dev;
        self.min_col = self.min_col.min(o.min_col);
        self.max_col = self.max_col.max(o.max_col);
    }

    /// Strong pixels so far.
    #[inline(always)]
    fn strong(&self) -> u64 {
        self.counts[1]
    }

    /// The component, complete: it started at `o` and its last row is `max_row`.
    fn component(&self, o: Origin, max_row: u32) -> Component {
        let [pixels, strong, pos_n, gx_pos] = self.counts;
        let [sum_row, sum_row2, sum_row3, sum_row4] = self.rows;
        let [sum_col32, sum_row_col32, sum_row2_col32, sum_mag] = self.cols;
        Component {
            pixels,
            strong,
            weak: pixels - strong,
            pos_n,
            sum_row,
            sum_row2,
            sum_row3,
            sum_row4,
            sum_col32,
            sum_row_col32,
            sum_row2_col32,
            sum_col32_sq: self.sum_col32_sq,
            sum_mag: sum_mag as u64,
            sum_dev: self.sum_dev,
            gx_pos,
            min_col: self.min_col,
            max_col: self.max_col,
            min_row: o.row,
            max_row,
            first_index: o.index,
        }
    }
}

/// `a += b`, lane by lane: one vector
/// addition where the target has them.
#[inline(always)]
fn add4<T: Copy + std::ops::Add<Output = T>>(a: &mut [T; 4], b: [T; 4]) {
    for (x, y) in a.iter_mut().zip(b) {
        *x = *x + y;
    }
}

/// Where a component starts: its first row and the raster index (row · width + column) of
/// its first pixel (the earliest of the merged components').
#[derive(Debug, Clone, Copy)]
struct Origin {
    row: u32,
    index: u64,
}

/// Writes the pixels `px` of row `row` with their labels `lab` into `out` from index `n` on,
/// each one kept by advancing the index unless it is filled (the next one overwrites it); the
/// index after them. `out` has room for all of them.
#[inline(always)]
fn write_kept(
    px: &[EdgePixel],
    lab: &[u32],
    row: u16,
    out: &mut [EdgePixel],
    mut n: usize,
) -> usize {
    for (p, &l) in px.iter().zip(lab) {
        out[n] = EdgePixel { row, comp: l, ..*p };
        n += (p.sub != FILLED) as usize;
    }
    n
}

/// [`write_kept`], its whole steps of four pixels by [`crate::simd::avx512::label`] on a CPU
/// with AVX-512 F/BW/VL/DQ (`cpu`).
#[inline(always)]
fn write_kept_at(
    cpu: Option<Avx512>,
    px: &[EdgePixel],
    lab: &[u32],
    row: u16,
    out: &mut [EdgePixel],
    n: usize,
) -> usize {
    #[cfg(target_arch = "x86_64")]
    if let Some(cpu) = cpu {
        let (k, n) = crate::simd::avx512::label::write_kept(cpu, px, lab, row, out, n);
        return write_kept(&px[k..], &lab[k..], row, out, n);
    }
    let _ = cpu;
    write_kept(px, lab, row, out, n)
}

/// "No edge pixel" in the per-column label arrays; components take labels 1 ..= pool.
const NO_LABEL: u32 = 0;

/// Sets the labels of columns `start ..= end` in a per-column label array (a one-pixel run
/// by one store: a slice fill is a library call).
#[inline(always)]
fn set_cols(labels: &mut [u32], start: u32, end: u32, l: u32) {
    let (a, b) = (start as usize + 1, end as usize + 1);
    if a == b {
        labels[a] = l;
    } else {
        labels[a..=b].fill(l);
    }
}

/// The union–find forest of the open components: each label's parent, sums and origin.
#[derive(Debug, Clone)]
struct Forest {
    parent: Vec<u32>,
    acc: Vec<Acc>,
    origin: Vec<Origin>,
    free: Vec<u32>,
    /// This row's merges, `(from, to)` in order (logged and freed at the row's end).
    merged: Vec<(u32, u32)>,
}

impl Forest {
    /// The root of label `l`, halving the path on the way (each visited label skips to its
    /// grandparent).
    fn find(&mut self, mut l: u32) -> u32 {
        let parent = &mut self.parent;
        while parent[l as usize] != l {
            let g = parent[parent[l as usize] as usize];
            parent[l as usize] = g;
            l = g;
        }
        l
    }

    /// The root of a label read from the previous row: until the row's first merge it is one
    /// already.
    #[inline(always)]
    fn root(&mut self, l: u32) -> u32 {
        if self.merged.is_empty() {
            l
        } else {
            self.find(l)
        }
    }

    /// A new component starting at `o`.
    #[inline(never)]
    fn alloc(&mut self, o: Origin) -> u32 {
        // Two rows of runs hold at most width + 1 labels: the pool never runs dry.
        let l = self.free.pop().unwrap_or(1);
        self.parent[l as usize] = l;
        self.acc[l as usize] = Acc::EMPTY;
        self.origin[l as usize] = o;
        l
    }

    /// Merges root `from` into root `to`.
    fn union(&mut self, to: u32, from: u32) {
        let o = self.acc[from as usize];
        self.acc[to as usize].merge(&o);
        let (a, b) = (self.origin[to as usize], self.origin[from as usize]);
        if b.index < a.index {
            self.origin[to as usize] = b;
        }
        self.parent[from as usize] = to;
        self.merged.push((from, to));
    }

    /// Joins the components of labels `a` and `b` (the up-left and up-right neighbours of a
    /// pixel with none straight above); the root kept.
    #[cold]
    #[inline(never)]
    fn join(&mut self, a: u32, b: u32) -> u32 {
        let (ra, rb) = (self.find(a), self.find(b));
        if ra != rb {
            self.union(ra, rb);
        }
        ra
    }

    /// The component of the run `a ..= b` (several pixels; `up` the previous row's labels):
    /// every upper neighbour's component merged into the first one's; [`NO_LABEL`] when it
    /// has none.
    #[inline(never)]
    fn label_run(&mut self, up: &[u32], a: usize, b: usize) -> u32 {
        let (mut label, mut last) = (NO_LABEL, NO_LABEL);
        for &v in &up[a..=b + 2] {
            if v == NO_LABEL || v == last {
                continue;
            }
            last = v;
            let r = self.root(v);
            if label == NO_LABEL {
                label = r;
            } else if r != label {
                self.union(label, r);
            }
        }
        label
    }

    /// Labels the run `a ..= b` of two or more pixels of row `y` (`up` the previous row's
    /// labels; `index` the raster index of its first pixel): its component, a new one when it
    /// touches none above, with its columns set in `here`.
    #[inline(never)]
    fn label_wide_run(
        &mut self,
        up: &[u32],
        here: &mut [u32],
        a: usize,
        b: usize,
        index: u64,
        y: u32,
    ) -> u32 {
        let mut l = self.label_run(up, a, b);
        if l == NO_LABEL {
            l = self.alloc(Origin { row: y, index });
        }
        set_cols(here, a as u32, b as u32, l);
        l
    }
}

/// Streaming labeller; see the module documentation.
#[derive(Debug, Clone)]
pub struct Labeller {
    width: usize,
    /// The previous row's pixel columns: the first `nprev` of `prev_cols` (their roots at the
    /// end of that row are in `up`).
    prev_cols: Vec<u16>,
    nprev: usize,
    /// The current row's columns (the buffer `prev_cols` becomes at the row's end).
    cols: Vec<u16>,
    /// The previous row's label of column x at index x + 1 ([`NO_LABEL`] where it has no edge
    /// pixel; one empty column on each side): a pixel's three upper neighbours are three loads.
    up: Vec<u32>,
    /// The current row's labels, laid out as `up` (they become `up` for the next row).
    here: Vec<u32>,
    forest: Forest,
    /// The last row each label was seen in.
    last_row: Vec<u32>,
    candidates: Vec<Component>,
    min_rows: u32,
    count: usize,
    record_all: bool,
    all: Vec<Component>,
    edges: Option<EdgeList>,
    row: u32,
    /// The row being pushed (sparse).
    input: SparseEdgeRow,
    /// Each pixel's label in the row being pushed.
    lab: Vec<u32>,
    /// The roots a row completes.
    done: Vec<u32>,
}

impl Labeller {
    /// A labeller for rows of `width` pixels; `height_hint` sizes the record of all components
    /// when `record_all` is set (for tests and stage dumps). Otherwise only the candidates are
    /// kept: the components with a strong pixel (hysteresis) spanning at least
    /// [`Labeller::min_rows`] rows (1 unless set).
    pub fn new(width: usize, height_hint: usize, record_all: bool) -> Self {
        // Labels 1 ..= width + 4 (0 is NO_LABEL): at most two rows of runs are alive.
        let labels = width + 5;
        let mut l = Labeller {
            width,
            // A row has at most `width` pixels.
            prev_cols: vec![0; width],
            nprev: 0,
            cols: vec![0; width],
            up: vec![NO_LABEL; width + 2],
            here: vec![NO_LABEL; width + 2],
            forest: Forest {
                parent: (0..labels as u32).collect(),
                acc: vec![Acc::EMPTY; labels],
                origin: vec![Origin { row: 0, index: 0 }; labels],
                free: Vec::with_capacity(labels),
                merged: Vec::with_capacity(labels),
            },
            last_row: vec![0; labels],
            candidates: Vec::with_capacity(256),
            min_rows: 1,
            count: 0,
            record_all,
            all: Vec::with_capacity(if record_all { height_hint * 4 } else { 0 }),
            edges: None,
            row: 0,
            input: SparseEdgeRow::new(width),
            lab: vec![NO_LABEL; width],
            done: Vec::with_capacity(width / 2 + 1),
        };
        l.reset();
        l
    }

    /// Also keeps every positioned edge pixel with its component ([`EdgeList`]), at most `cap`
    /// of them a frame (rows up to 65,535).
    pub fn keep_pixels(mut self, cap: usize) -> Self {
        self.edges = Some(EdgeList::with_capacity(cap, self.forest.parent.len()));
        self
    }

    /// The frame's edge pixels with their components (after [`Labeller::finish`]; `None`
    /// unless kept with [`Labeller::keep_pixels`]). Resolved on the first access.
    pub fn edge_list(&mut self) -> Option<&mut EdgeList> {
        self.edges.as_mut()
    }

    /// The candidates and the edge list (an incomplete one when pixels are not kept), for the
    /// baseline features.
    pub fn candidates_and_edges(&mut self) -> (&[Component], &mut EdgeList) {
        let e = self.edges.get_or_insert_with(EdgeList::none);
        (&self.candidates, e)
    }

    /// Keeps as candidates only components spanning at least `rows` rows (first to last).
    pub fn min_rows(mut self, rows: u32) -> Self {
        self.min_rows = rows.max(1);
        self
    }

    /// Starts a new frame.
    pub fn reset(&mut self) {
        self.nprev = 0;
        self.up.fill(NO_LABEL);
        self.here.fill(NO_LABEL);
        let f = &mut self.forest;
        f.free.clear();
        f.free.extend((1..f.parent.len() as u32).rev());
        f.merged.clear();
        self.candidates.clear();
        if let Some(e) = self.edges.as_mut() {
            e.reset();
        }
        self.all.clear();
        self.count = 0;
        self.row = 0;
    }

    /// Component `root`, whose last row was the one before row `self.row`, is complete.
    fn complete(&mut self, root: u32) {
        let f = &self.forest;
        let (acc, o) = (&f.acc[root as usize], f.origin[root as usize]);
        if let Some(e) = self.edges.as_mut() {
            e.events.push(Event::Complete {
                root,
                row: self.row,
                first_index: o.index as u32,
            });
        }
        self.count += 1;
        // Most components are not candidates: their `Component` is made only when every
        // component is recorded.
        let candidate = candidate(acc.strong(), o.row, self.row - 1, self.min_rows);
        if self.record_all || candidate {
            let c = acc.component(o, self.row - 1);
            if self.record_all {
                self.all.push(c);
            }
            if candidate {
                self.candidates.push(c);
            }
        }
        self.forest.free.push(root);
    }

    /// Pushes the next row of (filled) edges, dense.
    pub fn push_row(&mut self, edges: &EdgeRow) {
        let mut row = std::mem::take(&mut self.input);
        row.set_from(edges, self.row as usize);
        self.push_sparse(&row);
        self.input = row;
    }

    /// Pushes the next row of (filled) edges, sparse: its runs are the stretches of consecutive
    /// columns in `edges.pixels`.
    pub fn push_sparse(&mut self, edges: &SparseEdgeRow) {
        self.push_pixels(&edges.pixels);
    }

    /// Pushes the next row of (filled) edges as its pixels alone, by increasing column (their
    /// `row` and `comp` are not read: the row is the labeller's next).
    pub fn push_pixels(&mut self, px: &[EdgePixel]) {
        #[cfg(target_arch = "x86_64")]
        if let Some(cpu) = Avx512::get() {
            // Compiled with AVX-512 enabled: the same code (no intrinsics), with vector
            // additions for the sums' arrays of four and BMI2 shifts.
            crate::simd::avx512::label::run(
                cpu,
                #[inline(always)]
                || self.push_pixels_in(Some(cpu), px),
            );
            return;
        }
        self.push_pixels_in(None, px)
    }

    /// [`Labeller::push_pixels`], inlined into each level's compilation (`cpu`: the CPU has
    /// AVX-512 F/BW/VL/DQ, and the kept edge pixels are written by
    /// [`crate::simd::avx512::label`]).
    #[inline(always)]
    fn push_pixels_in(&mut self, cpu: Option<Avx512>, px: &[EdgePixel]) {
        let y = self.row;
        let r = y as i64;
        let rp = RowPowers {
            pow: [r, r * r, r * r * r, r * r * r * r],
            first: y as u64 * self.width as u64,
        };
        // The edge list's storage for this row (every pixel written, the positioned ones kept).
        let mut none: [EdgePixel; 0] = [];
        let (out, row_start) = match self.edges.as_mut() {
            Some(e) => {
                e.row_start.push(e.len as u32);
                if y > u16::MAX as u32 {
                    e.overflow = true;
                }
                // Room for the whole row (the storage only grows).
                let need = e.len + px.len();
                if !e.overflow && e.pixels.len() < need {
                    e.pixels.resize(need, EdgePixel::default());
                }
                let out = if e.overflow {
                    &mut none[..]
                } else {
                    &mut e.pixels[..]
                };
                (out, e.len)
            }
            None => (&mut none[..], 0),
        };
        let keep = !out.is_empty();
        let f = &mut self.forest;
        let (up, here, last_row) = (&self.up[..], &mut self.here[..], &mut self.last_row[..]);
        f.merged.clear();
        // Pass 1, the runs: each run's component, its columns in `here` and each pixel's
        // (provisional) label in `lab`. Pass 2, below: the sums and the
        // edge list from `lab`. Two passes, not one: the sums' read-modify-writes hang on a
        // chain of loads (the pixel, the labels above it, the component's record) and one
        // pass held about one pixel in flight; the second pass's records are known up front.
        let lab = &mut self.lab[..px.len()];
        let mut k = 0usize;
        while let Some(p) = px.get(k) {
            let a = p.col as usize;
            let single = px.get(k + 1).is_none_or(|q| q.col as usize != a + 1);
            let l = if single {
                // One pixel (most runs: the edges are one pixel wide and run down the frame).
                // Straight above: the up-left and up-right pixels, when present, are in its
                // run. Otherwise they are in different runs, joined when both are present
                // with different labels. Without a branch on which one it is: the only test
                // is "both diagonal neighbours present", rare on one-pixel-wide edges.
                let u = &up[a..a + 3];
                let (ul, um, ur) = (u[0], u[1], u[2]);
                let l = um | (ul | ur) & ((um == NO_LABEL) as u32).wrapping_neg();
                let l = if ul.min(ur) != NO_LABEL && um == NO_LABEL && ul != ur {
                    f.join(ul, ur)
                } else if l == NO_LABEL {
                    f.alloc(Origin {
                        row: y,
                        index: rp.first + a as u64,
                    })
                } else {
                    f.root(l)
                };
                here[a + 1] = l;
                lab[k] = l;
                k += 1;
                l
            } else {
                let mut k1 = k + 2;
                while px.get(k1).is_some_and(|q| q.col as usize == a + (k1 - k)) {
                    k1 += 1;
                }
                let b = a + (k1 - k) - 1;
                let l = f.label_wide_run(up, here, a, b, rp.first + a as u64, y);
                lab[k..k1].fill(l);
                k = k1;
                l
            };
            last_row[l as usize] = y;
        }
        // A merge later in the row may have left earlier pixels with a label that is no
        // longer a root: their sums, edge-list entries and columns in `here` go to the root,
        // and the row mark too (a merge later in the row may have moved it to another root).
        if !f.merged.is_empty() {
            for (l, p) in lab.iter_mut().zip(px) {
                let r = f.find(*l);
                *l = r;
                here[p.col as usize + 1] = r;
                last_row[r as usize] = y;
            }
        }
        // The columns, for the next row's walk over this one.
        for (c, p) in self.cols.iter_mut().zip(px) {
            *c = p.col;
        }
        for (p, &l) in px.iter().zip(lab.iter()) {
            if p.sub != FILLED {
                f.acc[l as usize].add_positioned(&rp, p);
            } else {
                f.acc[l as usize].add_filled(p);
            }
        }
        // The cap is checked once per row, below (the list grows by one row at most).
        let n = if keep {
            write_kept_at(cpu, px, lab, y as u16, out, row_start)
        } else {
            row_start
        };
        let merges = !f.merged.is_empty();
        if let Some(e) = self.edges.as_mut() {
            if !e.overflow {
                e.len = n;
                if e.len > e.cap {
                    e.overflow = true;
                    e.len = 0;
                }
            }
            e.events.extend(
                f.merged
                    .iter()
                    .map(|&(from, to)| Event::Merge { from, to, row: y }),
            );
        }
        self.close_prev(merges);
        let f = &mut self.forest;
        f.free.extend(f.merged.iter().map(|&(from, _)| from));
        std::mem::swap(&mut self.prev_cols, &mut self.cols);
        self.nprev = px.len();
        std::mem::swap(&mut self.up, &mut self.here);
        self.row += 1;
    }

    /// Ends the frame: every component still open is complete.
    pub fn finish(&mut self) {
        if let Some(e) = self.edges.as_mut() {
            e.row_start.push(e.len as u32);
        }
        self.close_prev(true);
        self.nprev = 0;
    }

    /// Completes the components of the previous row's pixels that row `self.row` did not
    /// continue (their roots not marked with it in `last_row`), each once, and clears that
    /// row's labels from `up` (the array becomes the next row's `here`). `merges`: labels may
    /// no longer be roots (a merge in this row), so they are looked up. The roots are listed
    /// first and completed after, in the same order: the walk then works on local slices (a
    /// call inside it made every field reload).
    #[inline(always)]
    fn close_prev(&mut self, merges: bool) {
        let y = self.row;
        let mut done = std::mem::take(&mut self.done);
        done.clear();
        let (up, last_row, f) = (&mut self.up[..], &mut self.last_row[..], &mut self.forest);
        for &c in &self.prev_cols[..self.nprev] {
            // The pixel's root at the end of its row (`here` then, fixed after merges).
            let label = std::mem::replace(&mut up[c as usize + 1], NO_LABEL);
            let r = if merges { f.find(label) } else { label };
            if last_row[r as usize] != y {
                last_row[r as usize] = y; // complete once
                done.push(r);
            }
        }
        for &r in &done {
            self.complete(r);
        }
        self.done = done;
    }

    /// Number of components completed so far in this frame.
    pub fn component_count(&self) -> usize {
        self.count
    }

    /// The candidates of the frame (components with a strong pixel spanning at least
    /// `min_rows` rows), in completion order.
    pub fn candidates(&self) -> &[Component] {
        &self.candidates
    }

    /// Every component of the frame, in completion order (only when built with `record_all`).
    pub fn all(&self) -> &[Component] {
        &self.all
    }
}

/// The labeller ends the detector's cascade: it takes the filled edge rows.
/// The labeller ends the detector's cascade ([`crate::rows::Then`]).
impl LastSink for Labeller {
    type Sink = Labeller;
    fn last_sink(&mut self) -> &mut Labeller {
        self
    }
}

impl RowSink for Labeller {
    type Row = SparseEdgeRow;
    fn input(&mut self) -> &mut SparseEdgeRow {
        &mut self.input
    }
    fn pushed<O: StageObserver + ?Sized>(&mut self, _: &mut O) {
        let row = std::mem::take(&mut self.input);
        self.push_sparse(&row);
        self.input = row;
    }
    fn finish<O: StageObserver + ?Sized>(&mut self, _: &mut O) {
        Labeller::finish(self);
    }
    fn reset(&mut self) {
        Labeller::reset(self);
    }
    fn lag(&self) -> usize {
        0
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::reference::{self, Image};
    use crate::segment::NONE;
    use proptest::prelude::*;

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(200))]
        /// The kept edge list holds every positioned pixel in raster order with the first
        /// index of its flood-fill component, frame after frame through one labeller (its
        /// storage reused), row by row too, and is marked incomplete past its cap. Cells:
        /// (edge?, class 1 weak / 2 strong, direction, sub-pixel offset, filled?).
        #[test]
        fn edge_list_equals_flood_fill(w in 1usize..40, cells in proptest::collection::vec((0u8..3, 1u8..3, any::<u8>(), -16i8..=16, 0u8..10), 1..1200)) {
            let h = cells.len() / w;
            let at = |x: usize, y: usize| cells[y * w + x];
            let mut rows = vec![EdgeRow::new(w); h];
            for (y, r) in rows.iter_mut().enumerate() {
                for x in 0..w {
                    let (edge, class, dir, sub, filled) = at(x, y);
                    if edge == 0 {
                        r.class[x] = class;
                        r.dir[x] = dir;
                        r.sub[x] = if filled == 0 { FILLED } else { sub };
                        r.mag[x] = if filled == 0 { 0 } else { 100 + x as u16 };
                    }
                }
            }
            let img = |f: &dyn Fn(&EdgeRow, usize) -> u8| {
                Image::from_vec(w, h, rows.iter().flat_map(|r| (0..w).map(|x| f(r, x))).collect())
            };
            let edges = (img(&|r, x| r.class[x]), img(&|r, x| r.dir[x]), Image::from_vec(w, h, rows.iter().flat_map(|r| r.sub.clone()).collect()));
            let mag = Image::from_vec(w, h, rows.iter().flat_map(|r| r.mag.clone()).collect());
            let (comps, labels) = reference::label(&edges, &mag);
            let mut want = Vec::new();
            for (y, r) in rows.iter().enumerate() {
                for x in (0..w).filter(|&x| r.class[x] != NONE && r.sub[x] != FILLED) {
                    let comp = comps[labels.get(x, y) as usize - 1].first_index as u32;
                    want.push(EdgePixel { row: y as u16, col: x as u16, class: r.class[x], dir: r.dir[x], sub: r.sub[x], mag: r.mag[x], comp });
                }
            }
            let mut l = Labeller::new(w, h, false).keep_pixels(w * h);
            for _frame in 0..2 {
                l.reset();
                for r in &rows {
                    l.push_row(r);
                }
                l.finish();
                let e = l.edge_list().expect("kept");
                prop_assert_eq!(e.pixels().expect("complete"), &want[..]);
                let by_rows = e.rows().expect("complete");
                for y in 0..h {
                    let row: Vec<_> = want.iter().filter(|p| p.row as usize == y).copied().collect();
                    prop_assert_eq!(by_rows.row(y), &row[..]);
                }
            }
            if !want.is_empty() {
                let mut small = Labeller::new(w, h, false).keep_pixels(want.len() - 1);
                for r in &rows {
                    small.push_row(r);
                }
                small.finish();
                prop_assert!(small.edge_list().expect("kept").pixels().is_none());
            }
        }
    }
}
