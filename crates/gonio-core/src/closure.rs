//! Circle-closure helpers: cyclic indices and zero-mean normalisation.
//!
//! A full circle closes: the N pitch deviations of a polygon sum to zero, and an encoder's error
//! over N equally spaced angles is defined relative to its mean. These helpers keep the 1-based,
//! wrap-around index arithmetic of the papers in one place.

/// Wraps a 1-based index into `1..=n` (so `n + 1 → 1` and `0 → n`).
///
/// This is the papers' `MOD[k, N]` read correctly: it returns `n`, never 0.
///
/// ```
/// use gonio_core::closure::wrap1;
/// assert_eq!(wrap1(25, 24), 1);
/// assert_eq!(wrap1(24, 24), 24);
/// assert_eq!(wrap1(0, 24), 24);
/// assert_eq!(wrap1(-1, 24), 23);
/// ```
#[inline]
pub fn wrap1(k: i64, n: usize) -> usize {
    let n = n as i64;
    ((k - 1).rem_euclid(n) + 1) as usize
}

/// The arithmetic mean (0 for an empty slice).
pub fn mean(values: &[f64]) -> f64 {
    if values.is_empty() {
        0.0
    } else {
        values.iter().sum::<f64>() / values.len() as f64
    }
}

/// Subtracts the mean so the values close (sum to zero); returns the mean removed.
///
/// ```
/// use gonio_core::closure::remove_mean;
/// let mut v = vec![1.0, 2.0, 6.0];
/// assert_eq!(remove_mean(&mut v), 3.0);
/// assert_eq!(v, vec![-2.0, -1.0, 3.0]);
/// ```
pub fn remove_mean(values: &mut [f64]) -> f64 {
    let m = mean(values);
    for v in values.iter_mut() {
        *v -= m;
    }
    m
}

/// Sum of `values[start-1]`, `values[start]`, … over `count` terms, cyclically (1-based `start`).
///
/// For pitch deviations β this is the paper's C(j, i) = β_j + … + β_(j+i−1).
///
/// ```
/// use gonio_core::closure::cyclic_sum;
/// let beta = [1.0, 2.0, 3.0, -6.0];
/// assert_eq!(cyclic_sum(&beta, 3, 3), 3.0 - 6.0 + 1.0);
/// ```
pub fn cyclic_sum(values: &[f64], start: usize, count: usize) -> f64 {
    let n = values.len();
    (0..count).map(|t| values[(start - 1 + t) % n]).sum()
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    proptest! {
        #[test]
        fn wrap_in_range(k in -1000i64..1000, n in 1usize..100) {
            let w = wrap1(k, n);
            prop_assert!((1..=n).contains(&w));
            prop_assert_eq!((w as i64 - k).rem_euclid(n as i64), 0);
        }
    }
}
