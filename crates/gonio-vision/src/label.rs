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
//! assert_eq!(l.best()[0].pixels, 3);
//! ```

use crate::segment::{EdgeRow, FILLED, NONE, STRONG, axial_deviation};

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
    fn empty() -> Self {
        Component {
            min_col: u32::MAX,
            min_row: u32::MAX,
            first_index: u64::MAX,
            ..Default::default()
        }
    }

    /// Adds one pixel.
    #[inline]
    pub fn add_pixel(&mut self, row: u32, col: u32, width: usize, class: u8, dir: u8, sub: i8) {
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
        }
        self.min_col = self.min_col.min(col);
        self.max_col = self.max_col.max(col);
        self.min_row = self.min_row.min(row);
        self.max_row = self.max_row.max(row);
        self.first_index = self.first_index.min(row as u64 * width as u64 + col as u64);
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
}

/// How many of the largest components are kept for the baseline features.
pub const KEEP: usize = 4;

#[derive(Debug, Clone, Copy)]
struct Run {
    start: u32,
    end: u32,
    label: u32,
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
    best: Vec<Component>,
    count: usize,
    record_all: bool,
    all: Vec<Component>,
    row: u32,
}

impl Labeller {
    /// A labeller for rows of `width` pixels; `height_hint` sizes the record of all components
    /// when `record_all` is set (for tests and stage dumps; otherwise only the [`KEEP`] largest
    /// components with a strong pixel are kept).
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
            best: Vec::with_capacity(KEEP + 1),
            count: 0,
            record_all,
            all: Vec::with_capacity(if record_all { height_hint * 4 } else { 0 }),
            row: 0,
        };
        l.reset();
        l
    }

    /// Starts a new frame.
    pub fn reset(&mut self) {
        self.prev.clear();
        self.cur.clear();
        self.free.clear();
        self.free.extend((0..self.parent.len() as u32).rev());
        self.merged.clear();
        self.best.clear();
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
        self.count += 1;
        if self.record_all {
            self.all.push(c);
        }
        if c.strong > 0 {
            let pos = self
                .best
                .iter()
                .position(|b| c.rank_key() < b.rank_key())
                .unwrap_or(self.best.len());
            if pos < KEEP {
                self.best.insert(pos, c);
                self.best.truncate(KEEP);
            }
        }
        self.free.push(root);
    }

    /// Pushes the next row of (filled) edges.
    #[allow(clippy::needless_range_loop)]
    pub fn push_row(&mut self, edges: &EdgeRow) {
        let w = self.width;
        let y = self.row;
        self.cur.clear();
        self.merged.clear();
        let class = &edges.class;
        let mut j = 0usize;
        let mut x = 0usize;
        while x < w {
            // Skip empty stretches quickly.
            if class[x] == NONE {
                if x + 32 <= w && class[x..x + 32].iter().fold(0u8, |a, &b| a | b) == 0 {
                    x += 32;
                } else {
                    x += 1;
                }
                continue;
            }
            let a = x;
            while x < w && class[x] != NONE {
                x += 1;
            }
            let b = x - 1;
            // Previous runs touching [a − 1, b + 1].
            while j < self.prev.len() && (self.prev[j].end as usize) + 1 < a {
                j += 1;
            }
            let mut label: Option<u32> = None;
            let mut k = j;
            while k < self.prev.len() && (self.prev[k].start as usize) <= b + 1 {
                let root = self.find(self.prev[k].label);
                match label {
                    None => label = Some(root),
                    Some(l) if l != root => {
                        let o = self.comps[root as usize];
                        self.comps[l as usize].merge(&o);
                        self.parent[root as usize] = l;
                        self.merged.push(root);
                    }
                    _ => {}
                }
                k += 1;
            }
            let l = match label {
                Some(l) => l,
                None => self.alloc(),
            };
            let comp = &mut self.comps[l as usize];
            for xx in a..=b {
                comp.add_pixel(y, xx as u32, w, class[xx], edges.dir[xx], edges.sub[xx]);
            }
            self.last_row[l as usize] = y;
            self.cur.push(Run {
                start: a as u32,
                end: b as u32,
                label: l,
            });
        }
        for i in 0..self.cur.len() {
            let r = self.find(self.cur[i].label);
            self.cur[i].label = r;
            // A merge later in the row may have moved the row mark to another root.
            self.last_row[r as usize] = y;
        }
        // Components of the previous row that did not continue are complete.
        for i in 0..self.prev.len() {
            let r = self.find(self.prev[i].label);
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

    /// The largest components with at least one strong pixel (hysteresis), best first, at most
    /// [`KEEP`].
    pub fn best(&self) -> &[Component] {
        &self.best
    }

    /// Every component of the frame, in completion order (only when built with `record_all`).
    pub fn all(&self) -> &[Component] {
        &self.all
    }
}
