//! The register chain kernel of [`crate::morphology`]'s closing and opening, written with AVX-512 VBMI
//! intrinsics (used only where the CPU has them, see [`crate::simd::vbmi`](mod@crate::simd::vbmi)).
//!
//! Per 64-column vector, an input row's chord classes are made in registers: the row's 128
//! columns x − 32 … x + 95 (two loads of a padded row), a doubling pyramid over them
//! with `vpermt2b` byte shifts across the two vectors, each class as the max of two shifted
//! pyramid vectors. The vertical union is the chain of the module doc: with G_j the class of
//! |dy| = j, T_j(m) = G_j(m) ∨ T_{j+1}(m − 1) (T_r = G_r) and R_j(m) = G_j(m) ∨ R_{j−1}(m − 1)
//! (R_0 = T_0) give the operation's row m − r as R_r(m): 2r max operations per vector and row,
//! and 2r vectors of state, which stay in registers while a batch of rows streams through one
//! column vector. Nothing but the input, the output and the state touches memory. In the
//! class loop ([`run`]) the shifts by a multiple of 4 bytes are `valignd` with an immediate
//! instead of `vpermt2b` (same bits, ≈ 2 % faster on the top-hat); [`run_direct`] keeps the
//! permutes (there the helper's `match` cost the inlining of the chain step).
//!
//! For r = 11 the seven classes have half widths 3, 5, 7, 8, 9, 10, 11. [`run`] makes only
//! 3, 5 and 7 from the pyramid (levels 1 … 3; level 1, the pairs, as the max of the row and
//! the row loaded one column further, no permute); 8 … 11 are each the next narrower one ∨
//! the row's columns x ± h (two loads, two max operations) ([`ChordClasses::BASE`]). Per 64-column
//! vector and row that is 10 shuffles + 17 max operations for the classes instead of 22 + 15
//! (the chain's 22 max operations are unchanged), all made in the loop that combines them:
//! no class goes through memory (a scratch of 16 rows' classes, one store and one reload per
//! class, measured ≈ 8 % slower on the top-hat once the classes needed this few registers).
//! [`run`]'s chain updates every state vector in place (R_d for descending d, then T_d for
//! ascending d, the row's classes held in registers), which spares the 11 register copies per row that the shared
//! `chain_step!` (still used by [`run_direct`], whose state is small) made the compiler emit.

use std::arch::x86_64::*;

use crate::buffer::PAD;

/// Columns of the 128 a class is made from (two vectors `la`, `lb`) before the vector's
/// first column: the pyramid's windows reach 32 columns either side.
const LEAD: usize = 32;
/// Largest radius of the kernel (2r state vectors; the pyramid window reaches 32 columns).
pub(crate) const MAX_RADIUS: usize = 12;

/// `vpermt2b` index vectors: row s selects bytes s … s + 63 of two concatenated vectors.
#[repr(C, align(64))]
struct Shifts([[u8; 64]; 33]);

const fn shifts() -> Shifts {
    let mut t = [[0u8; 64]; 33];
    let mut s = 0;
    while s < 33 {
        let mut i = 0;
        while i < 64 {
            t[s][i] = (i + s) as u8;
            i += 1;
        }
        s += 1;
    }
    Shifts(t)
}

static SHIFTS: Shifts = shifts();

/// The disk's half chord widths, as constants per radius.
struct ChordClasses<const R: usize>;

impl<const R: usize> ChordClasses<R> {
    const HW: [usize; MAX_RADIUS + 2] = {
        let mut hw = [0; MAX_RADIUS + 2];
        let lim = R * R + R;
        let mut dy = 0;
        while dy <= R {
            let mut w = R;
            while w * w + dy * dy > lim {
                w -= 1;
            }
            hw[dy] = w;
            dy += 1;
        }
        hw
    };
    /// The first class position (|dy|, from the widest class up) whose class is not one
    /// pixel wider than the next narrower one: the classes at |dy| < BASE are each made
    /// from the next narrower by two loads of the row (r = 11: half widths 3, 5, 7 from
    /// the pyramid, 8 … 11 by loads).
    const BASE: usize = {
        let hw = Self::HW;
        let mut d = 0;
        while d < R && hw[d] == hw[d + 1] {
            d += 1;
        }
        while d < R {
            let mut e = d + 1;
            while e < R && hw[e] == hw[e + 1] {
                e += 1;
            }
            if hw[d] != hw[e] + 1 {
                break;
            }
            d = e;
        }
        d
    };
}

/// Pyramid level (windows of 2^k) whose two windows cover a chord of half width h.
const fn level(h: usize) -> usize {
    let span = 2 * h + 1;
    (usize::BITS - 1 - span.leading_zeros()) as usize
}

#[inline]
#[target_feature(enable = "avx512f,avx512bw,avx512vbmi")]
fn idx(s: usize) -> __m512i {
    // SAFETY: an aligned 64-byte row of a static table.
    unsafe { _mm512_load_si512(SHIFTS.0[s].as_ptr().cast()) }
}

/// Bytes s … s + 63 of the 128 bytes `a` (low) `b` (high): one `valignd` with an immediate
/// where s is a multiple of 4 (no index vector), `vpermt2b` otherwise. The same bits.
#[inline]
#[target_feature(enable = "avx512f,avx512bw,avx512vbmi")]
fn shift2(a: __m512i, b: __m512i, s: usize) -> __m512i {
    macro_rules! al {
        ($($q:literal)*) => {
            match s / 4 {
                0 => a,
                $($q => _mm512_alignr_epi32::<$q>(b, a),)*
                _ => b,
            }
        };
    }
    if s.is_multiple_of(4) {
        al!(1 2 3 4 5 6 7 8 9 10 11 12 13 14 15)
    } else {
        _mm512_permutex2var_epi8(a, idx(s), b)
    }
}

/// `b` rotated down by s bytes (byte i = b[(i + s) mod 64]), as `vpermb` with index row s.
#[inline]
#[target_feature(enable = "avx512f,avx512bw,avx512vbmi")]
fn rot(b: __m512i, s: usize) -> __m512i {
    if s.is_multiple_of(4) {
        shift2(b, b, s)
    } else {
        _mm512_permutexvar_epi8(idx(s), b)
    }
}

#[inline]
#[target_feature(enable = "avx512f,avx512bw,avx512vbmi")]
fn load(s: &[u8], o: usize) -> __m512i {
    let s = &s[o..o + 64];
    // SAFETY: 64 bytes in bounds (checked by the slice).
    unsafe { _mm512_loadu_si512(s.as_ptr().cast()) }
}

#[inline]
#[target_feature(enable = "avx512f,avx512bw,avx512vbmi")]
fn store(s: &mut [u8], o: usize, v: __m512i, mask: u64) {
    let s = &mut s[o..o + 64];
    // SAFETY: 64 bytes in bounds (checked by the slice); only the masked bytes are written.
    unsafe {
        if mask == !0 {
            _mm512_storeu_si512(s.as_mut_ptr().cast(), v)
        } else {
            _mm512_mask_storeu_epi8(s.as_mut_ptr().cast(), mask, v)
        }
    }
}

#[inline]
#[target_feature(enable = "avx512f,avx512bw,avx512vbmi")]
fn ext<const MAX: bool>(a: __m512i, b: __m512i) -> __m512i {
    if MAX {
        _mm512_max_epu8(a, b)
    } else {
        _mm512_min_epu8(a, b)
    }
}

/// Calls `f(d)` for d = 12, 11, … 0 (constants after inlining).
macro_rules! down {
    ($f:ident) => {
        $f(12);
        $f(11);
        $f(10);
        $f(9);
        $f(8);
        $f(7);
        $f(6);
        $f(5);
        $f(4);
        $f(3);
        $f(2);
        $f(1);
        $f(0);
    };
}

/// Calls `f(d)` for d = 12, 11, … 0, the closure inlined (an `#[inline(always)]` closure
/// argument: in [`run`] the class and chain closures grew past the inliner's limit).
#[inline(always)]
fn down_each(mut f: impl FnMut(usize)) {
    down!(f);
}

/// Calls `f(d)` for d = 0, 1, … 12, the closure inlined.
#[inline(always)]
fn up_each(mut f: impl FnMut(usize)) {
    f(0);
    f(1);
    f(2);
    f(3);
    f(4);
    f(5);
    f(6);
    f(7);
    f(8);
    f(9);
    f(10);
    f(11);
    f(12);
}

/// Loads a column vector's chain state (2r vectors from `$sb`) into new arrays `$t`
/// (T_1 … T_r) and `$q` (R_0 … R_{r−1}); [`run`] and [`run_direct`] share it (a macro,
/// so the kernels' code stays exactly as written out).
macro_rules! load_state {
    ($r:ident, $state:ident, $sb:ident, $t:ident, $q:ident) => {
        let zero = _mm512_setzero_si512();
        let mut $t = [zero; $r];
        let mut $q = [zero; $r];
        let mut ld = |d: usize| {
            if d < $r {
                $t[d] = load($state, $sb + d * 64);
                $q[d] = load($state, $sb + ($r + d) * 64);
            }
        };
        down!(ld);
    };
}

/// Stores the chain state `$t`, `$q` back where [`load_state`] read it.
macro_rules! store_state {
    ($r:ident, $state:ident, $sb:ident, $t:ident, $q:ident) => {
        let mut st = |d: usize| {
            if d < $r {
                store($state, $sb + d * 64, $t[d], !0);
                store($state, $sb + ($r + d) * 64, $q[d], !0);
            }
        };
        down!(st);
    };
}

/// The chain's step at |dy| = `$d` with that row's class `$g` (the module doc's
/// T_j(m) = G_j(m) ∨ T_{j+1}(m − 1), R_j(m) = G_j(m) ∨ R_{j−1}(m − 1)): called for
/// d = r … 0, `$tprev` bringing T_{d+1}(m − 1) into step d, the row's output left in `$o`
/// at d = r.
/// A macro, not a function: the helper form measured ≈ 40 % slower (see [`run_direct`]).
macro_rules! chain_step {
    ($r:ident, $max:ident, $d:ident, $g:ident, $t:ident, $q:ident, $tprev:ident, $o:ident) => {
        if $d == $r {
            $o = ext::<$max>($g, $q[$r - 1]);
            $tprev = $t[$r - 1];
            $t[$r - 1] = $g;
        } else if $d > 0 {
            let nt = ext::<$max>($g, $tprev);
            $tprev = $t[$d - 1];
            $t[$d - 1] = nt;
            $q[$d] = ext::<$max>($g, $q[$d - 1]);
        } else {
            $q[0] = ext::<$max>($g, $tprev);
        }
    };
}

/// The byte mask that stores column vector `v` of `nvec`: all 64 but in the last one,
/// whose `width − 64·(nvec − 1)` columns are the frame's.
#[inline(always)]
fn store_mask(v: usize, nvec: usize, width: usize) -> u64 {
    if v + 1 < nvec {
        !0
    } else {
        crate::simd::first_lanes(width - (nvec - 1) * 64)
    }
}

/// Where the output rows of [`run`] go: row k (the output of input row `skip` + k) at
/// `buf[first + k·stride ..][.. width]`; with `SUB`, minus (saturating) `minus`'s row at
/// `mfirst + k·mstride` (the top-hat's input rows).
pub(crate) struct Out<'a> {
    pub(crate) buf: &'a mut [u8],
    pub(crate) first: usize,
    pub(crate) stride: usize,
    pub(crate) minus: &'a [u8],
    pub(crate) mfirst: usize,
    pub(crate) mstride: usize,
}

/// Stores column vector `v` of output row `k` (see [`Out`]), `mask` its frame columns.
#[inline]
#[target_feature(enable = "avx512f,avx512bw,avx512vbmi")]
fn put<const SUB: bool>(out: &mut Out<'_>, k: usize, v: usize, o: __m512i, mask: u64) {
    let o = if SUB {
        _mm512_subs_epu8(o, load(out.minus, out.mfirst + k * out.mstride + v * 64))
    } else {
        o
    };
    store(out.buf, out.first + k * out.stride + v * 64, o, mask);
}

/// Largest radius [`run_direct`] handles.
const DIRECT_MAX: usize = 4;

/// Disks whose widest chord has at most this half width make their chords in
/// [`run_direct`] from two unaligned loads of the row 16 bytes apart and one in-lane
/// `vpalignr` per column shift (no cross-lane permutes; five loads, all crossing a cache
/// line, measured slower).
const LOADED_MAX: usize = 2;

/// Feeds the rows `ins` (padded rows: column c at `PAD + c`, the operation's neutral value
/// around) through the chain `state` of every column vector; the output of input row i ≥
/// `skip` goes to row i − `skip` of `out` (see [`Out`]; with `SUB`, minus its input row).
///
/// Each row's chord classes are made in the loop that combines them: the classes at
/// |dy| ≥ [`ChordClasses::BASE`] from the pyramid, the wider ones, each one pixel wider than the
/// next narrower, from that one and the row's two new columns. (Until the classes needed
/// fewer vector registers they went through an L1 scratch, one store and one reload each:
/// with the 22 state vectors in registers the compiler now still finds room for them.)
#[target_feature(enable = "avx512f,avx512bw,avx512vbmi")]
fn run<const MAX: bool, const R: usize, const SUB: bool>(
    state: &mut [u8],
    ins: &[&[u8]],
    mut out: Out<'_>,
    skip: usize,
    width: usize,
) {
    if R <= DIRECT_MAX {
        return run_direct::<MAX, R, SUB>(state, ins, out, skip, width);
    }
    let hw = ChordClasses::<R>::HW;
    let base = ChordClasses::<R>::BASE;
    let nvec = width.div_ceil(64);
    let zero = _mm512_setzero_si512();
    for v in 0..nvec {
        let mask = store_mask(v, nvec, width);
        let sb = v * 2 * R * 64;
        // The chain: T_1 … T_r at t[0 .. r], R_0 … R_{r−1} at q[0 .. r].
        load_state!(R, state, sb, t, q);
        for (i, row) in ins.iter().enumerate() {
            let x0 = v * 64 + PAD;
            let (mut la, mut lb) = (load(row, x0 - LEAD), load(row, x0 - LEAD + 64));
            let mut lk = 0;
            // The classes of |dy| = 0 … r, narrowest first.
            let mut gs = [zero; MAX_RADIUS + 1];
            let mut g = zero;
            down_each(
                #[inline(always)]
                |d: usize| {
                    if d > R {
                        return;
                    }
                    if d == R || hw[d] != hw[d + 1] {
                        let h = hw[d];
                        g = if d >= base {
                            let k = level(h);
                            while lk < k {
                                if lk == 0 {
                                    // Pairs from the row shifted by one column: loads, no
                                    // permutes.
                                    la = ext::<MAX>(la, load(row, x0 - LEAD + 1));
                                    lb = ext::<MAX>(lb, load(row, x0 - LEAD + 65));
                                } else {
                                    let a = ext::<MAX>(la, shift2(la, lb, 1 << lk));
                                    let b = ext::<MAX>(lb, rot(lb, 1 << lk));
                                    (la, lb) = (a, b);
                                }
                                lk += 1;
                            }
                            let x = shift2(la, lb, LEAD - h);
                            let y = shift2(la, lb, LEAD + h + 1 - (1 << k));
                            ext::<MAX>(x, y)
                        } else {
                            // One wider than `g`: its two new columns from the row.
                            ext::<MAX>(g, ext::<MAX>(load(row, x0 - h), load(row, x0 + h)))
                        };
                    }
                    gs[d] = g;
                },
            );
            // The chain, each state vector updated in place: R_d descending, then
            // T_d ascending (no register copies for the shift by one row).
            let o = ext::<MAX>(gs[R], q[R - 1]);
            down_each(
                #[inline(always)]
                |d: usize| {
                    if d >= 1 && d < R {
                        q[d] = ext::<MAX>(gs[d], q[d - 1]);
                    }
                },
            );
            q[0] = ext::<MAX>(gs[0], t[0]);
            up_each(
                #[inline(always)]
                |d: usize| {
                    if d >= 1 && d < R {
                        t[d - 1] = ext::<MAX>(gs[d], t[d]);
                    }
                },
            );
            t[R - 1] = gs[R];
            if i >= skip {
                put::<SUB>(&mut out, i - skip, v, o, mask);
            }
        }
        store_state!(R, state, sb, t, q);
    }
}

/// [`run`] for small radii: the classes are made and combined row by row, all in
/// registers (the state and the index vectors fit; a scratch would cost a store and a
/// reload per class, and a 64-byte reload right after its store is not forwarded on Zen 4).
/// Written out beside [`run`] rather than sharing helpers with it: the helper form (the
/// chain step taking a closure for the classes) measured ≈ 40 % slower.
#[target_feature(enable = "avx512f,avx512bw,avx512vbmi")]
fn run_direct<const MAX: bool, const R: usize, const SUB: bool>(
    state: &mut [u8],
    ins: &[&[u8]],
    mut out: Out<'_>,
    skip: usize,
    width: usize,
) {
    let hw = ChordClasses::<R>::HW;
    let nvec = width.div_ceil(64);
    for v in 0..nvec {
        let mask = store_mask(v, nvec, width);
        let sb = v * 2 * R * 64;
        let zero = _mm512_setzero_si512();
        // T_1 … T_r at t[0 .. r], R_0 … R_{r−1} at q[0 .. r].
        load_state!(R, state, sb, t, q);
        for (i, row) in ins.iter().enumerate() {
            let x0 = v * 64 + PAD;
            let (mut la, mut lb) = (load(row, x0 - LEAD), load(row, x0 - LEAD + 64));
            let mut lk = 0;
            // Chords of half width ≤ LOADED_MAX: columns x − 2 … x + 2 from two loads
            // 16 bytes apart (`lo` from x − LOADED_MAX) and one in-lane `vpalignr` each:
            // lane i of `hi` is lane i + 1 of `lo`, so the per-lane byte shift by s is the
            // whole vector's shift by s (five line-crossing loads become two).
            let (lo, hi) = if hw[0] <= LOADED_MAX {
                (load(row, x0 - LOADED_MAX), load(row, x0 - LOADED_MAX + 16))
            } else {
                (zero, zero)
            };
            let col = |dx: isize| -> __m512i {
                match dx {
                    -2 => lo,
                    -1 => _mm512_alignr_epi8::<1>(hi, lo),
                    0 => _mm512_alignr_epi8::<2>(hi, lo),
                    1 => _mm512_alignr_epi8::<3>(hi, lo),
                    2 => _mm512_alignr_epi8::<4>(hi, lo),
                    _ => unreachable!("column shift beyond LOADED_MAX"),
                }
            };
            let (mut acc, mut acc_h) = (zero, usize::MAX);
            let mut g = zero;
            let mut tprev = zero;
            let mut o = zero;
            let mut step = |d: usize| {
                if d > R {
                    return;
                }
                let h = hw[d];
                if (d == R || h != hw[d + 1]) && hw[0] <= LOADED_MAX {
                    if acc_h == usize::MAX {
                        (acc, acc_h) = (col(0), 0);
                    }
                    while acc_h < h {
                        acc_h += 1;
                        let a = ext::<MAX>(col(-(acc_h as isize)), col(acc_h as isize));
                        acc = ext::<MAX>(acc, a);
                    }
                    g = acc;
                } else if d == R || h != hw[d + 1] {
                    let k = level(h);
                    while lk < k {
                        let s = idx(1 << lk);
                        let a = ext::<MAX>(la, _mm512_permutex2var_epi8(la, s, lb));
                        let b = ext::<MAX>(lb, _mm512_permutexvar_epi8(s, lb));
                        (la, lb) = (a, b);
                        lk += 1;
                    }
                    let x = _mm512_permutex2var_epi8(la, idx(LEAD - h), lb);
                    let y = _mm512_permutex2var_epi8(la, idx(LEAD + h + 1 - (1 << k)), lb);
                    g = ext::<MAX>(x, y);
                }
                chain_step!(R, MAX, d, g, t, q, tprev, o);
            };
            down!(step);
            if i >= skip {
                put::<SUB>(&mut out, i - skip, v, o, mask);
            }
        }
        store_state!(R, state, sb, t, q);
    }
}

/// True when [`feed`] runs for radius `r` on this CPU.
pub(crate) fn usable(r: usize) -> bool {
    (1..=MAX_RADIUS).contains(&r) && crate::simd::vbmi()
}

/// [`run`] for radius `r` (1 … [`MAX_RADIUS`]); `state` holds 2r vectors per column vector.
pub(crate) fn feed<const MAX: bool, const SUB: bool>(
    r: usize,
    state: &mut [u8],
    ins: &[&[u8]],
    out: Out<'_>,
    skip: usize,
    width: usize,
) {
    assert!(
        crate::simd::vbmi_detected(),
        "VBMI kernel on a CPU without VBMI"
    );
    macro_rules! go {
        ($($r:literal)*) => {
            match r {
                // SAFETY: the CPU has AVX-512 F/BW and VBMI (asserted above).
                $($r => unsafe { run::<MAX, $r, SUB>(state, ins, out, skip, width) },)*
                _ => unreachable!("radius {r} outside the VBMI kernel"),
            }
        };
    }
    go!(1 2 3 4 5 6 7 8 9 10 11 12)
}
