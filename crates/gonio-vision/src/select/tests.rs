use super::line::*;
use super::pair::*;
use super::tracks::*;
use crate::label::{EdgePixel, component_of};

/// A small deterministic generator (xorshift) for the interval and search cases.
fn next(s: &mut u64) -> u64 {
    *s ^= *s << 13;
    *s ^= *s >> 7;
    *s ^= *s << 17;
    *s
}

/// Intervals in order of their first rows, as a track's fragments come (overlapping,
/// adjacent, nested, equal starts).
fn intervals(s: &mut u64) -> Vec<(u32, u32)> {
    let n = (next(s) % 8) as usize;
    let mut a = (next(s) % 20) as u32;
    let mut v = Vec::new();
    for _ in 0..n {
        a += (next(s) % 12) as u32;
        v.push((a, a + (next(s) % 15) as u32));
    }
    v
}

fn rows(iv: &[(u32, u32)]) -> std::collections::BTreeSet<u32> {
    iv.iter().flat_map(|&(a, b)| a..=b).collect()
}

#[test]
fn shared_rows_match_the_row_sets() {
    // Against the rows as sets: the union's size, and the intersection's size, first and
    // last row. A wrong merge of adjacent or nested intervals changes one of them.
    let mut s = 0x9e37_79b9_7f4a_7c15;
    for _ in 0..5000 {
        let (a, b) = (intervals(&mut s), intervals(&mut s));
        let (ra, rb) = (rows(&a), rows(&b));
        assert_eq!(union_len(&a) as usize, ra.len(), "{a:?}");
        let (ma, mb): (Vec<_>, Vec<_>) = (merged(&a).collect(), merged(&b).collect());
        assert!(ma.windows(2).all(|w| w[0].1 + 1 < w[1].0), "{ma:?}");
        let both: Vec<u32> = ra.intersection(&rb).copied().collect();
        let want = match (both.first(), both.last()) {
            (Some(&f), Some(&l)) => (both.len() as u32, f, l),
            _ => (0, 0, 0),
        };
        assert_eq!(shared(&ma, &mb), want, "{a:?} {b:?}");
    }
}

#[test]
fn sums_from_the_change_are_the_sums_of_the_new_set() {
    // Random pixel lists in raster order (strong and weak, filled ones without a position,
    // both polarities) and random subsets of them: the sums carried over from one subset to
    // another by what `diff` says went and came equal `component_of` of the new subset, in
    // every field (a sign slip or a forgotten field in `resum` fails this).
    use crate::segment::{FILLED, STRONG, WEAK};
    let mut s = 0x5851_f42d_4c95_7f2d;
    let w = 1440;
    for _ in 0..400 {
        let mut all = Vec::new();
        let (mut row, mut col) = (next(&mut s) % 500, 0u64);
        for _ in 0..(next(&mut s) % 120) {
            col += 1 + next(&mut s) % 40;
            if col >= w as u64 {
                row += 1 + next(&mut s) % 3;
                col %= 40;
            }
            let r = next(&mut s);
            all.push(EdgePixel {
                row: row as u16,
                col: col as u16,
                class: if r.is_multiple_of(3) { STRONG } else { WEAK },
                dir: (r >> 8) as u8,
                sub: if r.is_multiple_of(11) {
                    FILLED
                } else {
                    (r >> 16) as i8 % 16
                },
                mag: (r >> 24) as u16,
                comp: 0,
            });
        }
        // The old subset, then the new one with each pixel's membership flipped with a
        // probability of 1/2 to 1/64: changes small (summed from the change) and large
        // (summed afresh).
        let keep = 1 + next(&mut s) % 8;
        let was: Vec<bool> = all.iter().map(|_| next(&mut s) % 8 < keep).collect();
        let flip = 2 << (next(&mut s) % 6);
        let is: Vec<bool> = was
            .iter()
            .map(|&k| k ^ next(&mut s).is_multiple_of(flip))
            .collect();
        let pick = |m: &[bool]| -> Vec<EdgePixel> {
            all.iter().zip(m).filter(|x| *x.1).map(|x| *x.0).collect()
        };
        let (old, new) = (pick(&was), pick(&is));
        let (mut gone, mut came) = (Vec::new(), Vec::new());
        let same = diff(&old, &new, &mut gone, &mut came);
        assert_eq!(same, old == new);
        let want = component_of(&new, w);
        let got = resum(&component_of(&old, w), &gone, &came, &new, w);
        assert_eq!(got, want, "{} -> {} pixels", old.len(), new.len());
        // A pure removal, as the refit's row drops make.
        let kept: Vec<EdgePixel> = old.iter().filter(|e| e.row % 2 == 0).copied().collect();
        diff(&old, &kept, &mut gone, &mut came);
        assert!(came.is_empty());
        let got = resum(&component_of(&old, w), &gone, &[], &kept, w);
        assert_eq!(got, component_of(&kept, w));
        // The refit's one-pass filter and comparison: the same kept set, and the same pixels
        // gone and come in the same order, as filtering and then `diff`.
        let same = diff(&old, &new, &mut gone, &mut came);
        let (mut got_new, mut got_gone, mut got_came) = (Vec::new(), Vec::new(), Vec::new());
        let got_same = filter_diff(&all, &was, &is, &mut got_new, &mut got_gone, &mut got_came);
        assert_eq!(
            (got_same, &got_new, &got_gone, &got_came),
            (same, &new, &gone, &came)
        );
        // Both edges' row means and widths in one pass: the same bits as one edge at a time.
        let h = 900;
        let (mut ml, mut mr, mut nl, mut nr, mut widths) =
            (Vec::new(), Vec::new(), Vec::new(), Vec::new(), Vec::new());
        row_widths(
            &old,
            &new,
            h,
            (&mut ml, &mut mr),
            (&mut nl, &mut nr),
            &mut widths,
        );
        let (mut wl, mut wr, mut n) = (Vec::new(), Vec::new(), Vec::new());
        row_means(&old, h, &mut wl, &mut n);
        row_means(&new, h, &mut wr, &mut n);
        let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        assert_eq!((bits(&ml), bits(&mr)), (bits(&wl), bits(&wr)));
        let want: Vec<f64> = (0..h)
            .map(|y| wr[y] - wl[y])
            .filter(|w| w.is_finite())
            .collect();
        assert_eq!(bits(&widths), bits(&want));
    }
}

#[test]
fn skipped_ransac_tries_change_no_line() {
    // Every try counted in full (no early stop, no skipped try) against `best_line`, on
    // small sets (repeated pairs of pixels), collinear ones (every pixel an inlier) and
    // scattered ones: the same line, bit for bit.
    fn every_try(
        rows: &[f64],
        cols: &[f64],
        min_rows: f64,
        tan: f64,
        gate: f64,
    ) -> Option<(f64, f64, f64)> {
        let (n, half) = (rows.len(), rows.len() / 2);
        let mut best: Option<(usize, f64, f64, f64)> = None;
        for k in 0..48 {
            let ia = k * half / 48;
            let ib = half + ((k * 37) % 48) * (n - half) / 48;
            let dr = rows[ib] - rows[ia];
            if dr < min_rows {
                continue;
            }
            let slope = (cols[ib] - cols[ia]) / dr;
            if slope.abs() > tan {
                continue;
            }
            let (r0, c0) = (rows[ia], cols[ia]);
            let inl = rows
                .iter()
                .zip(cols)
                .filter(|&(&r, &c)| (c - c0 - slope * (r - r0)).abs() <= gate)
                .count();
            if best.is_none_or(|b| inl > b.0) {
                best = Some((inl, r0, c0, slope));
            }
        }
        best.map(|(_, r0, c0, slope)| (r0, c0, slope))
    }
    let mut s = 0x1405_7b7e_f767_814f;
    for case in 0..3000 {
        let n = 2 + (next(&mut s) % 200) as usize;
        let scatter = [0.0, 0.3, 3.0][case % 3];
        let mut rows: Vec<f64> = (0..n).map(|_| (next(&mut s) % 540) as f64).collect();
        rows.sort_by(f64::total_cmp);
        let cols: Vec<f64> = rows
            .iter()
            .map(|&r| 700.0 + 0.05 * r + scatter * ((next(&mut s) % 1000) as f64 / 500.0 - 1.0))
            .collect();
        let want = every_try(&rows, &cols, 20.0, 0.2, 1.5);
        assert_eq!(best_line(&rows, &cols, 20.0, 0.2, 1.5), want, "case {case}");
    }
}

#[test]
fn moments_in_i64_are_the_i128_ones() {
    // Wherever `fits_i64` lets the i64 path run, its integers equal the i128 expansion's:
    // random sums of either sign up to the bounds (each drawn near its top half the time,
    // with h up to 1023 and n up to 2¹⁹ − 1: the products the bounds were derived for; one
    // sum a case drawn up to four bits beyond its bound, for the guard to refuse), computed
    // with i64 overflow checks (a wrapped product panics). The bounds keep a bit or two of
    // slack; Σr, Σr³ or Σr⁴ loosened by four bits (e.g. Σr⁴ < 2⁵⁹) fails this.
    let mut s = 0x3c6e_f372_fe94_f82b;
    let mut draw = |bits: u32| -> i64 {
        let r = next(&mut s);
        let top = 1i64 << bits;
        let v = if r.is_multiple_of(2) {
            top - 1 - (r >> 40) as i64 % 1024
        } else {
            (r >> 1) as i64 % top
        };
        if r & 4 == 0 { v } else { -v }
    };
    let mut ran = 0;
    for case in 0..40_000u32 {
        let h = 1023 - draw(4).abs();
        let n = draw(19).abs();
        let loose = case % 16;
        let mut wide = |k: u32, bits: u32| draw(bits + u32::from(k == loose) * (1 + case / 16 % 4));
        let sums = [n, wide(1, 26), wide(2, 34), wide(3, 44), wide(4, 55)];
        let cs = [wide(5, 36), wide(6, 46), wide(7, 56)];
        if !fits_i64(h, &sums, &cs) {
            continue;
        }
        ran += 1;
        let want = expand(h as i128, sums.map(i128::from), cs.map(i128::from));
        let got = expand(Checked(h), sums.map(Checked), cs.map(Checked));
        assert_eq!(got.map(|v| v.0 as i128), want, "h {h} {sums:?} {cs:?}");
    }
    assert!(ran > 20_000, "{ran}");
    // And `moments` of a real component against the i128 expansion.
    let c = component_of(
        &[(3, 100, 5), (200, 101, -7), (539, 99, 0)].map(|(row, col, sub)| EdgePixel {
            row,
            col,
            class: crate::segment::STRONG,
            dir: 0,
            sub,
            mag: 9,
            comp: 0,
        }),
        1440,
    );
    let (u, v, _) = moments(&c, 540);
    let h = 539i128;
    let (s1, n) = (c.sum_row as i128, c.pos_n as i128);
    assert_eq!(u[1], (2 * s1 - h * n) as f64);
    let u4 = 16 * c.sum_row4 as i128 - 32 * h * c.sum_row3 as i128
        + 24 * h * h * c.sum_row2 as i128
        - 8 * h * h * h * s1
        + h * h * h * h * n;
    assert_eq!(u[4], u4 as f64);
    let v2 = 4 * c.sum_row2_col32 as i128 - 4 * h * c.sum_row_col32 as i128
        + h * h * c.sum_col32 as i128;
    assert_eq!(v[2], v2 as f64 / 32.0);
}

/// An i64 whose arithmetic panics on overflow (in every build profile).
#[derive(Debug, Clone, Copy)]
struct Checked(i64);

impl From<i8> for Checked {
    fn from(v: i8) -> Self {
        Checked(v.into())
    }
}
impl std::ops::Add for Checked {
    type Output = Checked;
    fn add(self, o: Checked) -> Checked {
        Checked(self.0.checked_add(o.0).expect("i64 overflow"))
    }
}
impl std::ops::Sub for Checked {
    type Output = Checked;
    fn sub(self, o: Checked) -> Checked {
        Checked(self.0.checked_sub(o.0).expect("i64 overflow"))
    }
}
impl std::ops::Mul for Checked {
    type Output = Checked;
    fn mul(self, o: Checked) -> Checked {
        Checked(self.0.checked_mul(o.0).expect("i64 overflow"))
    }
}

#[test]
fn partition_near_is_partition_point_for_every_hint() {
    let mut s = 0x2545_f491_4f6c_dd1d;
    for len in [0usize, 1, 2, 5, 31, 32, 33, 70, 200] {
        let mut v: Vec<u32> = (0..len).map(|_| (next(&mut s) % 300) as u32).collect();
        v.sort_unstable();
        for t in [0u32, 1, 17, 150, 299, 300, 400] {
            let pred = |x: &u32| *x < t;
            let want = v.partition_point(pred);
            for hint in 0..=len + 2 {
                assert_eq!(
                    partition_near(&v, hint, pred),
                    want,
                    "len {len} t {t} hint {hint}"
                );
            }
        }
    }
}
