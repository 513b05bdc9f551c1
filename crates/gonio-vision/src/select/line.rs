//! The line fit: a component's centred moments from its exact integer sums, the small dense
//! solvers, the least-squares curve of a component (a line or a parabola of the row), the
//! deterministic RANSAC line through a set of pixels, and the median.

use crate::label::{Component, EdgePixel};
use crate::optics::Params;

/// A least-squares curve of a component's pixels: column = a + b·u + q·u² with
/// u = 2·row − (H − 1) (q = 0 for a short component), and the scatter about it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Curve {
    /// Column at u = 0 (the window's middle row), px.
    pub a: f64,
    /// Linear coefficient, px per u.
    pub b: f64,
    /// Quadratic coefficient, px per u².
    pub q: f64,
    /// RMS distance of the positioned pixels from the curve, px.
    pub rms_px: f64,
    /// Positioned pixels.
    pub n: f64,
}

impl Curve {
    /// Column at `row`, px.
    pub fn at(&self, row: f64, height: usize) -> f64 {
        let u = 2.0 * row - (height as f64 - 1.0);
        self.a + self.b * u + self.q * u * u
    }
}

/// Centred moments of a component: Σuᵏ (k = 0…4), Σuᵏ·c (k = 0…2, px), Σc² (px²).
pub(crate) fn moments(c: &Component, height: usize) -> ([f64; 5], [f64; 3], f64) {
    // u = 2·row − (H − 1): centred, integer. Exact expansion: in i64 when every product and
    // partial sum provably fits ([`fits_i64`]: the usual case; the same integers), else in
    // i128.
    let h = height as i64 - 1;
    let s = [
        c.pos_n as i64,
        c.sum_row,
        c.sum_row2,
        c.sum_row3,
        c.sum_row4,
    ];
    let cs = [c.sum_col32, c.sum_row_col32, c.sum_row2_col32];
    let e: [i128; 8] = if fits_i64(h, &s, &cs) {
        expand(h, s, cs).map(i128::from)
    } else {
        expand(h as i128, s.map(i128::from), cs.map(i128::from))
    };
    let f = to_f64;
    (
        [f(e[0]), f(e[1]), f(e[2]), f(e[3]), f(e[4])],
        [f(e[5]) / 32.0, f(e[6]) / 32.0, f(e[7]) / 32.0],
        f(c.sum_col32_sq) / 1024.0,
    )
}

/// The centred sums of [`moments`] from the raw ones (`s` = n, Σr, Σr², Σr³, Σr⁴; `c` = Σc,
/// Σr·c, Σr²·c; `h` = H − 1): n, Σu…Σu⁴, Σc, Σu·c, Σu²·c, exact in `T` when nothing overflows.
pub(super) fn expand<T>(h: T, s: [T; 5], c: [T; 3]) -> [T; 8]
where
    T: Copy + From<i8> + std::ops::Add<Output = T> + std::ops::Sub<Output = T>,
    T: std::ops::Mul<Output = T>,
{
    let k = |v: i8| T::from(v);
    let [n, s1, s2, s3, s4] = s;
    let u1 = k(2) * s1 - h * n;
    let u2 = k(4) * s2 - k(4) * h * s1 + h * h * n;
    let u3 = k(8) * s3 - k(12) * h * s2 + k(6) * h * h * s1 - h * h * h * n;
    let u4 = k(16) * s4 - k(32) * h * s3 + k(24) * h * h * s2 - k(8) * h * h * h * s1
        + h * h * h * h * n;
    let [c0, c1, c2] = c;
    let v1 = k(2) * c1 - h * c0;
    let v2 = k(4) * c2 - k(4) * h * c1 + h * h * c0;
    [n, u1, u2, u3, u4, c0, v1, v2]
}

/// True when [`expand`] cannot overflow an i64: 0 ≤ n < 2¹⁹, 0 ≤ h < 2¹⁰ and each raw sum
/// within a bound that keeps every product below 2⁵⁹ (e.g. 32·h·Σr³ < 2⁵·2¹⁰·2⁴⁴), so each
/// sum of at most five of them below 2⁶². A 540-row window with a few thousand pixels is far
/// inside.
pub(super) fn fits_i64(h: i64, s: &[i64; 5], c: &[i64; 3]) -> bool {
    let below = |v: i64, bits: u32| v.unsigned_abs() < 1 << bits;
    (0..1 << 10).contains(&h)
        && (0..1 << 19).contains(&s[0])
        && below(s[1], 26)
        && below(s[2], 34)
        && below(s[3], 44)
        && below(s[4], 55)
        && below(c[0], 36)
        && below(c[1], 46)
        && below(c[2], 56)
}

/// `x as f64`, through the hardware's i64 conversion when x fits in an i64 (the usual case;
/// the i128 conversion is a library call). Both round to nearest: the same value.
/// The i128 path is a separate cold function: inlined, LLVM computed both conversions and
/// selected one, so the library call ran every time.
#[inline]
pub(super) fn to_f64(x: i128) -> f64 {
    #[cold]
    #[inline(never)]
    fn wide(x: i128) -> f64 {
        x as f64
    }
    match i64::try_from(x) {
        Ok(v) => v as f64,
        Err(_) => wide(x),
    }
}

pub(super) fn det3(m: [[f64; 3]; 3]) -> f64 {
    m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
        - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
        + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0])
}

/// Solves a 3×3 system by Cramer's rule; `None` when (nearly) singular.
fn solve3(a: [[f64; 3]; 3], b: [f64; 3]) -> Option<[f64; 3]> {
    let d = det3(a);
    let scale = a[0][0] * a[1][1] * a[2][2];
    if d.is_nan() || d.abs() <= 1e-9 * scale.abs() {
        return None;
    }
    let mut x = [0.0; 3];
    for (i, xi) in x.iter_mut().enumerate() {
        let mut m = a;
        for r in 0..3 {
            m[r][i] = b[r];
        }
        *xi = det3(m) / d;
    }
    Some(x)
}

/// The component's curve: a parabola when it spans at least half the window's rows, a line
/// otherwise (a shorter piece cannot pin the curvature, and a line extrapolates better);
/// `None` without two positioned pixels on different rows.
pub fn curve(c: &Component, height: usize) -> Option<Curve> {
    curve_with(c, height, None)
}

/// As [`curve`], but a piece spanning less than half the window's rows bends with the given
/// curvature `q_prior` (px per u², e.g. the frame's: every edge in the window is a circle
/// concentric with the ring) instead of being straight.
pub fn curve_with(c: &Component, height: usize, q_prior: Option<f64>) -> Option<Curve> {
    if c.pos_n < 2 {
        return None;
    }
    let (u, v, cc) = moments(c, height);
    let n = u[0];
    // A line through the columns less q·u²: Σ(c − q u²) = v0 − q·u2, Σu(c − q u²) = v1 − q·u3,
    // Σ(c − q u²)² = cc − 2q·v2 + q²·u4.
    let line = |q: f64| {
        let (w0, w1) = (v[0] - q * u[2], v[1] - q * u[3]);
        let ww = cc - 2.0 * q * v[2] + q * q * u[4];
        let suu = u[2] - u[1] * u[1] / n;
        if suu <= 0.0 {
            return None;
        }
        let b = (w1 - u[1] * w0 / n) / suu;
        let a = (w0 - b * u[1]) / n;
        Some((a, b, q, ww, a * w0 + b * w1, 2.0))
    };
    let fit = if parabola(c, height) {
        match solve3(
            [[u[0], u[1], u[2]], [u[1], u[2], u[3]], [u[2], u[3], u[4]]],
            [v[0], v[1], v[2]],
        ) {
            Some([a, b, q]) => Some((a, b, q, cc, a * v[0] + b * v[1] + q * v[2], 3.0)),
            None => line(0.0),
        }
    } else {
        line(q_prior.unwrap_or(0.0))
    };
    let (a, b, q, total, explained, k) = fit?;
    let ssr = (total - explained).max(0.0);
    let dof = (n - k).max(1.0);
    Some(Curve {
        a,
        b,
        q,
        rms_px: (ssr / dof).sqrt(),
        n,
    })
}

/// True when [`curve_with`] fits `c` with a parabola (it spans at least half the window's rows,
/// with four positioned pixels or more): its curvature prior is then not used.
pub(super) fn parabola(c: &Component, height: usize) -> bool {
    (c.max_row - c.min_row) as f64 >= height as f64 / 2.0 && c.pos_n >= 4
}

/// A deterministic RANSAC line through pixels whose columns are first reduced by the curvature
/// `q` (px per u²): pairs of pixels from the upper and lower halves (in raster order) at least
/// `min_fragment_rows` rows apart, slope within the baseline filter's tolerance, the line with
/// most pixels within `gate` px. Returns (row, reduced column, slope) of the line; when it
/// does, `rows` and `cols` hold each pixel's row and reduced column.
pub(super) fn ransac(
    px: &[EdgePixel],
    q: f64,
    gate: f64,
    p: &Params,
    rows: &mut Vec<f64>,
    cols: &mut Vec<f64>,
) -> Option<(f64, f64, f64)> {
    let h = p.height;
    let tan = p.tan_tolerance_q10 as f64 / 1024.0;
    let col = |e: &EdgePixel| {
        let u = 2.0 * e.row as f64 - (h as f64 - 1.0);
        e.col32() as f64 / 32.0 - q * u * u
    };
    let n = px.len();
    let half = n / 2;
    if half == 0 {
        return None;
    }
    // Each pixel's row and reduced column once (the same values the tries would compute).
    rows.clear();
    rows.extend(px.iter().map(|e| e.row as f64));
    cols.clear();
    cols.extend(px.iter().map(col));
    let (rows, cols) = (&rows[..], &cols[..]);
    let min_rows = p.min_fragment_rows as f64;
    // The tries and their counts under one dispatch (not one per try).
    crate::simd::dispatch(
        #[inline(always)]
        || best_line(rows, cols, min_rows, tan, gate),
    )
}

/// RANSAC's tries ([`ransac`]) over the pixels' rows and reduced columns: (row, reduced column,
/// slope) of the first line with most pixels within `gate`; `None` without a pair of pixels
/// `min_rows` rows apart within the slope tolerance `tan`.
#[inline(always)]
pub(super) fn best_line(
    rows: &[f64],
    cols: &[f64],
    min_rows: f64,
    tan: f64,
    gate: f64,
) -> Option<(f64, f64, f64)> {
    let n = rows.len();
    let half = n / 2;
    let mut best: Option<(usize, f64, f64, f64)> = None;
    const TRIES: usize = 48;
    let ib_of = |k: usize| half + ((k * 37) % TRIES) * (n - half) / TRIES;
    // The first try with this try's `ia` (`ia` never decreases with k).
    let mut group = 0;
    for k in 0..TRIES {
        // Skipped tries could not be chosen (the choice needs strictly more inliers than the
        // best so far): once every pixel is an inlier of the best line, any later one; and a
        // try of the same pair of pixels as an earlier one (fewer than 48 pixels a half), whose
        // line and count are that try's, no more than the best since.
        if best.is_some_and(|b| b.0 == n) {
            break;
        }
        let ia = k * half / TRIES;
        if k > 0 && (k - 1) * half / TRIES != ia {
            group = k;
        }
        let ib = ib_of(k);
        if (group..k).any(|k2| ib_of(k2) == ib) {
            continue;
        }
        let dr = rows[ib] - rows[ia];
        if dr < min_rows {
            continue;
        }
        let slope = (cols[ib] - cols[ia]) / dr;
        if slope.abs() > tan {
            continue;
        }
        let (r0, c0) = (rows[ia], cols[ia]);
        // A line must beat the best so far: counting stops once it no longer can.
        let need = best.map_or(0, |b| b.0 + 1);
        let inl = inliers(rows, cols, r0, c0, slope, gate, need);
        if best.is_none_or(|b| inl > b.0) {
            best = Some((inl, r0, c0, slope));
        }
    }
    best.map(|(_, r0, c0, slope)| (r0, c0, slope))
}

/// Pixels within `gate` of the line through (r0, c0) with `slope` (vectorised: exact f64
/// arithmetic, no contraction, so every code path counts the same), counted 64 at a time; the
/// count stops early, below `need`, once even every pixel left could not bring it to `need`
/// (the caller only wants lines with at least `need`).
#[inline(always)]
pub(super) fn inliers(
    rows: &[f64],
    cols: &[f64],
    r0: f64,
    c0: f64,
    slope: f64,
    gate: f64,
    need: usize,
) -> usize {
    const CHUNK: usize = 64;
    let (mut n, mut left) = (0, rows.len());
    for (rs, cs) in rows.chunks(CHUNK).zip(cols.chunks(CHUNK)) {
        n += rs
            .iter()
            .zip(cs)
            .map(|(&r, &c)| ((c - c0 - slope * (r - r0)).abs() <= gate) as usize)
            .sum::<usize>();
        left -= rs.len();
        if n + left < need {
            break;
        }
    }
    n
}

pub(super) fn median(v: &mut [f64]) -> f64 {
    // The middle elements by selection, not a full sort: under `total_cmp` (a total order,
    // equal only for identical bits) the k-th smallest value is the sorted array's v[k].
    let n = v.len();
    if n == 0 {
        return f64::NAN;
    }
    let (below, &mut m, _) = v.select_nth_unstable_by(n / 2, f64::total_cmp);
    if n % 2 == 1 {
        m
    } else {
        let lo = below.iter().copied().max_by(f64::total_cmp).unwrap_or(m);
        0.5 * (lo + m)
    }
}

/// Solves a small dense system by Gaussian elimination with partial pivoting.
#[allow(clippy::needless_range_loop)]
pub(super) fn solve_n<const N: usize>(mut a: [[f64; N]; N], mut b: [f64; N]) -> Option<[f64; N]> {
    for k in 0..N {
        let piv = (k..N).max_by(|&i, &j| a[i][k].abs().total_cmp(&a[j][k].abs()))?;
        if a[piv][k].abs() < 1e-12 * a[k][k].abs().max(1.0) || a[piv][k] == 0.0 {
            return None;
        }
        a.swap(k, piv);
        b.swap(k, piv);
        for i in k + 1..N {
            let f = a[i][k] / a[k][k];
            for j in k..N {
                a[i][j] -= f * a[k][j];
            }
            b[i] -= f * b[k];
        }
    }
    let mut x = [0.0; N];
    for k in (0..N).rev() {
        let s: f64 = (k + 1..N).map(|j| a[k][j] * x[j]).sum();
        x[k] = (b[k] - s) / a[k][k];
    }
    Some(x)
}

/// Window-mean column of a curve: its mean over the window's rows, px.
pub fn window_mean(c: &Curve, height: usize) -> f64 {
    let mean_u2 = ((height * height) as f64 - 1.0) / 3.0;
    c.a + c.q * mean_u2
}
