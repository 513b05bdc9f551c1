//! Working memory of the self-calibration kept from one call to the next on each thread: the FFT
//! plans (their twiddle factors) and the large buffers (a 36,000-position turn of 12 heads needs
//! ≈ 10 MB of spectra and tables). Fresh allocations of that size come from the operating system
//! as untouched pages, and faulting them in cost as much as the arithmetic; reused buffers do not.
//! The values computed are the same either way (buffers are zeroed or overwritten before use).

use realfft::num_complex::Complex;
use realfft::{ComplexToReal, RealFftPlanner, RealToComplex};
use std::cell::RefCell;
use std::sync::Arc;

type C64 = Complex<f64>;

/// Buffers kept per thread at most (the largest call needs about thirty).
const KEEP: usize = 64;

thread_local! {
    static PLANNER: RefCell<RealFftPlanner<f64>> = RefCell::new(RealFftPlanner::new());
    static COMPLEX: RefCell<Vec<Vec<C64>>> = const { RefCell::new(Vec::new()) };
    static REAL: RefCell<Vec<Vec<f64>>> = const { RefCell::new(Vec::new()) };
}

/// The forward real FFT of length `n` (planned once per thread).
pub(crate) fn forward(n: usize) -> Arc<dyn RealToComplex<f64>> {
    PLANNER.with(|p| p.borrow_mut().plan_fft_forward(n))
}

/// The inverse real FFT of length `n` (planned once per thread).
pub(crate) fn inverse(n: usize) -> Arc<dyn ComplexToReal<f64>> {
    PLANNER.with(|p| p.borrow_mut().plan_fft_inverse(n))
}

fn take<T: Copy>(pool: &RefCell<Vec<Vec<T>>>, len: usize, zero: T) -> Vec<T> {
    let mut pool = pool.borrow_mut();
    // The smallest kept buffer that is large enough, else the largest (it grows once).
    let pick = pool
        .iter()
        .enumerate()
        .filter(|(_, v)| v.capacity() >= len)
        .min_by_key(|(_, v)| v.capacity())
        .or_else(|| pool.iter().enumerate().max_by_key(|(_, v)| v.capacity()))
        .map(|(i, _)| i);
    let mut v = pick.map(|i| pool.swap_remove(i)).unwrap_or_default();
    v.clear();
    v.resize(len, zero);
    v
}

fn give<T>(pool: &RefCell<Vec<Vec<T>>>, v: Vec<T>) {
    let mut pool = pool.borrow_mut();
    if pool.len() < KEEP && v.capacity() > 0 {
        pool.push(v);
    }
}

/// `len` complex zeros.
pub(crate) fn complex(len: usize) -> Vec<C64> {
    COMPLEX.with(|p| take(p, len, C64::new(0.0, 0.0)))
}

/// `len` real zeros.
pub(crate) fn real(len: usize) -> Vec<f64> {
    REAL.with(|p| take(p, len, 0.0))
}

/// Hands a complex buffer back for the next call.
pub(crate) fn give_complex(v: Vec<C64>) {
    COMPLEX.with(|p| give(p, v));
}

/// Hands a real buffer back for the next call.
pub(crate) fn give_real(v: Vec<f64>) {
    REAL.with(|p| give(p, v));
}
