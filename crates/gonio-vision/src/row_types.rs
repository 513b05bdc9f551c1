//! The rows the stages hand on: a row of gradients ([`GradRow`]), a row of segmented edges, dense
//! ([`EdgeRow`]) or sparse ([`SparseEdgeRow`] of [`EdgePixel`]s), and the edge classes. Plain
//! data below the stages that make and read them ([`crate::gradient`], [`crate::segment`],
//! [`crate::fill`], [`crate::label`]) and the observer that sees them ([`crate::rows`]).

use crate::buffer::{Aligned, RowBuf, next_set};

/// Class of a non-edge pixel.
pub const NONE: u8 = 0;
/// Class of a weak edge pixel (low ≤ |G| < high, or filled).
pub const WEAK: u8 = 1;
/// Class of a strong edge pixel (|G| ≥ high).
pub const STRONG: u8 = 2;
/// Sub-pixel offset marking a pixel added by edge filling (no position of its own).
pub const FILLED: i8 = i8::MIN;

/// Signed deviation of a binary angle from the horizontal axis (0° or 180°), in −64 … 63.
pub fn axial_deviation(dir: u8) -> i32 {
    (dir.wrapping_add(64) % 128) as i32 - 64
}

/// One row of gradients.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct GradRow {
    /// Horizontal derivative (positive: brighter to the right).
    pub gx: Aligned<i16>,
    /// Vertical derivative (positive: brighter below).
    pub gy: Aligned<i16>,
    /// |Gx| + |Gy|.
    pub mag: Aligned<u16>,
}

impl GradRow {
    /// A zeroed row of `width` pixels.
    pub fn new(width: usize) -> Self {
        GradRow {
            gx: Aligned::new(width, 0),
            gy: Aligned::new(width, 0),
            mag: Aligned::new(width, 0),
        }
    }
}

impl RowBuf for GradRow {
    fn copy_row(&mut self, o: &GradRow) {
        self.gx.copy_from_slice(&o.gx);
        self.gy.copy_from_slice(&o.gy);
        self.mag.copy_from_slice(&o.mag);
    }
}

/// One row of segmented edges, dense: a value per column.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct EdgeRow {
    /// [`NONE`], [`WEAK`] or [`STRONG`] per pixel.
    pub class: Vec<u8>,
    /// Gradient direction (binary angle) of edge pixels, 0 elsewhere.
    pub dir: Vec<u8>,
    /// Sub-pixel x offset of the edge in 1/32 px (−16 … 16), [`FILLED`] for filled pixels.
    pub sub: Vec<i8>,
    /// Gradient magnitude |Gx| + |Gy| of edge pixels with a position of their own, 0 elsewhere.
    pub mag: Vec<u16>,
}

impl EdgeRow {
    /// An empty row of `width` pixels.
    pub fn new(width: usize) -> Self {
        EdgeRow {
            class: vec![0; width],
            dir: vec![0; width],
            sub: vec![0; width],
            mag: vec![0; width],
        }
    }
    /// Clears the row.
    pub fn clear(&mut self) {
        self.class.fill(0);
        self.dir.fill(0);
        self.sub.fill(0);
        self.mag.fill(0);
    }
    /// The row holding the pixels of `s` (and nothing else).
    pub fn set_from(&mut self, s: &SparseEdgeRow) {
        self.clear();
        for p in &s.pixels {
            let x = p.col as usize;
            self.class[x] = p.class;
            self.dir[x] = p.dir;
            self.sub[x] = p.sub;
            self.mag[x] = if p.sub == FILLED { 0 } else { p.mag };
        }
    }
}

impl RowBuf for EdgeRow {
    fn copy_row(&mut self, o: &EdgeRow) {
        self.class.copy_from_slice(&o.class);
        self.dir.copy_from_slice(&o.dir);
        self.sub.copy_from_slice(&o.sub);
        self.mag.copy_from_slice(&o.mag);
    }
}

/// One row of edge pixels, sparse: the pixels in column order (edges are a few percent of a
/// frame's pixels) and a bit per column marking them.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct SparseEdgeRow {
    /// The edge pixels by increasing column (`comp` unused).
    pub pixels: Vec<EdgePixel>,
    /// Bit x % 64 of word x / 64 is set when column x holds an edge pixel.
    pub bits: Vec<u64>,
}

impl SparseEdgeRow {
    /// An empty row of `width` pixels.
    pub fn new(width: usize) -> Self {
        SparseEdgeRow {
            pixels: Vec::with_capacity(width / 4),
            bits: vec![0; width.div_ceil(64)],
        }
    }
    /// Removes every pixel.
    pub fn clear(&mut self) {
        self.pixels.clear();
        self.bits.fill(0);
    }
    /// Appends a pixel right of all those already in the row.
    #[inline]
    pub fn push(&mut self, p: EdgePixel) {
        let x = p.col as usize;
        debug_assert!(self.pixels.last().is_none_or(|q| q.col < p.col));
        self.bits[x / 64] |= 1 << (x % 64);
        self.pixels.push(p);
    }
    /// The edge pixels of a dense row `e` in row `y`.
    pub fn set_from(&mut self, e: &EdgeRow, y: usize) {
        self.clear();
        let mut x = 0;
        loop {
            x = next_set(&e.class, x);
            if x >= e.class.len() {
                break;
            }
            self.push(EdgePixel {
                row: y as u16,
                col: x as u16,
                class: e.class[x],
                dir: e.dir[x],
                sub: e.sub[x],
                mag: e.mag[x],
                comp: 0,
            });
            x += 1;
        }
    }
    /// True when column `x` holds an edge pixel.
    #[inline]
    pub fn has(&self, x: usize) -> bool {
        self.bits[x / 64] >> (x % 64) & 1 != 0
    }
}

impl RowBuf for SparseEdgeRow {
    fn copy_row(&mut self, o: &SparseEdgeRow) {
        self.pixels.clone_from(&o.pixels);
        self.bits.copy_from_slice(&o.bits);
    }
}

/// One positioned edge pixel as the labeller saw it, with its component.
///
/// Laid out as written (16 bytes; `repr(C)`), so that copying a pixel into the edge list with
/// its row and component set compiles to one 16-byte load and store plus two field stores.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[repr(C)]
pub struct EdgePixel {
    /// Row.
    pub row: u16,
    /// Column.
    pub col: u16,
    /// [`WEAK`] or [`STRONG`].
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
