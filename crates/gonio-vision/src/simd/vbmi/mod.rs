//! The kernels written with AVX-512 VBMI/VBMI2 intrinsics (byte permutes `vpermb`/`vpermt2b`,
//! `vpcompressw`, the double shifts `vpshldq`/`vpshrdq`) besides AVX-512 F/BW, one file per
//! stage that calls them; used where the CPU has them
//! ([`crate::simd::vbmi`](mod@crate::simd::vbmi)).

pub(crate) mod fill;
pub(crate) mod morphology;
pub(crate) mod segment;
