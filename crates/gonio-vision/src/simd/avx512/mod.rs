//! The kernels written with AVX-512 F/BW/VL/DQ intrinsics (with AVX2, BMI1/2, LZCNT, POPCNT),
//! one file per stage that calls them.

pub(crate) mod blur_sobel;
pub(crate) mod label;
