//! Edge filling (seed Algorithm 1); lag 1 row.
//!
//! NMS's four-way quantisation leaves one-pixel gaps in slanted edges. An empty pixel is filled
//! when two opposite neighbours (W–E, N–S, NW–SE, NE–SW, checked in that order) are both edge
//! pixels whose directions differ by less than 45°; the filled pixel is weak, takes the mean of
//! the two directions and has no sub-pixel position of its own ([`FILLED`]). Filling looks at
//! the unfilled input only, so it never cascades.
//!
//! The streaming [`EdgeFill`] works on sparse rows: the necessary condition (an empty pixel
//! with some opposite pair of edge neighbours) is a few word operations on the rows' edge bits,
//! 64 columns at a time; [`fill_pixel`] then decides each pixel it leaves, and the filled pixels
//! are merged into the row's pixel list.
//!
//! ```
//! use gonio_vision::fill::fill_pixel;
//! use gonio_vision::segment::{WEAK, STRONG, FILLED};
//! // A gap between two strong pixels left and right with directions 2 and 6: filled, dir 4.
//! let class = [[0, 0, 0], [STRONG, 0, STRONG], [0, 0, 0]];
//! let dir = [[0, 0, 0], [2, 0, 6], [0, 0, 0]];
//! assert_eq!(fill_pixel(&class, &dir), Some((WEAK, 4, FILLED)));
//! // Directions 45° or more apart: left empty.
//! let dir = [[0, 0, 0], [0, 0, 32], [0, 0, 0]];
//! assert_eq!(fill_pixel(&class, &dir), None);
//! ```

use crate::label::EdgePixel;
use crate::rows::{RowLag, RowStage, StageObserver};
use crate::segment::{FILLED, NONE, SparseEdgeRow, WEAK};

/// Opposite neighbour pairs ((dy, dx) offsets into a 3×3 block), in the order they are tried.
const PAIRS: [((usize, usize), (usize, usize)); 4] = [
    ((1, 0), (1, 2)),
    ((0, 1), (2, 1)),
    ((0, 0), (2, 2)),
    ((0, 2), (2, 0)),
];

/// Decides whether the empty centre of a 3×3 block (`class[dy][dx]`, `dir[dy][dx]`) is filled;
/// returns its (class, dir, sub) if so.
pub fn fill_pixel(class: &[[u8; 3]; 3], dir: &[[u8; 3]; 3]) -> Option<(u8, u8, i8)> {
    if class[1][1] != NONE {
        return None;
    }
    for ((ay, ax), (by, bx)) in PAIRS {
        if class[ay][ax] != NONE && class[by][bx] != NONE {
            let (da, db) = (dir[ay][ax], dir[by][bx]);
            let diff = db.wrapping_sub(da) as i8;
            if (diff as i32).abs() < 32 {
                return Some((WEAK, da.wrapping_add((diff / 2) as u8), FILLED));
            }
        }
    }
    None
}

/// Streaming edge filling.
#[derive(Debug, Clone)]
pub struct EdgeFill {
    width: usize,
    ring: [SparseEdgeRow; 3],
    /// Each ring row's directions by column (meaningful where its bit is set).
    dirs: [Vec<u8>; 3],
    empty: SparseEdgeRow,
    fills: Vec<EdgePixel>,
    rows: RowLag,
}

/// Words `a` shifted so that bit x holds column x − 1 (`left`) and x + 1 (`right`) of the row.
#[inline(always)]
fn shifted(bits: &[u64], i: usize) -> (u64, u64) {
    let w = bits[i];
    let prev = if i > 0 { bits[i - 1] >> 63 } else { 0 };
    let next = bits.get(i + 1).map_or(0, |&n| n << 63);
    ((w << 1) | prev, (w >> 1) | next)
}

impl EdgeFill {
    /// A filler for rows of `width` pixels.
    pub fn new(width: usize) -> Self {
        EdgeFill {
            width,
            ring: [
                SparseEdgeRow::new(width),
                SparseEdgeRow::new(width),
                SparseEdgeRow::new(width),
            ],
            dirs: [vec![0; width], vec![0; width], vec![0; width]],
            empty: SparseEdgeRow::new(width),
            fills: Vec::new(),
            rows: RowLag::new(1),
        }
    }

    fn emit_impl(&mut self, out: &mut SparseEdgeRow) {
        let w = self.width;
        let y = self.rows.output_row();
        let c_slot = self.rows.clamped(0);
        let (up_slot, down_slot) = (self.rows.neighbour(-1), self.rows.neighbour(1));
        let cur = &self.ring[c_slot];
        let up = up_slot.map_or(&self.empty, |s| &self.ring[s]);
        let down = down_slot.map_or(&self.empty, |s| &self.ring[s]);
        let none: &[u8] = &[];
        let dirs = |s: Option<usize>| s.map_or(none, |s| &self.dirs[s][..]);
        let rows = [
            (up, dirs(up_slot)),
            (cur, &self.dirs[c_slot][..]),
            (down, dirs(down_slot)),
        ];
        self.fills.clear();
        for i in 0..cur.bits.len() {
            let c = cur.bits[i];
            let (cl, cr) = shifted(&cur.bits, i);
            let (ul, ur) = shifted(&up.bits, i);
            let (dl, dr) = shifted(&down.bits, i);
            let pair = (cl & cr) | (up.bits[i] & down.bits[i]) | (ul & dr) | (ur & dl);
            let mut need = !c & pair;
            while need != 0 {
                let x = i * 64 + need.trailing_zeros() as usize;
                need &= need - 1;
                if x >= w {
                    break;
                }
                let mut class = [[NONE; 3]; 3];
                let mut dir = [[0u8; 3]; 3];
                for (dy, (r, d)) in rows.iter().enumerate() {
                    for dx in 0..3 {
                        let xx = x + dx;
                        if xx >= 1 && xx <= w && r.has(xx - 1) {
                            class[dy][dx] = WEAK; // any edge class: fill_pixel only tests ≠ NONE
                            dir[dy][dx] = d[xx - 1];
                        }
                    }
                }
                if let Some((c, d, s)) = fill_pixel(&class, &dir) {
                    self.fills.push(EdgePixel {
                        row: y as u16,
                        col: x as u16,
                        class: c,
                        dir: d,
                        sub: s,
                        mag: 0,
                        comp: 0,
                    });
                }
            }
        }
        // The row's own pixels, the filled ones merged in by column.
        out.pixels.clear();
        out.bits.copy_from_slice(&cur.bits);
        let mut next = 0;
        for f in &self.fills {
            let x = f.col as usize;
            let k = next + cur.pixels[next..].partition_point(|p| (p.col as usize) < x);
            out.pixels.extend_from_slice(&cur.pixels[next..k]);
            out.pixels.push(*f);
            out.bits[x / 64] |= 1 << (x % 64);
            next = k;
        }
        out.pixels.extend_from_slice(&cur.pixels[next..]);
    }
}

impl RowStage for EdgeFill {
    type In = SparseEdgeRow;
    type Out = SparseEdgeRow;
    fn rows(&self) -> &RowLag {
        &self.rows
    }
    fn rows_mut(&mut self) -> &mut RowLag {
        &mut self.rows
    }
    fn input(&mut self) -> &mut SparseEdgeRow {
        &mut self.ring[self.rows.input_slot()]
    }
    fn accept(&mut self) {
        let s = self.rows.input_slot();
        let d = &mut self.dirs[s];
        for p in &self.ring[s].pixels {
            d[p.col as usize] = p.dir;
        }
    }
    fn emit<O: StageObserver + ?Sized>(&mut self, out: &mut SparseEdgeRow, obs: &mut O) {
        self.emit_impl(out);
        obs.filled(out);
    }
}
