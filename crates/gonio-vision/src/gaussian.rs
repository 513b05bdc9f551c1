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

/// The binomial kernel (sums to 16).
pub const KERNEL: [u16; 5] = [1, 4, 6, 4, 1];

/// Streaming 5×5 binomial blur.
#[derive(Debug, Clone)]
pub struct Gaussian5 {
    width: usize,
    padded: Vec<u8>,
    ring: Vec<u16>,
    n_in: usize,
    n_out: usize,
}

impl Gaussian5 {
    /// A blur for rows of `width` pixels.
    pub fn new(width: usize) -> Self {
        Gaussian5 {
            width,
            padded: vec![0; width + 4],
            ring: vec![0; 5 * width],
            n_in: 0,
            n_out: 0,
        }
    }
    /// Lag in rows (2).
    pub fn lag(&self) -> usize {
        2
    }
    /// Starts a new frame.
    pub fn reset(&mut self) {
        self.n_in = 0;
        self.n_out = 0;
    }
    /// Pushes one row; true when `out` holds the next output row.
    pub fn push_row(&mut self, row: &[u8], out: &mut [u8]) -> bool {
        let w = self.width;
        self.padded[2..w + 2].copy_from_slice(row);
        self.padded[0] = row[0];
        self.padded[1] = row[0];
        self.padded[w + 2] = row[w - 1];
        self.padded[w + 3] = row[w - 1];
        let s = (self.n_in % 5) * w;
        let p = &self.padded;
        for (i, h) in self.ring[s..s + w].iter_mut().enumerate() {
            *h = p[i] as u16
                + 4 * p[i + 1] as u16
                + 6 * p[i + 2] as u16
                + 4 * p[i + 3] as u16
                + p[i + 4] as u16;
        }
        self.n_in += 1;
        if self.n_in > 2 {
            self.emit(out);
            true
        } else {
            false
        }
    }
    /// After the last row: the next pending output row, false when none is left.
    pub fn flush_row(&mut self, out: &mut [u8]) -> bool {
        if self.n_out < self.n_in {
            self.emit(out);
            true
        } else {
            false
        }
    }
    fn emit(&mut self, out: &mut [u8]) {
        let w = self.width;
        let y = self.n_out as isize;
        let last = self.n_in as isize - 1;
        let r = |dy: isize| {
            let s = ((y + dy).clamp(0, last) as usize % 5) * w;
            &self.ring[s..s + w]
        };
        let (a, b, c, d, e) = (r(-2), r(-1), r(0), r(1), r(2));
        for (x, o) in out.iter_mut().enumerate() {
            let v = a[x] as u32 + 4 * b[x] as u32 + 6 * c[x] as u32 + 4 * d[x] as u32 + e[x] as u32;
            *o = ((v + 128) >> 8) as u8;
        }
        self.n_out += 1;
    }
}
