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
//! zero-sized values only this module makes, after `is_x86_feature_detected!` found every
//! feature the path's functions enable ([`AVX2_FEATURES`], [`AVX512_FEATURES`],
//! [`VBMI_FEATURES`], [`VNNI_FEATURES`]; a test reads every `#[target_feature]` of the crate and
//! holds it to these lists). A stage thus holds no unsafe code.

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

/// Every target feature the AVX2 level's code is compiled with (the `#[target_feature]` of
/// every function it runs, kernels included): the level is used only on a CPU with all of them.
pub const AVX2_FEATURES: &[&str] = &["avx2", "bmi1", "bmi2", "lzcnt", "popcnt"];

/// Every target feature the AVX-512 level's code is compiled with (F/BW/VL/DQ, and the AVX2
/// level's).
pub const AVX512_FEATURES: &[&str] = &[
    "avx512f", "avx512bw", "avx512vl", "avx512dq", "avx2", "bmi1", "bmi2", "lzcnt", "popcnt",
];

/// The features the VBMI kernels enable beyond the AVX-512 level's.
pub const VBMI_FEATURES: &[&str] = &["avx512vbmi", "avx512vbmi2"];

/// The features the VNNI kernels enable beyond the AVX-512 level's.
pub const VNNI_FEATURES: &[&str] = &["avx512vnni"];

/// Whether the CPU has the target feature `name` (checked with `is_x86_feature_detected!`);
/// `None` for a name this function does not know (every name in the lists above is known).
pub fn cpu_has(name: &str) -> Option<bool> {
    #[cfg(target_arch = "x86_64")]
    {
        macro_rules! known {
            ($($f:tt),*) => {
                match name {
                    $($f => Some(std::is_x86_feature_detected!($f)),)*
                    _ => None,
                }
            };
        }
        known!(
            "avx2",
            "bmi1",
            "bmi2",
            "lzcnt",
            "popcnt",
            "avx512f",
            "avx512bw",
            "avx512vl",
            "avx512dq",
            "avx512vbmi",
            "avx512vbmi2",
            "avx512vnni"
        )
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        let _ = name;
        None
    }
}

/// Whether the CPU has every feature of `features`.
fn has_all(features: &[&str]) -> bool {
    features.iter().all(|f| cpu_has(f) == Some(true))
}

/// 0 = not yet checked, else the [`Level`] the CPU supports.
static DETECTED: AtomicU8 = AtomicU8::new(0);

/// The best level this CPU supports: the highest whose every feature
/// ([`AVX512_FEATURES`], [`AVX2_FEATURES`]) it has. Checked once: the kernels' safe wrappers
/// assert it on every call (a row's), and the features of a CPU do not change while it runs.
#[inline]
pub fn detected() -> Level {
    match DETECTED.load(Ordering::Relaxed) {
        1 => Level::Scalar,
        2 => Level::Avx2,
        3 => Level::Avx512,
        _ => {
            let l = if has_all(AVX512_FEATURES) {
                Level::Avx512
            } else if has_all(AVX2_FEATURES) {
                Level::Avx2
            } else {
                Level::Scalar
            };
            DETECTED.store(l as u8, Ordering::Relaxed);
            l
        }
    }
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
            // SAFETY: the CPU has every feature each function enables ([`AVX512_FEATURES`],
            // [`AVX2_FEATURES`]: all checked in `detected`, which bounds every level `level`
            // returns).
            Level::Avx512 => return unsafe { with_avx512(f) },
            Level::Avx2 => return unsafe { with_avx2(f) },
            Level::Scalar => {}
        }
    }
    f()
}

/// 0 = not yet checked, 1 = VBMI kernels off, 2 = on.
static VBMI: AtomicU8 = AtomicU8::new(0);

/// True when the CPU has AVX-512 VBMI (`vpermb`, `vpermt2b`) and VBMI2 (`vpcompressw`)
/// ([`VBMI_FEATURES`]) besides the AVX-512 level.
pub fn vbmi_detected() -> bool {
    cached(&VBMI_CPU, || {
        detected() == Level::Avx512 && has_all(VBMI_FEATURES)
    })
}

/// 0 = not yet checked, 1 = the CPU lacks VBMI or VBMI2, 2 = it has both.
static VBMI_CPU: AtomicU8 = AtomicU8::new(0);

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

/// True when the CPU has AVX-512 VNNI (`vpdpbusd`, [`VNNI_FEATURES`]) besides the AVX-512
/// level.
pub fn vnni_detected() -> bool {
    cached(&VNNI_CPU, || {
        detected() == Level::Avx512 && has_all(VNNI_FEATURES)
    })
}

/// 0 = not yet checked, 1 = the CPU lacks VNNI, 2 = it has it.
static VNNI_CPU: AtomicU8 = AtomicU8::new(0);

/// Every code path this CPU offers, by name: `scalar`, `avx2`, `avx512`, and the AVX-512
/// kernels beyond the level, `vbmi` and `vnni`, as far as the CPU has their features. A test
/// that compares the paths checks that it ran every one of these.
pub fn offered() -> Vec<&'static str> {
    let mut v = vec!["scalar"];
    if detected() >= Level::Avx2 {
        v.push("avx2");
    }
    if detected() >= Level::Avx512 {
        v.push("avx512");
    }
    if vbmi_detected() {
        v.push("vbmi");
    }
    if vnni_detected() {
        v.push("vnni");
    }
    v
}

/// The code paths in use now, by the names of [`offered`]: the level and, at the AVX-512
/// level, the `vbmi` and `vnni` kernels when they are on.
pub fn in_use() -> Vec<&'static str> {
    let mut v = vec![match level() {
        Level::Scalar => "scalar",
        Level::Avx2 => "avx2",
        Level::Avx512 => "avx512",
    }];
    if vbmi() {
        v.push("vbmi");
    }
    if vnni() {
        v.push("vnni");
    }
    v
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

/// Proof that the VBMI kernels are in use ([`vbmi`](mod@vbmi): the AVX-512 level on a CPU with
/// AVX-512 VBMI and VBMI2): made only by [`Vbmi::get`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct Vbmi(());

impl Vbmi {
    /// The proof, when the VBMI kernels are in use.
    #[inline]
    pub(crate) fn get() -> Option<Vbmi> {
        vbmi().then_some(Vbmi(()))
    }
}

/// Proof that the VNNI path is in use ([`vnni`](mod@vnni): the AVX-512 level on a CPU with AVX-512
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

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::{Path, PathBuf};

    /// Every `#[target_feature]` attribute of a source text: the function it is on and the
    /// features it enables.
    fn enabled(text: &str) -> Vec<(String, Vec<String>)> {
        // Written in two pieces, so that this function's own text is not one of them.
        let key = concat!("target_feature", "(enable = \"");
        let mut out = Vec::new();
        let mut rest = text;
        while let Some(i) = rest.find(key) {
            rest = &rest[i + key.len()..];
            let end = rest.find('"').expect("the attribute's closing quote");
            let features = rest[..end].split(',').map(|f| f.trim().to_string());
            let after = &rest[end..];
            let name = after.find("fn ").map_or("", |j| {
                after[j + 3..]
                    .split(|c: char| !(c.is_alphanumeric() || c == '_'))
                    .next()
                    .unwrap_or("")
            });
            out.push((name.to_string(), features.collect()));
        }
        out
    }

    fn rs_files(dir: &Path, out: &mut Vec<PathBuf>) {
        for e in std::fs::read_dir(dir).expect("the crate's sources") {
            let p = e.expect("a directory entry").path();
            if p.is_dir() {
                rs_files(&p, out);
            } else if p.extension().is_some_and(|x| x == "rs") {
                out.push(p);
            }
        }
    }

    /// Every feature a function of the crate enables is one its path checks before it runs: the
    /// AVX2 kernels and `with_avx2` [`AVX2_FEATURES`], the rest of the AVX-512 level
    /// [`AVX512_FEATURES`], the VBMI and VNNI kernels those and their own. A feature enabled
    /// anywhere else, or not in its list, fails with the function's name.
    #[test]
    fn every_enabled_feature_is_checked_before_its_path_runs() {
        let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
        let mut files = Vec::new();
        rs_files(&src, &mut files);
        let mut seen = 0;
        for f in files {
            let text = std::fs::read_to_string(&f).expect("a source file");
            let rel = f
                .strip_prefix(&src)
                .expect("under src")
                .to_string_lossy()
                .replace('\\', "/");
            for (func, features) in enabled(&text) {
                let allowed: Vec<&str> = match rel.as_str() {
                    "simd/mod.rs" if func == "with_avx2" => AVX2_FEATURES.to_vec(),
                    "simd/mod.rs" => AVX512_FEATURES.to_vec(),
                    "simd/avx2.rs" => AVX2_FEATURES.to_vec(),
                    r if r.starts_with("simd/avx512/") => AVX512_FEATURES.to_vec(),
                    r if r.starts_with("simd/vbmi/") => [AVX512_FEATURES, VBMI_FEATURES].concat(),
                    "simd/vnni.rs" => [AVX512_FEATURES, VNNI_FEATURES].concat(),
                    r => panic!(
                        "{r}: fn {func} enables {features:?}: target features belong in simd/, in the module of the path that checks them"
                    ),
                };
                for feature in &features {
                    assert!(
                        allowed.contains(&feature.as_str()),
                        "{rel}: fn {func} enables {feature}, which its path does not check (allowed: {allowed:?})"
                    );
                }
                seen += 1;
            }
        }
        assert!(seen >= 20, "only {seen} #[target_feature] attributes found");
        #[cfg(target_arch = "x86_64")]
        for f in [AVX512_FEATURES, VBMI_FEATURES, VNNI_FEATURES].concat() {
            assert!(
                cpu_has(f).is_some(),
                "{f}: a feature cpu_has does not check"
            );
        }
        assert_eq!(cpu_has("sse9"), None);
    }

    #[test]
    fn a_level_is_offered_only_with_all_its_features() {
        let offered = offered();
        assert_eq!(
            offered.contains(&"avx2"),
            has_all(AVX2_FEATURES) || has_all(AVX512_FEATURES)
        );
        assert_eq!(offered.contains(&"avx512"), has_all(AVX512_FEATURES));
        assert!(!offered.contains(&"vbmi") || has_all(VBMI_FEATURES));
        assert!(!offered.contains(&"vnni") || has_all(VNNI_FEATURES));
    }
}
