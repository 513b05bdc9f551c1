//! Edge filling (Yu et al., 2024, Algorithm 1); lag 1 row.
//!
//! NMS's four-way quantisation leaves one-pixel gaps in slanted edges. An empty pixel is filled
//! when two opposite neighbours (W–E, N–S, NW–SE, NE–SW, checked in that order) are both edge
//! pixels whose directions differ by less than 45°; the filled pixel is weak, takes the mean of
//! the two directions and has no sub-pixel position of its own ([`FILLED`]). Filling looks at
//! the unfilled input only, so it never cascades.
//!
//! The streaming [`EdgeFill`] works on sparse rows: the necessary condition (an empty pixel
//! with some opposite pair of edge neighbours) is a few word operations on the rows' edge bits,
//! 64 columns at a time — with AVX-512 (VBMI2, `crate::simd::vbmi`) eight words at once, the
//! shifts across words by `vpshldq`/`vpshrdq`, written by hand because only a few percent of the
//! words hold a candidate and the scalar scan's per-word loop was most of the stage. Each
//! candidate is then decided by [`fill_pixel`]'s rule on the pairs the words showed (in its
//! order), and the filled pixels are merged into the row's pixel list; a row with none (half of
//! them) hands its list on without a copy. `tests/simd.rs` checks both scans against
//! [`fill_pixel`] on random rows of every width up to 70 and wider ones.
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

/// The direction of a pixel filled between two edge pixels of directions `da` and `db` (the
/// mean, turning the short way), or `None` when they differ by 45° or more.
#[inline(always)]
fn mean_dir(da: u8, db: u8) -> Option<u8> {
    let diff = db.wrapping_sub(da) as i8;
    ((diff as i32).abs() < 32).then(|| da.wrapping_add((diff / 2) as u8))
}

/// Decides whether the empty centre of a 3×3 block (`class[dy][dx]`, `dir[dy][dx]`) is filled;
/// returns its (class, dir, sub) if so.
pub fn fill_pixel(class: &[[u8; 3]; 3], dir: &[[u8; 3]; 3]) -> Option<(u8, u8, i8)> {
    if class[1][1] != NONE {
        return None;
    }
    PAIRS.iter().find_map(|&((ay, ax), (by, bx))| {
        if class[ay][ax] != NONE && class[by][bx] != NONE {
            mean_dir(dir[ay][ax], dir[by][bx]).map(|d| (WEAK, d, FILLED))
        } else {
            None
        }
    })
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

/// Word `w` of a row's edge bits shifted so that bit x holds column x − 1 (`prev`: the word
/// before).
#[inline(always)]
fn from_left(w: u64, prev: u64) -> u64 {
    (w << 1) | (prev >> 63)
}

/// Word `w` shifted so that bit x holds column x + 1 (`next`: the word after).
#[inline(always)]
fn from_right(w: u64, next: u64) -> u64 {
    (w >> 1) | (next << 63)
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
        let (up_slot, c_slot, down_slot) = self.rows.around();
        let cur = &self.ring[c_slot];
        let up = up_slot.map_or(&self.empty, |s| &self.ring[s]);
        let down = down_slot.map_or(&self.empty, |s| &self.ring[s]);
        // A missing row has no edge bits, so its directions are never read.
        let dirs = |s: Option<usize>| &self.dirs[s.unwrap_or(c_slot)][..];
        let (cd, ud, dd) = (&self.dirs[c_slot][..], dirs(up_slot), dirs(down_slot));
        let n = cur.bits.len();
        let (cb, ub, db) = (&cur.bits[..], &up.bits[..n], &down.bits[..n]);
        let fills = &mut self.fills;
        fills.clear();
        // Word i's empty pixels with an opposite pair of edge neighbours, and the pairs.
        let word = |i: usize| {
            let at = |b: &[u64], j: usize| b.get(j).copied().unwrap_or(0);
            let (c, u, d) = (cb[i], ub[i], db[i]);
            let j = i.wrapping_sub(1);
            let (cp, upr, dp) = (at(cb, j), at(ub, j), at(db, j));
            let (cn, un, dn) = (at(cb, i + 1), at(ub, i + 1), at(db, i + 1));
            // W–E, N–S, NW–SE, NE–SW.
            let pairs = [
                from_left(c, cp) & from_right(c, cn),
                u & d,
                from_left(u, upr) & from_right(d, dn),
                from_right(u, un) & from_left(d, dp),
            ];
            (!c & (pairs[0] | pairs[1] | pairs[2] | pairs[3]), pairs)
        };
        // Fills the candidates `need` of word i (`word(i)`).
        let mut fill_word = |i: usize, (mut need, pairs): (u64, [u64; 4])| {
            while need != 0 {
                let b = need.trailing_zeros() as usize;
                need &= need - 1;
                let x = i * 64 + b;
                if x >= w {
                    break;
                }
                // fill_pixel's pairs in its order, each only where both pixels exist (so the
                // columns x ∓ 1 are inside the row).
                let (l, r) = (x.wrapping_sub(1), x + 1);
                let ends = [
                    (cd, l, cd, r),
                    (ud, x, dd, x),
                    (ud, l, dd, r),
                    (ud, r, dd, l),
                ];
                let filled = pairs.iter().zip(ends).find_map(|(m, (ra, xa, rb, xb))| {
                    if m >> b & 1 != 0 {
                        mean_dir(ra[xa], rb[xb])
                    } else {
                        None
                    }
                });
                if let Some(dir) = filled {
                    fills.push(EdgePixel {
                        row: y as u16,
                        col: x as u16,
                        class: WEAK,
                        dir,
                        sub: FILLED,
                        mag: 0,
                        comp: 0,
                    });
                }
            }
        };
        // The words with candidates (a few percent): eight at a time with AVX-512 (the same
        // word operations in vector lanes), else one at a time.
        if !words_with_candidates(cb, ub, db, &mut |i| fill_word(i, word(i))) {
            for i in 0..n {
                let wd = word(i);
                if wd.0 != 0 {
                    fill_word(i, wd);
                }
            }
        }
        out.bits.copy_from_slice(&cur.bits);
        if self.fills.is_empty() {
            // The row as it came: its pixel list moves out (the ring keeps its bits and
            // directions for the next row; its list is rewritten with the next input).
            std::mem::swap(&mut out.pixels, &mut self.ring[c_slot].pixels);
            return;
        }
        // The row's own pixels, the filled ones merged in by column.
        let cur = &self.ring[c_slot].pixels;
        out.pixels.clear();
        let mut next = 0;
        for f in &self.fills {
            let x = f.col as usize;
            let k = next + cur[next..].partition_point(|p| (p.col as usize) < x);
            out.pixels.extend_from_slice(&cur[next..k]);
            out.pixels.push(*f);
            out.bits[x / 64] |= 1 << (x % 64);
            next = k;
        }
        out.pixels.extend_from_slice(&cur[next..]);
    }
}

/// Calls `f(i)` for every word i of the rows' edge bits (`c` the row, `u`, `d` the rows above
/// and below) holding an empty pixel with an opposite pair of edge neighbours, in order, with
/// AVX-512 (F/BW + VBMI2, `crate::simd::vbmi`: the candidate test of eight words at once);
/// `false` (and no call) when the VBMI kernels are off.
fn words_with_candidates(c: &[u64], u: &[u64], d: &[u64], f: &mut impl FnMut(usize)) -> bool {
    #[cfg(target_arch = "x86_64")]
    if let Some(cpu) = crate::simd::Vbmi::get() {
        crate::simd::vbmi::fill::scan(cpu, c, u, d, f);
        return true;
    }
    let _ = (c, u, d, f);
    false
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
