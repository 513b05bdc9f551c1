//! Runtime CPU-feature dispatch and every kernel written with intrinsics: the crate's only
//! unsafe code (the workspace denies `unsafe_code`; only this module allows it).
//!
//! The hot row loops are compiled again with AVX2 and with AVX-512 (F, BW, VL, DQ) enabled, and
//! the best version the CPU has is chosen at run time (`dispatch`): plain safe integer Rust
//! that the compiler vectorises, every copy the same code, so all paths give the same bits
//! (the tests run each: [`set_level`]). The kernels written by hand with intrinsics live in one
//! module per instruction set:
//!
//! - `avx2`: the focus measure's Σ|a − b|, Σ(a − b)² of two rows;
//! - `avx512` (F/BW/VL/DQ): the fused blur and Sobel, the segmentation's classification and
//!   directions, the labeller's pixel writes and row scan;
//! - `vbmi` (AVX-512 VBMI/VBMI2): the morphology's register kernel, the segmentation's pixel
//!   gather, the edge filling's scan;
//! - `vnni` (AVX-512 VNNI): the focus sums' dot products.
//!
//! Each kernel is an `unsafe fn` with `#[target_feature]` and a `# Safety` section, every
//! unsafe block in it has a `// SAFETY:` comment, and the stages call it through a safe
//! wrapper that takes a proof of the CPU's features (`Avx2`, `Avx512`, `Vbmi`, `Vnni`):
//! zero-sized values only this module makes, after `is_x86_feature_detected!`. A stage thus
//! holds no unsafe code.

#![allow(unsafe_code)]

use std::sync::atomic::{AtomicU8, Ordering};

/// A code path.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub enum Level {
    /// The baseline target (SSE2 on x86-64): the scalar reference path.
    Scalar = 1,
    /// AVX2 (32-byte vectors).
    Avx2 = 2,
    /// AVX-512 F/BW/VL/DQ (64-byte vectors, mask registers).
    Avx512 = 3,
}

/// 0 = not yet chosen, else a [`Level`].
static MODE: AtomicU8 = AtomicU8::new(0);

/// The best level this CPU supports.
pub fn detected() -> Level {
    #[cfg(target_arch = "x86_64")]
    {
        if std::is_x86_feature_detected!("avx512f")
            && std::is_x86_feature_detected!("avx512bw")
            && std::is_x86_feature_detected!("avx512vl")
            && std::is_x86_feature_detected!("avx512dq")
        {
            return Level::Avx512;
        }
        if std::is_x86_feature_detected!("avx2") {
            return Level::Avx2;
        }
    }
    Level::Scalar
}

/// The level in use: the best the CPU has unless [`set_level`] chose another.
#[inline]
pub fn level() -> Level {
    match MODE.load(Ordering::Relaxed) {
        1 => Level::Scalar,
        2 => Level::Avx2,
        3 => Level::Avx512,
        _ => {
            let l = std::env::var("GONIO_SIMD")
                .ok()
                .and_then(|v| match v.as_str() {
                    "scalar" => Some(Level::Scalar),
                    "avx2" => Some(Level::Avx2),
                    "avx512" => Some(Level::Avx512),
                    _ => None,
                })
                .map_or(detected(), |l| l.min(detected()));
            MODE.store(l as u8, Ordering::Relaxed);
            l
        }
    }
}

/// Uses `want`, or the best level the CPU has below it; returns the level now in use.
/// Process-wide; meant for tests and benchmarks (the environment variable `GONIO_SIMD` =
/// `scalar`, `avx2` or `avx512` does the same for a whole run).
pub fn set_level(want: Level) -> Level {
    let l = want.min(detected());
    MODE.store(l as u8, Ordering::Relaxed);
    l
}

/// Forces the scalar path (`false`) or re-enables the best path the CPU has (`true`).
pub fn set_enabled(enabled: bool) {
    set_level(if enabled {
        Level::Avx512
    } else {
        Level::Scalar
    });
}

/// True when an AVX2 or AVX-512 path is used.
pub fn avx2() -> bool {
    level() >= Level::Avx2
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,bmi1,bmi2,lzcnt,popcnt")]
unsafe fn with_avx2<R>(f: impl FnOnce() -> R) -> R {
    f()
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,avx512bw,avx512vl,avx512dq,avx2,bmi1,bmi2,lzcnt,popcnt")]
pub(crate) unsafe fn with_avx512<R>(f: impl FnOnce() -> R) -> R {
    f()
}

/// Runs `f` compiled for the level in use.
#[inline(always)]
pub(crate) fn dispatch<R>(f: impl FnOnce() -> R) -> R {
    #[cfg(target_arch = "x86_64")]
    {
        match level() {
            // SAFETY: the CPU supports the features (checked by `is_x86_feature_detected!` in
            // `detected`, which bounds every level `level` returns).
            Level::Avx512 => return unsafe { with_avx512(f) },
            Level::Avx2 => return unsafe { with_avx2(f) },
            Level::Scalar => {}
        }
    }
    f()
}

/// 0 = not yet checked, 1 = VBMI kernels off, 2 = on.
static VBMI: AtomicU8 = AtomicU8::new(0);

/// True when the CPU has AVX-512 VBMI (`vpermb`, `vpermt2b`) and VBMI2 (`vpcompressw`) besides
/// the AVX-512 level (checked once with `is_x86_feature_detected!`).
pub fn vbmi_detected() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        if detected() == Level::Avx512 {
            return std::is_x86_feature_detected!("avx512vbmi")
                && std::is_x86_feature_detected!("avx512vbmi2");
        }
    }
    false
}

/// True when the kernels written with AVX-512 VBMI/VBMI2 intrinsics (the morphology's register
/// kernel, the segmentation's mask path) are used: the level in use is AVX-512, the CPU has
/// VBMI and VBMI2 and [`set_vbmi`] did not turn them off.
#[inline]
pub fn vbmi() -> bool {
    cached(&VBMI, vbmi_detected) && level() == Level::Avx512
}

/// The flag `flag` (0 = not yet checked, 1 = off, 2 = on), set from `detect` on first use.
#[inline]
fn cached(flag: &AtomicU8, detect: fn() -> bool) -> bool {
    match flag.load(Ordering::Relaxed) {
        1 => false,
        2 => true,
        _ => {
            let on = detect();
            flag.store(if on { 2 } else { 1 }, Ordering::Relaxed);
            on
        }
    }
}

/// Turns the VBMI kernels off (`false`: the AVX-512 level then runs the compiler-vectorised
/// loops, as on a CPU without VBMI) or back on where the CPU has them (`true`). Process-wide;
/// meant for tests and benchmarks.
pub fn set_vbmi(enabled: bool) {
    let on = enabled && vbmi_detected();
    VBMI.store(if on { 2 } else { 1 }, Ordering::Relaxed);
}

/// 0 = not yet checked, 1 = no AVX-512 VNNI, 2 = the CPU has it.
static VNNI: AtomicU8 = AtomicU8::new(0);

/// True when the CPU has AVX-512 VNNI (`vpdpbusd`) besides the AVX-512 level (checked with
/// `is_x86_feature_detected!`).
pub fn vnni_detected() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        if detected() == Level::Avx512 {
            return std::is_x86_feature_detected!("avx512vnni");
        }
    }
    false
}

/// True when the level in use is AVX-512 and the CPU has AVX-512 VNNI (checked once): the focus
/// sums' dot-product path ([`crate::focus`]).
#[inline]
pub fn vnni() -> bool {
    cached(&VNNI, vnni_detected) && level() == Level::Avx512
}

/// The mask of a 64-lane vector's first `n` lanes (all 64 when `n` ≥ 64): the columns of a
/// row's tail, for masked loads and stores.
#[inline(always)]
pub(crate) const fn first_lanes(n: usize) -> u64 {
    if n >= 64 { !0 } else { (1u64 << n) - 1 }
}

/// Asks the CPU to bring `bytes` into the L1 cache ahead of their use: one `prefetcht0` per
/// 64-byte line. A hint only (it never faults and changes no result); nothing on other targets.
#[inline(always)]
pub(crate) fn prefetch(bytes: &[u8]) {
    #[cfg(target_arch = "x86_64")]
    for line in bytes.chunks(64) {
        use std::arch::x86_64::{_MM_HINT_T0, _mm_prefetch};
        // SAFETY: a prefetch is a hint that cannot fault; the address lies inside `bytes`. SSE
        // is part of the x86-64 baseline.
        unsafe { _mm_prefetch::<_MM_HINT_T0>(line.as_ptr().cast()) };
    }
}

/// Proof that the AVX2 level (or above) is in use on a CPU that has AVX2: made only by
/// [`Avx2::get`] (the features checked with `is_x86_feature_detected!` in [`detected`], which
/// bounds every level [`level`] returns), so a kernel that takes one may use the instructions.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct Avx2(());

impl Avx2 {
    /// The proof, when the level in use is AVX2 or above.
    #[inline]
    pub(crate) fn get() -> Option<Avx2> {
        (level() >= Level::Avx2).then_some(Avx2(()))
    }

    /// The proof, when the CPU has AVX2, whatever the level in use (for the tests that
    /// compare the AVX2 path with the others).
    #[cfg(test)]
    pub(crate) fn detected() -> Option<Avx2> {
        (detected() >= Level::Avx2).then_some(Avx2(()))
    }
}

/// Proof that the AVX-512 level (F/BW/VL/DQ, with AVX2, BMI1/2, LZCNT, POPCNT) is in use on a
/// CPU that has it: made only by [`Avx512::get`] (see [`Avx2`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct Avx512(());

impl Avx512 {
    /// The proof, when the level in use is AVX-512.
    #[inline]
    pub(crate) fn get() -> Option<Avx512> {
        (level() == Level::Avx512).then_some(Avx512(()))
    }
}

/// Proof that the VBMI kernels are in use ([`vbmi`]: the AVX-512 level on a CPU with AVX-512
/// VBMI and VBMI2): made only by [`Vbmi::get`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct Vbmi(());

impl Vbmi {
    /// The proof, when the VBMI kernels are in use.
    #[inline]
    pub(crate) fn get() -> Option<Vbmi> {
        vbmi().then_some(Vbmi(()))
    }
}

/// Proof that the VNNI path is in use ([`vnni`]: the AVX-512 level on a CPU with AVX-512
/// VNNI): made only by [`Vnni::get`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct Vnni(());

impl Vnni {
    /// The proof, when the VNNI path is in use.
    #[inline]
    pub(crate) fn get() -> Option<Vnni> {
        vnni().then_some(Vnni(()))
    }

    /// The proof, when the CPU has AVX-512 F/BW and VNNI, whatever the level in use (for the
    /// tests that compare the VNNI path with the others).
    #[cfg(test)]
    pub(crate) fn detected() -> Option<Vnni> {
        vnni_detected().then_some(Vnni(()))
    }
}

#[cfg(target_arch = "x86_64")]
pub(crate) mod avx2;
#[cfg(target_arch = "x86_64")]
pub(crate) mod avx512;
#[cfg(target_arch = "x86_64")]
pub(crate) mod vbmi;
#[cfg(target_arch = "x86_64")]
pub(crate) mod vnni;
