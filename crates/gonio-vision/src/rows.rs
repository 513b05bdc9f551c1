//! Row bookkeeping shared by the streaming stages: rows received, rows emitted, the fixed lag,
//! and which slot of the stage's ring of 2·lag + 1 rows holds a given row.
//!
//! Every stage with a vertical kernel of half-height `lag` keeps the last 2·lag + 1 input rows in
//! a ring and emits output row y once row y + lag has arrived (or, after the frame's last row,
//! from [`RowLag::pending`]). Only the counting lives here; each stage keeps its own row storage.
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

/// Counters of a streaming stage with a fixed lag.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct RowLag {
    lag: usize,
    n_in: usize,
    n_out: usize,
}

impl RowLag {
    /// Bookkeeping for a stage whose output row y needs input rows up to y + `lag`.
    pub const fn new(lag: usize) -> Self {
        RowLag {
            lag,
            n_in: 0,
            n_out: 0,
        }
    }

    /// The lag in rows.
    #[inline]
    pub fn lag(&self) -> usize {
        self.lag
    }

    /// Rows in the ring: 2·lag + 1.
    #[inline]
    pub fn depth(&self) -> usize {
        2 * self.lag + 1
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

/// The first index ≥ `from` whose byte is not zero (`bytes.len()` when none): eight bytes at a
/// time, for the sparse masks of edge and candidate pixels.
///
/// ```
/// use gonio_vision::rows::next_set;
/// let m = [0u8, 0, 0, 0, 0, 0, 0, 0, 0, 0, 3, 0];
/// assert_eq!(next_set(&m, 0), 10);
/// assert_eq!(next_set(&m, 11), 12);
/// ```
#[inline(always)]
pub fn next_set(bytes: &[u8], from: usize) -> usize {
    let mut x = from;
    while let Some(chunk) = bytes.get(x..x + 8) {
        let word = u64::from_le_bytes(chunk.try_into().unwrap_or([0; 8]));
        if word != 0 {
            return x + (word.trailing_zeros() / 8) as usize;
        }
        x += 8;
    }
    while x < bytes.len() && bytes[x] == 0 {
        x += 1;
    }
    x.min(bytes.len())
}
