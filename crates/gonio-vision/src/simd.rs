//! Runtime CPU-feature dispatch: the hot row loops are compiled again with AVX2 and with
//! AVX-512BW enabled and the widest one the CPU has is chosen at run time.
//!
//! The loops are plain safe integer Rust that the compiler vectorises; the AVX2 and AVX-512 copies
//! are the same code, so every path gives the same bits (the tests run all of them:
//! [`set_level`]). The only unsafe code is the call into the `#[target_feature]` functions, made
//! after checking the feature.

#![allow(unsafe_code)]

use std::sync::atomic::{AtomicU8, Ordering};

/// Instruction-set level of the hot loops.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub enum Level {
    /// Baseline target (SSE2 on x86-64).
    Scalar = 1,
    /// AVX2.
    Avx2 = 2,
    /// AVX-512 F + BW + VL.
    Avx512 = 3,
}

/// 0 = not yet detected, else the [`Level`] in use.
static MODE: AtomicU8 = AtomicU8::new(0);

fn from_u8(m: u8) -> Level {
    match m {
        3 => Level::Avx512,
        2 => Level::Avx2,
        _ => Level::Scalar,
    }
}

/// The level in use (detected on first call).
#[inline]
pub fn level() -> Level {
    match MODE.load(Ordering::Relaxed) {
        0 => {
            let m = detect();
            MODE.store(m as u8, Ordering::Relaxed);
            m
        }
        m => from_u8(m),
    }
}

/// True when an AVX2 (or wider) path is used.
pub fn avx2() -> bool {
    level() >= Level::Avx2
}

/// The widest level this CPU supports.
pub fn detect() -> Level {
    #[cfg(target_arch = "x86_64")]
    {
        if std::is_x86_feature_detected!("avx512bw")
            && std::is_x86_feature_detected!("avx512f")
            && std::is_x86_feature_detected!("avx512vl")
        {
            return Level::Avx512;
        }
        if std::is_x86_feature_detected!("avx2") {
            return Level::Avx2;
        }
        Level::Scalar
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        Level::Scalar
    }
}

/// Uses `want` or, if the CPU lacks it, the widest level it has. Process-wide; meant for tests
/// and benchmarks. Returns the level now in use.
pub fn set_level(want: Level) -> Level {
    let l = want.min(detect());
    MODE.store(l as u8, Ordering::Relaxed);
    l
}

/// Forces the scalar path (`false`) or re-enables the widest path the CPU has (`true`).
/// Process-wide; meant for tests and benchmarks.
pub fn set_enabled(enabled: bool) {
    set_level(if enabled {
        Level::Avx512
    } else {
        Level::Scalar
    });
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn with_avx2<R>(f: impl FnOnce() -> R) -> R {
    f()
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,avx512f,avx512bw,avx512vl")]
unsafe fn with_avx512<R>(f: impl FnOnce() -> R) -> R {
    f()
}

/// Runs `f` compiled for the widest available level.
#[inline(always)]
pub(crate) fn dispatch<R>(f: impl FnOnce() -> R) -> R {
    #[cfg(target_arch = "x86_64")]
    {
        match level() {
            // SAFETY: the CPU supports AVX-512 F/BW/VL (checked by `is_x86_feature_detected!`).
            Level::Avx512 => return unsafe { with_avx512(f) },
            // SAFETY: the CPU supports AVX2 (checked by `is_x86_feature_detected!`).
            Level::Avx2 => return unsafe { with_avx2(f) },
            Level::Scalar => {}
        }
    }
    f()
}
