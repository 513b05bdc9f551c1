//! Runtime CPU-feature dispatch: the hot row loops are compiled a second time with AVX2 enabled
//! and chosen at run time when the CPU has it.
//!
//! The loops are plain safe integer Rust that the compiler vectorises; the AVX2 copy is the same
//! code, so both paths give the same bits (the tests run both: [`set_enabled`]). The only unsafe
//! code is the call into the `#[target_feature]` function, made after checking the feature.

#![allow(unsafe_code)]

use std::sync::atomic::{AtomicU8, Ordering};

/// 0 = not yet detected, 1 = scalar, 2 = AVX2.
static MODE: AtomicU8 = AtomicU8::new(0);

/// True when the AVX2 path is used.
pub fn avx2() -> bool {
    match MODE.load(Ordering::Relaxed) {
        0 => {
            let m = if detect() { 2 } else { 1 };
            MODE.store(m, Ordering::Relaxed);
            m == 2
        }
        m => m == 2,
    }
}

fn detect() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        std::is_x86_feature_detected!("avx2")
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        false
    }
}

/// Forces the scalar path (`false`) or re-enables the AVX2 path where the CPU has it (`true`).
/// Process-wide; meant for tests and benchmarks.
pub fn set_enabled(enabled: bool) {
    MODE.store(if enabled && detect() { 2 } else { 1 }, Ordering::Relaxed);
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn with_avx2<R>(f: impl FnOnce() -> R) -> R {
    f()
}

/// Runs `f` compiled for AVX2 when available, else as is.
#[inline(always)]
pub(crate) fn dispatch<R>(f: impl FnOnce() -> R) -> R {
    #[cfg(target_arch = "x86_64")]
    {
        if avx2() {
            // SAFETY: the CPU supports AVX2 (checked by `is_x86_feature_detected!`).
            return unsafe { with_avx2(f) };
        }
    }
    f()
}
