//! Single-pass streaming connected-component labelling with 8-connectivity and per-component
//! sums (seed Algorithm 2 and the component feature buffer).
//!
//! The algorithm is the product here, so it is hand-written. Each row is cut into runs of edge
//! pixels; a run takes the label of the previous row's runs it touches (8-connected: overlapping
//! columns widened by one), and when it touches several, their components are merged on the spot
//! (union–find; the sums are added). After each row the runs hold root labels only, so labels
//! merged away are recycled at once and a component whose runs stop is complete: it is handed to
//! the result with its sums and its label is recycled. Memory: two rows of runs and a label pool
//! of width + 4 entries, whatever the frame's height or content.
//!
//! Most runs are one pixel (98 % on a dense frame), so those take a path of their own
//! (`Component::add_one`): the row's powers computed once per row, a filled pixel's position
//! terms multiplied by zero instead of branched around, the first row and first pixel set
//! once when the component opens (rows only grow). Until a row's first merge every previous
//! run's label is a root and is used without `find`; the edge list's cap is checked once per
//! row. All of it gives the same integers as [`Component::add_pixel`].
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

use crate::rows::{RowSink, StageObserver};
use crate::segment::{EdgeRow, FILLED, STRONG, SparseEdgeRow, axial_deviation};

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

    /// Adds a run of pixels of one row, consecutive columns (the same sums as
    /// [`Component::add_pixel`] on each, with the row's powers multiplied once per run).
    #[inline]
    pub fn add_run(&mut self, row: u32, run: &[EdgePixel], width: usize) {
        let (Some(first), Some(last)) = (run.first(), run.last()) else {
            return;
        };
        let (mut strong, mut dev, mut gx_pos) = (0u64, 0i64, 0u64);
        let (mut pn, mut sc, mut scc, mut sm) = (0i64, 0i64, 0i64, 0u64);
        for p in run {
            strong += (p.class == STRONG) as u64;
            dev += axial_deviation(p.dir) as i64;
            gx_pos += (p.dir.wrapping_add(64) < 128) as u64;
            if p.sub != FILLED {
                let c = p.col as i64 * 32 + p.sub as i64;
                pn += 1;
                sc += c;
                scc += c * c;
                sm += p.mag as u64;
            }
        }
        let n = run.len() as u64;
        self.pixels += n;
        self.strong += strong;
        self.weak += n - strong;
        self.sum_dev += dev;
        self.gx_pos += gx_pos;
        if pn > 0 {
            let r = row as i64;
            let (r2, pn_u) = (r * r, pn as u64);
            self.pos_n += pn_u;
            self.sum_row += r * pn;
            self.sum_row2 += r2 * pn;
            self.sum_row3 += r2 * r * pn;
            self.sum_row4 += r2 * r2 * pn;
            self.sum_col32 += sc;
            self.sum_row_col32 += r * sc;
            self.sum_row2_col32 += r2 * sc;
            self.sum_col32_sq += scc as i128;
            self.sum_mag += sm;
        }
        let (a, b) = (first.col as u32, last.col as u32);
        self.min_col = self.min_col.min(a);
        self.max_col = self.max_col.max(b);
        self.min_row = self.min_row.min(row);
        self.max_row = self.max_row.max(row);
        self.first_index = self.first_index.min(row as u64 * width as u64 + a as u64);
    }

    /// Adds one positioned-or-filled pixel of row `rp.row` (its powers `rp`), as
    /// [`Component::add_pixel`] but without branches: a filled pixel's position terms are
    /// multiplied by zero instead of skipped (the same integers). The component's first row
    /// and first pixel must already be at or before this pixel.
    #[inline(always)]
    fn add_one(&mut self, rp: &RowPowers, p: &EdgePixel) {
        let col = p.col as u32;
        let strong = (p.class == STRONG) as u64;
        let pos = (p.sub != FILLED) as i64;
        let c = (p.col as i64 * 32 + p.sub as i64) * pos;
        self.pixels += 1;
        self.strong += strong;
        self.weak += 1 - strong;
        self.sum_dev += axial_deviation(p.dir) as i64;
        self.gx_pos += (p.dir.wrapping_add(64) < 128) as u64;
        self.pos_n += pos as u64;
        self.sum_row += rp.r & -pos;
        self.sum_row2 += rp.r2 & -pos;
        self.sum_row3 += rp.r3 & -pos;
        self.sum_row4 += rp.r4 & -pos;
        self.sum_col32 += c;
        self.sum_row_col32 += rp.r * c;
        self.sum_row2_col32 += rp.r2 * c;
        self.sum_col32_sq += (c * c) as i128;
        self.sum_mag += p.mag as u64 & (-pos) as u64;
        self.min_col = self.min_col.min(col);
        self.max_col = self.max_col.max(col);
        // Rows only grow: this row is the last, and the first row and first pixel are those
        // set when the component was opened ([`Labeller::push_sparse`]) or an earlier one's.
        self.max_row = rp.row;
    }

    /// Adds another component's sums (a merge).
    pub fn merge(&mut self, o: &Component) {
        self.pixels += o.pixels;
        self.strong += o.strong;
        self.weak += o.weak;
        self.pos_n += o.pos_n;
        self.sum_row += o.sum_row;
        self.sum_row2 += o.sum_row2;
        self.sum_row3 += o.sum_row3;
        self.sum_row4 += o.sum_row4;
        self.sum_col32 += o.sum_col32;
        self.sum_row_col32 += o.sum_row_col32;
        self.sum_row2_col32 += o.sum_row2_col32;
        self.sum_col32_sq += o.sum_col32_sq;
        self.sum_mag += o.sum_mag;
        self.sum_dev += o.sum_dev;
        self.gx_pos += o.gx_pos;
        self.min_col = self.min_col.min(o.min_col);
        self.max_col = self.max_col.max(o.max_col);
        self.min_row = self.min_row.min(o.min_row);
        self.max_row = self.max_row.max(o.max_row);
        self.first_index = self.first_index.min(o.first_index);
    }

    /// The ranking of components: more pixels first, then earlier first pixel.
    pub fn rank_key(&self) -> (std::cmp::Reverse<u64>, u64) {
        (std::cmp::Reverse(self.pixels), self.first_index)
    }

    /// Rows from the first to the last, inclusive.
    pub fn row_span(&self) -> u32 {
        self.max_row.saturating_sub(self.min_row) + 1
    }

    /// A ring-edge candidate: a strong pixel (hysteresis) and at least `min_rows` rows.
    pub fn is_candidate(&self, min_rows: u32) -> bool {
        self.strong > 0 && self.row_span() >= min_rows
    }
}

/// One positioned edge pixel as the labeller saw it, with its component.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct EdgePixel {
    /// Row.
    pub row: u16,
    /// Column.
    pub col: u16,
    /// [`WEAK`](crate::segment::WEAK) or [`STRONG`].
    pub class: u8,
    /// Gradient direction (binary angle).
    pub dir: u8,
    /// Sub-pixel x offset, 1/32 px.
    pub sub: i8,
    /// Gradient magnitude.
    pub mag: u16,
    /// The component's `first_index` once resolved (a provisional label before).
    pub comp: u32,
}

impl EdgePixel {
    /// Column with its sub-pixel offset, 1/32 px.
    pub fn col32(&self) -> i64 {
        self.col as i64 * 32 + self.sub as i64
    }
    /// True for a rising edge (gradient toward +x).
    pub fn rising(&self) -> bool {
        self.dir.wrapping_add(64) < 128
    }
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
    pixels: Vec<EdgePixel>,
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
        let overflow = pixels.len() > cap;
        let pixels = if overflow { Vec::new() } else { pixels };
        let mut row_start = Vec::with_capacity(height + 1);
        let mut k = 0;
        for y in 0..=height {
            while k < pixels.len() && (pixels[k].row as usize) < y {
                k += 1;
            }
            row_start.push(k as u32);
        }
        EdgeList {
            pixels,
            row_start,
            events: Vec::new(),
            resolved: true,
            overflow,
            cap,
            labels: 0,
            fin: Vec::new(),
        }
    }

    fn reset(&mut self) {
        self.pixels.clear();
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
        let mut b = self.pixels.len();
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
        (!self.overflow).then_some(&self.pixels[..])
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
            pixels: &self.pixels,
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

/// A row's index and its powers, computed once per row for the one-pixel runs.
struct RowPowers {
    row: u32,
    r: i64,
    r2: i64,
    r3: i64,
    r4: i64,
    /// row · width.
    first: u64,
}

#[derive(Debug, Clone, Copy)]
struct Run {
    start: u32,
    end: u32,
    label: u32,
    /// Range of this run's pixels in the edge list.
    rec: (u32, u32),
}

/// Streaming labeller; see the module documentation.
#[derive(Debug, Clone)]
pub struct Labeller {
    width: usize,
    prev: Vec<Run>,
    cur: Vec<Run>,
    parent: Vec<u32>,
    comps: Vec<Component>,
    last_row: Vec<u32>,
    free: Vec<u32>,
    merged: Vec<u32>,
    candidates: Vec<Component>,
    min_rows: u32,
    count: usize,
    record_all: bool,
    all: Vec<Component>,
    edges: Option<EdgeList>,
    row: u32,
    /// The row being pushed (sparse).
    input: SparseEdgeRow,
}

impl Labeller {
    /// A labeller for rows of `width` pixels; `height_hint` sizes the record of all components
    /// when `record_all` is set (for tests and stage dumps). Otherwise only the candidates are
    /// kept: the components with a strong pixel (hysteresis) spanning at least
    /// [`Labeller::min_rows`] rows (1 unless set).
    pub fn new(width: usize, height_hint: usize, record_all: bool) -> Self {
        let pool = width + 4;
        let mut l = Labeller {
            width,
            prev: Vec::with_capacity(width / 2 + 1),
            cur: Vec::with_capacity(width / 2 + 1),
            parent: (0..pool as u32).collect(),
            comps: vec![Component::empty(); pool],
            last_row: vec![0; pool],
            free: Vec::with_capacity(pool),
            merged: Vec::with_capacity(pool),
            candidates: Vec::with_capacity(256),
            min_rows: 1,
            count: 0,
            record_all,
            all: Vec::with_capacity(if record_all { height_hint * 4 } else { 0 }),
            edges: None,
            row: 0,
            input: SparseEdgeRow::new(width),
        };
        l.reset();
        l
    }

    /// Also keeps every positioned edge pixel with its component ([`EdgeList`]), at most `cap`
    /// of them a frame (rows up to 65,535).
    pub fn keep_pixels(mut self, cap: usize) -> Self {
        self.edges = Some(EdgeList::with_capacity(cap, self.parent.len()));
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
        self.prev.clear();
        self.cur.clear();
        self.free.clear();
        self.free.extend((0..self.parent.len() as u32).rev());
        self.merged.clear();
        self.candidates.clear();
        if let Some(e) = self.edges.as_mut() {
            e.reset();
        }
        self.all.clear();
        self.count = 0;
        self.row = 0;
    }

    fn find(&mut self, mut l: u32) -> u32 {
        let mut root = l;
        while self.parent[root as usize] != root {
            root = self.parent[root as usize];
        }
        while self.parent[l as usize] != root {
            let next = self.parent[l as usize];
            self.parent[l as usize] = root;
            l = next;
        }
        root
    }

    fn alloc(&mut self) -> u32 {
        // The pool holds at most two rows of runs (≤ width + 2 labels): never empty.
        let l = self.free.pop().unwrap_or(0);
        self.parent[l as usize] = l;
        self.comps[l as usize] = Component::empty();
        l
    }

    fn complete(&mut self, root: u32) {
        let c = self.comps[root as usize];
        if let Some(e) = self.edges.as_mut() {
            e.events.push(Event::Complete {
                root,
                row: self.row,
                first_index: c.first_index as u32,
            });
        }
        self.count += 1;
        if self.record_all {
            self.all.push(c);
        }
        if c.is_candidate(self.min_rows) {
            self.candidates.push(c);
        }
        self.free.push(root);
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
        let w = self.width;
        let y = self.row;
        self.cur.clear();
        self.merged.clear();
        let mut keep = false;
        if let Some(e) = self.edges.as_mut() {
            e.row_start.push(e.pixels.len() as u32);
            if y > u16::MAX as u32 {
                e.overflow = true;
            }
            keep = !e.overflow;
            if keep {
                e.pixels.reserve(edges.pixels.len());
            }
        }
        let r = y as i64;
        let rp = RowPowers {
            row: y,
            r,
            r2: r * r,
            r3: r * r * r,
            r4: r * r * r * r,
            first: y as u64 * w as u64,
        };
        let px = &edges.pixels;
        let mut j = 0usize;
        let mut k0 = 0usize;
        while k0 < px.len() {
            let mut k1 = k0 + 1;
            while k1 < px.len() && px[k1].col == px[k1 - 1].col + 1 {
                k1 += 1;
            }
            let run = &px[k0..k1];
            k0 = k1;
            let (a, b) = (run[0].col as usize, run[run.len() - 1].col as usize);
            // Previous runs touching [a − 1, b + 1].
            while j < self.prev.len() && (self.prev[j].end as usize) + 1 < a {
                j += 1;
            }
            let mut label: Option<u32> = None;
            let mut k = j;
            while k < self.prev.len() && (self.prev[k].start as usize) <= b + 1 {
                // Until this row's first merge every previous run's label is a root.
                let root = if self.merged.is_empty() {
                    self.prev[k].label
                } else {
                    self.find(self.prev[k].label)
                };
                match label {
                    None => label = Some(root),
                    Some(l) if l != root => {
                        let o = self.comps[root as usize];
                        self.comps[l as usize].merge(&o);
                        self.parent[root as usize] = l;
                        self.merged.push(root);
                        if let Some(e) = self.edges.as_mut() {
                            e.events.push(Event::Merge {
                                from: root,
                                to: l,
                                row: y,
                            });
                        }
                    }
                    _ => {}
                }
                k += 1;
            }
            let l = match label {
                Some(l) => l,
                None => {
                    let l = self.alloc();
                    let c = &mut self.comps[l as usize];
                    c.min_row = y;
                    c.first_index = rp.first + a as u64;
                    l
                }
            };
            if let [p] = run {
                self.comps[l as usize].add_one(&rp, p);
            } else {
                self.comps[l as usize].add_run(y, run, w);
            }
            // The cap is checked once per row, below (the list grows by one row at most).
            let rec = match self.edges.as_mut() {
                Some(e) if keep => {
                    let r0 = e.pixels.len() as u32;
                    for p in run {
                        if p.sub != FILLED {
                            let mut q = *p;
                            q.row = y as u16;
                            q.comp = l;
                            e.pixels.push(q);
                        }
                    }
                    (r0, e.pixels.len() as u32)
                }
                _ => (0, 0),
            };
            self.last_row[l as usize] = y;
            self.cur.push(Run {
                start: a as u32,
                end: b as u32,
                label: l,
                rec,
            });
        }
        if let Some(e) = self
            .edges
            .as_mut()
            .filter(|e| !e.overflow && e.pixels.len() > e.cap)
        {
            e.overflow = true;
            e.pixels.clear();
        }
        // Without a merge in this row every label is still a root (the common case: edges
        // running down the frame), and nothing needs relabelling.
        let merges = !self.merged.is_empty();
        if merges {
            for i in 0..self.cur.len() {
                let r = self.find(self.cur[i].label);
                self.cur[i].label = r;
                // A merge later in the row may have moved the row mark to another root.
                self.last_row[r as usize] = y;
                if let Some(e) = self.edges.as_mut().filter(|e| !e.overflow) {
                    let (r0, r1) = self.cur[i].rec;
                    for px in &mut e.pixels[r0 as usize..r1 as usize] {
                        px.comp = r;
                    }
                }
            }
        }
        // Components of the previous row that did not continue are complete.
        for i in 0..self.prev.len() {
            let r = if merges {
                self.find(self.prev[i].label)
            } else {
                self.prev[i].label
            };
            if self.last_row[r as usize] != y {
                self.last_row[r as usize] = y; // complete once
                self.complete(r);
            }
        }
        for i in 0..self.merged.len() {
            let m = self.merged[i];
            self.free.push(m);
        }
        std::mem::swap(&mut self.prev, &mut self.cur);
        self.row += 1;
    }

    /// Ends the frame: every component still open is complete.
    pub fn finish(&mut self) {
        let y = self.row;
        if let Some(e) = self.edges.as_mut() {
            e.row_start.push(e.pixels.len() as u32);
        }
        for i in 0..self.prev.len() {
            let r = self.find(self.prev[i].label);
            if self.last_row[r as usize] != y {
                self.last_row[r as usize] = y;
                self.complete(r);
            }
        }
        self.prev.clear();
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
