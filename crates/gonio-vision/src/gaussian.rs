//! Streaming 5×5 Gaussian blur (binomial 1-4-6-4-1, σ = 1) with replicated borders; lag 2 rows.
//!
//! Integer arithmetic: the separable sum of weights 256 is rounded, `(Σ + 128) >> 8`.
//!
//! ```
//! use gonio_vision::gaussian::Gaussian5;
//! let mut g = Gaussian5::new(6);
//! let mut out = [0u8; 6];
//! let mut rows = Vec::new();
//! for _ in 0..4 { if g.push_row(&[50; 6], &mut out) { rows.push(out); } }
//! while g.flush_row(&mut out) { rows.push(out); }
//! assert_eq!(rows, vec![[50u8; 6]; 4]); // a flat image stays flat
//! ```

use crate::rows::RowLag;

/// The binomial kernel (sums to 16).
pub const KERNEL: [u16; 5] = [1, 4, 6, 4, 1];

/// Streaming 5×5 binomial blur.
#[derive(Debug, Clone)]
pub struct Gaussian5 {
    width: usize,
    padded: Vec<u8>,
    ring: Vec<u16>,
    rows: RowLag,
}

impl Gaussian5 {
    /// A blur for rows of `width` pixels.
    pub fn new(width: usize) -> Self {
        Gaussian5 {
            width,
            padded: vec![0; width + 4],
            ring: vec![0; 5 * width],
            rows: RowLag::new(2),
        }
    }
    /// Lag in rows (2).
    pub fn lag(&self) -> usize {
        self.rows.lag()
    }
    /// Starts a new frame.
    pub fn reset(&mut self) {
        self.rows.reset();
    }
    /// Pushes one row; true when `out` holds the next output row.
    pub fn push_row(&mut self, row: &[u8], out: &mut [u8]) -> bool {
        crate::simd::dispatch(|| self.push_row_impl(row, out))
    }

    #[inline(always)]
    fn push_row_impl(&mut self, row: &[u8], out: &mut [u8]) -> bool {
        let w = self.width;
        self.padded[2..w + 2].copy_from_slice(row);
        self.padded[0] = row[0];
        self.padded[1] = row[0];
        self.padded[w + 2] = row[w - 1];
        self.padded[w + 3] = row[w - 1];
        let s = self.rows.input_slot() * w;
        let p = &self.padded;
        let (p0, p1, p2, p3, p4) = (
            &p[..w],
            &p[1..w + 1],
            &p[2..w + 2],
            &p[3..w + 3],
            &p[4..w + 4],
        );
        for (((((h, &a), &b), &c), &d), &e) in self.ring[s..s + w]
            .iter_mut()
            .zip(p0)
            .zip(p1)
            .zip(p2)
            .zip(p3)
            .zip(p4)
        {
            *h = a as u16 + 4 * b as u16 + 6 * c as u16 + 4 * d as u16 + e as u16;
        }
        let ready = self.rows.pushed();
        if ready {
            self.emit(out);
        }
        ready
    }
    /// After the last row: the next pending output row, false when none is left.
    pub fn flush_row(&mut self, out: &mut [u8]) -> bool {
        let ready = self.rows.pending();
        if ready {
            crate::simd::dispatch(|| self.emit(out));
        }
        ready
    }
    #[inline(always)]
    fn emit(&mut self, out: &mut [u8]) {
        let w = self.width;
        let r = |dy: isize| {
            let s = self.rows.clamped(dy) * w;
            &self.ring[s..s + w]
        };
        let (a, b, c, d, e) = (r(-2), r(-1), r(0), r(1), r(2));
        for (x, o) in out.iter_mut().enumerate() {
            let v = a[x] as u32 + 4 * b[x] as u32 + 6 * c[x] as u32 + 4 * d[x] as u32 + e[x] as u32;
            *o = ((v + 128) >> 8) as u8;
        }
        self.rows.advance();
    }
}
