//! Edge filling (seed Algorithm 1); lag 1 row.
//!
//! NMS's four-way quantisation leaves one-pixel gaps in slanted edges. An empty pixel is filled
//! when two opposite neighbours (W–E, N–S, NW–SE, NE–SW, checked in that order) are both edge
//! pixels whose directions differ by less than 45°; the filled pixel is weak, takes the mean of
//! the two directions and has no sub-pixel position of its own ([`FILLED`]). Filling looks at
//! the unfilled input only, so it never cascades.
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

use crate::rows::{RowLag, next_set};
use crate::segment::{EdgeRow, FILLED, NONE, WEAK};

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
    ring: [EdgeRow; 3],
    empty: EdgeRow,
    any: Vec<u8>,
    rows: RowLag,
}

impl EdgeFill {
    /// A filler for rows of `width` pixels.
    pub fn new(width: usize) -> Self {
        EdgeFill {
            width,
            ring: [
                EdgeRow::new(width),
                EdgeRow::new(width),
                EdgeRow::new(width),
            ],
            empty: EdgeRow::new(width),
            any: vec![0; width],
            rows: RowLag::new(1),
        }
    }
    /// Lag in rows (1).
    pub fn lag(&self) -> usize {
        self.rows.lag()
    }
    /// Starts a new frame.
    pub fn reset(&mut self) {
        self.rows.reset();
    }
    /// Pushes one edge row; true when `out` holds the next output row.
    pub fn push_row(&mut self, row: &EdgeRow, out: &mut EdgeRow) -> bool {
        self.ring[self.rows.input_slot()].copy_from(row);
        let ready = self.rows.pushed();
        self.emit_if(ready, out)
    }
    /// Like [`EdgeFill::push_row`] but takes the row by swapping buffers instead of copying it:
    /// `row` is left holding stale data for the caller to overwrite.
    pub fn push_row_swap(&mut self, row: &mut EdgeRow, out: &mut EdgeRow) -> bool {
        std::mem::swap(&mut self.ring[self.rows.input_slot()], row);
        let ready = self.rows.pushed();
        self.emit_if(ready, out)
    }
    /// After the last row: the next pending output row, false when none is left.
    pub fn flush_row(&mut self, out: &mut EdgeRow) -> bool {
        let ready = self.rows.pending();
        self.emit_if(ready, out)
    }
    fn emit_if(&mut self, ready: bool, out: &mut EdgeRow) -> bool {
        if ready {
            crate::simd::dispatch(|| self.emit_impl(out));
        }
        ready
    }

    #[inline(always)]
    #[allow(clippy::needless_range_loop)]
    fn emit_impl(&mut self, out: &mut EdgeRow) {
        let w = self.width;
        let cur = &self.ring[self.rows.clamped(0)];
        let up = self
            .rows
            .neighbour(-1)
            .map_or(&self.empty, |s| &self.ring[s]);
        let down = self
            .rows
            .neighbour(1)
            .map_or(&self.empty, |s| &self.ring[s]);
        out.copy_from(cur);
        // Necessary condition, vectorised over the row: an empty pixel with some opposite pair
        // of edge neighbours. fill_pixel then decides exactly. The two border pixels are always
        // checked in full.
        let (uc, cc, dc) = (&up.class, &cur.class, &down.class);
        let need = &mut self.any;
        if w >= 3 {
            let n = w - 2;
            let (cl, cm, cr) = (&cc[..n], &cc[1..n + 1], &cc[2..n + 2]);
            let (ul, um, ur) = (&uc[..n], &uc[1..n + 1], &uc[2..n + 2]);
            let (dl, dm, dr) = (&dc[..n], &dc[1..n + 1], &dc[2..n + 2]);
            let nd = &mut need[1..n + 1];
            for i in 0..n {
                let e = |v: u8| v != NONE;
                let pair = (e(cl[i]) & e(cr[i]))
                    | (e(um[i]) & e(dm[i]))
                    | (e(ul[i]) & e(dr[i]))
                    | (e(ur[i]) & e(dl[i]));
                nd[i] = (!e(cm[i]) & pair) as u8;
            }
            need[0] = 1;
            need[w - 1] = 1;
        } else {
            need.fill(1);
        }
        let mut x = 0;
        loop {
            x = next_set(&self.any, x);
            if x >= w {
                break;
            }
            {
                if cur.class[x] == NONE {
                    let get = |r: &EdgeRow, dx: isize| {
                        let xx = x as isize + dx;
                        if xx < 0 || xx >= w as isize {
                            (0, 0)
                        } else {
                            (r.class[xx as usize], r.dir[xx as usize])
                        }
                    };
                    let mut class = [[0u8; 3]; 3];
                    let mut dir = [[0u8; 3]; 3];
                    for (dy, r) in [up, cur, down].into_iter().enumerate() {
                        for dx in 0..3 {
                            let (c, d) = get(r, dx as isize - 1);
                            class[dy][dx] = c;
                            dir[dy][dx] = d;
                        }
                    }
                    if let Some((c, d, s)) = fill_pixel(&class, &dir) {
                        out.class[x] = c;
                        out.dir[x] = d;
                        out.sub[x] = s;
                    }
                }
            }
            x += 1;
        }
        self.rows.advance();
    }
}
