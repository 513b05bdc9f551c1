//! The segmentation's constants and per-row state that its scalar path ([`crate::segment`]) and
//! its AVX-512 kernel (`simd::vbmi::segment`) share: the arctangent table, tan 22.5°, the
//! thresholds as the row pass uses them ([`ClassConsts`]) and the kernel's scratch rows
//! ([`KeptScratch`]).

use crate::buffer::Aligned;
use crate::segment::SegmentParams;

/// atan(i/64) in binary-angle units (256 per turn), rounded, i = 0 … 64.
pub(crate) const ATAN64: [u8; 65] = [
    0, 1, 1, 2, 3, 3, 4, 4, 5, 6, 6, 7, 8, 8, 9, 9, 10, 11, 11, 12, 12, 13, 13, 14, 15, 15, 16, 16,
    17, 17, 18, 18, 19, 19, 20, 20, 21, 21, 22, 22, 23, 23, 24, 24, 25, 25, 25, 26, 26, 27, 27, 27,
    28, 28, 29, 29, 29, 30, 30, 30, 31, 31, 31, 32, 32,
];

/// tan(22.5°) in Q8, for the four-way quantisation.
pub(crate) const TAN22_Q8: u32 = 106;

/// tan(22.5°) as a 16-bit multiplier: ay·256 ≤ 106·ax ⇔ ay ≤ ⌊ax·106·256 / 2¹⁶⌋ (ay an integer).
pub(crate) const TAN22_MUL: u16 = (TAN22_Q8 * 256) as u16;

/// The segmentation's thresholds as the row pass uses them.
#[derive(Debug, Clone, Copy)]
pub(crate) struct ClassConsts {
    pub(crate) low: u16,
    pub(crate) high: u16,
    /// (tan_q10 mod 1024)·64: ⌊tan_q10·ax / 1024⌋ = mulhi(ax, this) + (ax if tan_q10 ≥ 1024).
    pub(crate) tan_mul: u16,
    /// All ones when tan_q10 ≥ 1024.
    pub(crate) tan_all: u16,
    /// tan_q10 ≤ 424: every candidate lies in the 0° sector.
    pub(crate) horizontal: bool,
}

impl ClassConsts {
    pub(crate) fn new(p: SegmentParams) -> Self {
        assert!(p.tan_q10 < 2048, "direction tolerance of 63° or more");
        ClassConsts {
            low: p.low,
            high: p.high,
            tan_mul: ((p.tan_q10 % 1024) * 64) as u16,
            tan_all: if p.tan_q10 >= 1024 { u16::MAX } else { 0 },
            horizontal: p.tan_q10 * 256 <= TAN22_Q8 * 1024,
        }
    }
}

/// Scratch rows of the AVX-512 path: the neighbours across the edge per column, and the kept
/// pixels of one row, compact (each with 16 elements of slack for the last vector).
#[derive(Debug, Clone)]
pub(crate) struct KeptScratch {
    /// The neighbour before (a) and after (b) the centre across the edge, per column.
    pub(crate) a: Aligned<u16>,
    pub(crate) b: Aligned<u16>,
    /// The kept columns, in order.
    pub(crate) cols: Vec<u16>,
    pub(crate) gx: Vec<i16>,
    pub(crate) gy: Vec<i16>,
    pub(crate) c: Vec<u16>,
    pub(crate) ka: Vec<u16>,
    pub(crate) kb: Vec<u16>,
    pub(crate) dir: Vec<u8>,
    pub(crate) sub: Vec<i8>,
}

impl KeptScratch {
    pub(crate) fn new(width: usize) -> Self {
        let row = width.div_ceil(32) * 32;
        let n = width + 32;
        KeptScratch {
            a: Aligned::new(row, 0),
            b: Aligned::new(row, 0),
            cols: vec![0; n],
            gx: vec![0; n],
            gy: vec![0; n],
            c: vec![0; n],
            ka: vec![0; n],
            kb: vec![0; n],
            dir: vec![0; n],
            sub: vec![0; n],
        }
    }
}
