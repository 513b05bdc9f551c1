//! Correlation matrices in envelope (profile) storage and their Cholesky factor.
//!
//! Row i stores the columns from `first[i]` (the lowest row it is correlated with, or i) up to the
//! diagonal. The Cholesky factor of a matrix fills in only inside its envelope, so the factor
//! takes the same storage, and its cost is at most Σ_i (i − first[i] + 1)²: linear in the number
//! of rows for correlations between neighbouring rows (a chain of 1,000 rows: 2,000 entries),
//! against n³/3 for a dense factorisation (3·10⁸ for the same chain).
//!
//! The arithmetic is that of the dense column-by-column factorisation, term for term: the entries
//! outside the envelope are exact zeros there, so skipping them changes no bit of the result.

/// A symmetric correlation matrix (unit diagonal) in envelope storage, or its lower Cholesky
/// factor after [`Envelope::cholesky`].
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Envelope {
    /// First stored column of each row (≤ the row).
    first: Vec<usize>,
    /// Offset of each row's first stored entry in `values`.
    start: Vec<usize>,
    values: Vec<f64>,
}

impl Envelope {
    /// The n×n correlation matrix with unit diagonal and r_ij for each `(i, j, r)` (i ≠ j, both
    /// < n; a pair given twice keeps the last r). `Err(entries)` when its envelope would hold more
    /// than `limit` entries (nothing is allocated beyond O(n) then).
    pub(crate) fn correlation(
        n: usize,
        pairs: &[(usize, usize, f64)],
        limit: usize,
    ) -> Result<Envelope, usize> {
        let mut first: Vec<usize> = (0..n).collect();
        for &(i, j, _) in pairs {
            let (lo, hi) = if i < j { (i, j) } else { (j, i) };
            first[hi] = first[hi].min(lo);
        }
        let mut start = Vec::with_capacity(n);
        let mut size = 0usize;
        for (i, &f) in first.iter().enumerate() {
            start.push(size);
            size = size.saturating_add(i - f + 1);
        }
        if size > limit {
            return Err(size);
        }
        let mut m = Envelope {
            first,
            start,
            values: vec![0.0; size],
        };
        for i in 0..n {
            let k = m.index(i, i);
            m.values[k] = 1.0;
        }
        for &(i, j, r) in pairs {
            let (lo, hi) = if i < j { (i, j) } else { (j, i) };
            let k = m.index(hi, lo);
            m.values[k] = r;
        }
        Ok(m)
    }

    /// Number of rows.
    pub(crate) fn rows(&self) -> usize {
        self.first.len()
    }

    /// Number of stored entries (diagonal included).
    pub(crate) fn entries(&self) -> usize {
        self.values.len()
    }

    fn index(&self, i: usize, j: usize) -> usize {
        self.start[i] + (j - self.first[i])
    }

    /// Row i: its first stored column and the entries from there to the diagonal.
    pub(crate) fn row(&self, i: usize) -> (usize, &[f64]) {
        let end = self.start[i] + (i - self.first[i]) + 1;
        (self.first[i], &self.values[self.start[i]..end])
    }

    /// Replaces the matrix by its lower Cholesky factor; `None` if it is not positive
    /// semi-definite (a pivot below −10⁻¹⁰, or a zero pivot with a non-zero entry below it).
    /// Zero pivots (perfect correlation) are allowed.
    pub(crate) fn cholesky(&mut self) -> Option<()> {
        let n = self.rows();
        for i in 0..n {
            let fi = self.first[i];
            let si = self.start[i];
            // Off-diagonal entries L[i][j], j = fi..i, in the dense algorithm's order and
            // arithmetic: s = a_ij − Σ_k L[i][k]·L[j][k] term by term for ascending k.
            for j in fi..i {
                let fj = self.first[j];
                let sj = self.start[j];
                let k0 = fi.max(fj);
                let mut s = self.values[si + (j - fi)];
                for k in k0..j {
                    s -= self.values[si + (k - fi)] * self.values[sj + (k - fj)];
                }
                let d = self.values[sj + (j - fj)];
                self.values[si + (j - fi)] = if d > 0.0 {
                    s / d
                } else if s.abs() < 1e-10 {
                    0.0
                } else {
                    return None;
                };
            }
            let mut d = self.values[si + (i - fi)];
            for k in fi..i {
                let l = self.values[si + (k - fi)];
                d -= l * l;
            }
            if d < -1e-10 {
                return None;
            }
            self.values[si + (i - fi)] = d.max(0.0).sqrt();
        }
        Some(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The dense column-by-column factorisation this module replaces, for comparison.
    fn dense_cholesky(m: &mut [f64], n: usize) -> Option<()> {
        for j in 0..n {
            let mut d = m[j * n + j];
            for k in 0..j {
                d -= m[j * n + k] * m[j * n + k];
            }
            if d < -1e-10 {
                return None;
            }
            let d = d.max(0.0).sqrt();
            m[j * n + j] = d;
            for i in j + 1..n {
                let mut s = m[i * n + j];
                for k in 0..j {
                    s -= m[i * n + k] * m[j * n + k];
                }
                m[i * n + j] = if d > 0.0 {
                    s / d
                } else if s.abs() < 1e-10 {
                    0.0
                } else {
                    return None;
                };
            }
            for k in j + 1..n {
                m[j * n + k] = 0.0;
            }
        }
        Some(())
    }

    fn dense(n: usize, pairs: &[(usize, usize, f64)]) -> Vec<f64> {
        let mut m = vec![0.0; n * n];
        for i in 0..n {
            m[i * n + i] = 1.0;
        }
        for &(i, j, r) in pairs {
            m[i * n + j] = r;
            m[j * n + i] = r;
        }
        m
    }

    /// Bit-identical to the dense factor on a mixed pattern (chain, long-range pairs, an
    /// uncorrelated row, a perfectly correlated pair), and the same verdict on a matrix that is
    /// not positive semi-definite.
    #[test]
    fn same_bits_as_the_dense_factor() {
        let n = 9;
        let pairs = [
            (0, 1, 0.3),
            (1, 2, -0.4),
            (2, 3, 0.25),
            (5, 1, 0.2),
            (6, 7, 1.0),
            (8, 3, -0.1),
            (8, 5, 0.05),
        ];
        let mut d = dense(n, &pairs);
        dense_cholesky(&mut d, n).unwrap();
        let mut e = Envelope::correlation(n, &pairs, 1000).unwrap();
        e.cholesky().unwrap();
        for i in 0..n {
            let (f, row) = e.row(i);
            for j in 0..=i {
                let v = if j >= f { row[j - f] } else { 0.0 };
                assert_eq!(v.to_bits(), d[i * n + j].to_bits(), "L[{i}][{j}]");
            }
        }
        // r = 0.9 around a triangle with one negative pair is not a correlation matrix.
        let bad = [(0, 1, 0.9), (1, 2, 0.9), (0, 2, -0.9)];
        let mut d = dense(3, &bad);
        assert!(dense_cholesky(&mut d, 3).is_none());
        let mut e = Envelope::correlation(3, &bad, 1000).unwrap();
        assert!(e.cholesky().is_none());
    }

    #[test]
    fn chain_envelope_is_linear_and_limit_is_checked_first() {
        let n = 1000;
        let pairs: Vec<_> = (0..n - 1).map(|i| (i, i + 1, 0.3)).collect();
        let e = Envelope::correlation(n, &pairs, 10_000).unwrap();
        assert_eq!(e.entries(), 2 * n - 1);
        // One pair between the ends makes the envelope of the last row n long.
        assert_eq!(
            Envelope::correlation(n, &[(0, n - 1, 0.1)], 10).unwrap_err(),
            2 * n - 1
        );
    }
}
