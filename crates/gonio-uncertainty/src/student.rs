//! The Student-t distribution: cumulative distribution, quantile and the GUM coverage factor.
//!
//! Written here rather than taken from a statistics crate because the coverage factor is part of
//! the product and must behave at the ends: the quantile is found by a safeguarded Newton iteration
//! on the regularised incomplete beta function ([`gonio_core::special::beta_inc`]),
//!
//! ```text
//! P(|T| > t) = I_{ν/(ν+t²)}(ν/2, 1/2),
//! ```
//!
//! for ν ≤ 10⁵, by the Cornish–Fisher expansion about the normal quantile (Abramowitz & Stegun
//! 26.7.5, four terms, error far below 1e-12 there) for larger ν, and by the normal distribution for
//! ν = ∞ (`f64::INFINITY`). Relative accuracy of the quantile is ~1e-12 for ν ≥ 1 and probabilities
//! in (1e-10, 1 − 1e-10).
//!
//! ```
//! use gonio_uncertainty::student::coverage_factor;
//! // JCGM 100 Table G.2 and the seed's Table 3: t₀.₉₇₅(13) = 2.160.
//! assert!((coverage_factor(0.95, 13.0) - 2.160368656).abs() < 1e-8);
//! assert!((coverage_factor(0.95, f64::INFINITY) - 1.959963985).abs() < 1e-8);
//! ```

use gonio_core::special::{beta_inc, ln_gamma, normal_cdf, normal_quantile};

/// Above this many degrees of freedom the quantile uses the Cornish–Fisher expansion.
const EXPANSION_NU: f64 = 1e5;

/// Two-sided tail P(|T| > |t|) for ν degrees of freedom (finite).
fn two_sided_tail(t: f64, nu: f64) -> f64 {
    let t2 = t * t;
    if t2 == 0.0 {
        return 1.0;
    }
    if t2.is_infinite() {
        return 0.0;
    }
    beta_inc(0.5 * nu, 0.5, nu / (nu + t2))
}

/// Probability density of Student's t with ν degrees of freedom (ν = ∞: the normal density).
pub fn student_t_pdf(t: f64, nu: f64) -> f64 {
    if nu.is_infinite() {
        return (-0.5 * t * t).exp() / (2.0 * std::f64::consts::PI).sqrt();
    }
    let ln = ln_gamma(0.5 * (nu + 1.0))
        - ln_gamma(0.5 * nu)
        - 0.5 * (nu * std::f64::consts::PI).ln()
        - 0.5 * (nu + 1.0) * (t * t / nu).ln_1p();
    ln.exp()
}

/// The cumulative distribution P(T ≤ t) of Student's t with ν > 0 degrees of freedom
/// (`f64::INFINITY` gives the standard normal). Returns NaN for ν ≤ 0 or NaN inputs.
///
/// ```
/// use gonio_uncertainty::student::student_t_cdf;
/// // ν = 1 is the Cauchy distribution: F(t) = 1/2 + atan(t)/π.
/// let t = 3.0f64;
/// assert!((student_t_cdf(t, 1.0) - (0.5 + t.atan() / std::f64::consts::PI)).abs() < 1e-14);
/// ```
pub fn student_t_cdf(t: f64, nu: f64) -> f64 {
    if t.is_nan() || nu.is_nan() || nu <= 0.0 {
        return f64::NAN;
    }
    if nu.is_infinite() {
        return normal_cdf(t);
    }
    let half_tail = 0.5 * two_sided_tail(t, nu);
    if t > 0.0 { 1.0 - half_tail } else { half_tail }
}

/// The Cornish–Fisher expansion of the t quantile about the normal quantile z (A&S 26.7.5).
fn cornish_fisher(z: f64, nu: f64) -> f64 {
    let z2 = z * z;
    let z3 = z2 * z;
    let z5 = z3 * z2;
    let z7 = z5 * z2;
    let z9 = z7 * z2;
    let g1 = (z3 + z) / 4.0;
    let g2 = (5.0 * z5 + 16.0 * z3 + 3.0 * z) / 96.0;
    let g3 = (3.0 * z7 + 19.0 * z5 + 17.0 * z3 - 15.0 * z) / 384.0;
    let g4 = (79.0 * z9 + 776.0 * z7 + 1482.0 * z5 - 1920.0 * z3 - 945.0 * z) / 92160.0;
    z + g1 / nu + g2 / (nu * nu) + g3 / (nu * nu * nu) + g4 / (nu * nu * nu * nu)
}

/// The quantile t_p(ν): the value with P(T ≤ t) = p, for 0 < p < 1 and ν > 0 (`f64::INFINITY`
/// gives the normal quantile). p = 0 and 1 give ∓∞; anything else outside gives NaN.
///
/// ```
/// use gonio_uncertainty::student::student_t_quantile;
/// // ν = 2 has a closed form: t = (2p − 1)·√(2 / (1 − (2p − 1)²)).
/// let p: f64 = 0.9;
/// let q = 2.0 * p - 1.0;
/// let exact = q * (2.0 / (1.0 - q * q)).sqrt();
/// assert!((student_t_quantile(p, 2.0) / exact - 1.0).abs() < 1e-12);
/// ```
pub fn student_t_quantile(p: f64, nu: f64) -> f64 {
    if p.is_nan() || nu.is_nan() || nu <= 0.0 || !(0.0..=1.0).contains(&p) {
        return f64::NAN;
    }
    if p == 0.0 {
        return f64::NEG_INFINITY;
    }
    if p == 1.0 {
        return f64::INFINITY;
    }
    if p == 0.5 {
        return 0.0;
    }
    // Work with the upper tail α = P(T > t) < 1/2 and t > 0, then restore the sign.
    let (alpha, sign) = if p > 0.5 { (1.0 - p, 1.0) } else { (p, -1.0) };
    if nu.is_infinite() {
        return sign * -normal_quantile(alpha);
    }
    let z = -normal_quantile(alpha);
    if nu > EXPANSION_NU {
        return sign * cornish_fisher(z, nu);
    }
    sign * upper_quantile(alpha, nu, z)
}

/// Solves P(|T| > t) = 2α for t > 0 by Newton on ln P(|T| > t), kept inside a bisection bracket.
fn upper_quantile(alpha: f64, nu: f64, z: f64) -> f64 {
    let target = 2.0 * alpha;
    let ln_target = target.ln();
    // Bracket [lo, hi]: the tail decreases in t.
    let mut lo = 0.0f64;
    let mut hi = z.max(1.0);
    while two_sided_tail(hi, nu) > target {
        lo = hi;
        hi *= 2.0;
        // Beyond t ≈ 1.3e154, t² overflows and the tail cannot be evaluated: the quantile is
        // not a number f64 can resolve (ν ≈ 1e-5 puts it near 10^(1e5)), not that value.
        if !(hi * hi).is_finite() {
            return f64::INFINITY;
        }
        // Nor when ν/(ν + t²) leaves the normal range of f64 first (ν of 1e-300): the tail
        // I_x(ν/2, ½) then reads 0 where it is still near 1, and the bracket would end at a
        // made-up t.
        if nu / (nu + hi * hi) < f64::MIN_POSITIVE {
            return f64::INFINITY;
        }
    }
    // Start from the expansion (good for large ν), clamped into the bracket.
    let mut t = cornish_fisher(z, nu);
    if !(t > lo && t < hi) {
        t = 0.5 * (lo + hi);
    }
    for _ in 0..200 {
        let tail = two_sided_tail(t, nu);
        if tail > target {
            lo = t;
        } else {
            hi = t;
        }
        // d/dt ln tail = −2 f(t) / tail.
        let slope = -2.0 * student_t_pdf(t, nu) / tail;
        let mut next = t - (tail.ln() - ln_target) / slope;
        if next.is_nan() || next <= lo || next >= hi {
            next = 0.5 * (lo + hi);
        }
        let done = (next - t).abs() <= 1e-15 * t.abs() || hi - lo <= 1e-15 * hi;
        t = next;
        if done {
            break;
        }
    }
    t
}

/// The GUM coverage factor k_p(ν) = t_{(1+p)/2}(ν): the half-width, in standard uncertainties, of
/// the two-sided interval that holds the fraction p (0 < p < 1) of a t distribution with ν degrees
/// of freedom (ν = ∞: the normal value, e.g. 1.96 for p = 0.95, 2.0 for p = 0.9545).
/// Returns NaN for p outside (0, 1) or ν ≤ 0, and ∞ when the quantile is beyond what an f64
/// t can resolve (t² would overflow: ν of about 10⁻⁴ or less); callers treat both as errors.
///
/// ```
/// use gonio_uncertainty::student::coverage_factor;
/// // JCGM 100 Annex H.1: k₉₉ = t₀.₉₉₅(16) = 2.92.
/// assert!((coverage_factor(0.99, 16.0) - 2.920781621).abs() < 1e-8);
/// ```
pub fn coverage_factor(p: f64, nu: f64) -> f64 {
    if !(p > 0.0 && p < 1.0) {
        return f64::NAN;
    }
    student_t_quantile(0.5 + 0.5 * p, nu)
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    #[test]
    fn a_quantile_beyond_f64_is_infinite_not_a_made_up_number() {
        // ν = 1e-5: the 97.5 % quantile is about 40^(1/ν); it was reported as 1.3e154 (where t²
        // overflows).
        for nu in [1e-300, 1e-100, 1e-5, 1e-4, 1e-3] {
            let k = coverage_factor(0.95, nu);
            assert!(k.is_infinite(), "ν = {nu}: k = {k}");
        }
        // Small but resolvable ν still gives a finite k that satisfies its defining equation.
        let nu = 0.05;
        let k = coverage_factor(0.95, nu);
        assert!(k.is_finite() && k > 1e20, "{k}");
        assert!((two_sided_tail(k, nu) / 0.05 - 1.0).abs() < 1e-9);
    }

    /// Two-sided coverage A(t|ν) = P(|T| ≤ t) for whole ν by the finite trigonometric series of
    /// Abramowitz & Stegun 26.7.3–26.7.4 (independent of the incomplete beta function).
    fn coverage_series(t: f64, nu: u32) -> f64 {
        let theta = (t / f64::from(nu).sqrt()).atan();
        let (s, c) = theta.sin_cos();
        let c2 = c * c;
        if nu % 2 == 1 {
            // 2/π [θ + sinθ (cosθ + 2/3 cos³θ + … + (2·4⋯(ν−3))/(1·3⋯(ν−2)) cos^(ν−2)θ)]
            let mut sum = 0.0;
            if nu > 1 {
                let mut term = c;
                sum = term;
                let mut j = 1;
                while 2 * j + 1 < nu {
                    term *= c2 * (2 * j) as f64 / (2 * j + 1) as f64;
                    sum += term;
                    j += 1;
                }
            }
            2.0 / PI * (theta + s * sum)
        } else {
            // sinθ [1 + 1/2 cos²θ + (1·3)/(2·4) cos⁴θ + … + (1·3⋯(ν−3))/(2·4⋯(ν−2)) cos^(ν−2)θ]
            let mut term = 1.0;
            let mut sum = 1.0;
            let mut j = 1;
            while 2 * j < nu {
                term *= c2 * (2 * j - 1) as f64 / (2 * j) as f64;
                sum += term;
                j += 1;
            }
            s * sum
        }
    }

    /// Independent quantile: bisection on the series to full precision.
    fn coverage_factor_series(p: f64, nu: u32) -> f64 {
        let (mut lo, mut hi) = (0.0f64, 1.0f64);
        while coverage_series(hi, nu) < p {
            hi *= 2.0;
        }
        for _ in 0..200 {
            let mid = 0.5 * (lo + hi);
            if coverage_series(mid, nu) < p {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        0.5 * (lo + hi)
    }

    const PS: [f64; 6] = [0.6827, 0.90, 0.95, 0.9545, 0.99, 0.9973];

    #[test]
    fn quantiles_match_independent_series_for_nu_1_to_1000() {
        let mut worst = 0.0f64;
        for nu in 1..=1000u32 {
            for &p in &PS {
                let k = coverage_factor(p, f64::from(nu));
                let r = coverage_factor_series(p, nu);
                let rel = (k / r - 1.0).abs();
                worst = worst.max(rel);
                assert!(rel < 1e-6, "nu={nu} p={p}: {k} vs series {r}");
            }
        }
        eprintln!("worst relative error of k over ν = 1…1000, 6 coverages: {worst:e}");
        // The requirement is 1e-6; the implementation does far better.
        assert!(worst < 1e-9, "worst relative error {worst}");
    }

    #[test]
    fn closed_forms_nu_1_2_and_infinity() {
        for &p in &PS {
            // ν = 1 (Cauchy): k = tan(πp/2).
            let k1 = (PI * p / 2.0).tan();
            assert!((coverage_factor(p, 1.0) / k1 - 1.0).abs() < 1e-12, "p={p}");
            // ν = 2: k = p √(2/(1 − p²)).
            let k2 = p * (2.0 / (1.0 - p * p)).sqrt();
            assert!((coverage_factor(p, 2.0) / k2 - 1.0).abs() < 1e-12, "p={p}");
            // ν = ∞: the normal quantile.
            let kz = normal_quantile(0.5 + p / 2.0);
            assert!((coverage_factor(p, f64::INFINITY) / kz - 1.0).abs() < 1e-14);
        }
        // 95.45 % at ν = ∞ is k = 2 (to the 4 digits of 95.45).
        assert!((coverage_factor(0.9545, f64::INFINITY) - 2.0).abs() < 1e-3);
    }

    #[test]
    fn published_high_precision_values() {
        // Values to 10 digits as tabulated (e.g. R's qt and NIST/SEMATECH tables).
        let cases = [
            (0.975, 13.0, 2.160368656),
            (0.995, 16.0, 2.920781621),
            (0.975, 1.0, 12.70620474),
            (0.975, 10.0, 2.228138852),
            (0.95, 10.0, 1.812461123),
            (0.995, 10.0, 3.169272673),
            (0.975, 30.0, 2.042272456),
            (0.975, 100.0, 1.983971519),
        ];
        for (p, nu, t) in cases {
            let q = student_t_quantile(p, nu);
            assert!((q / t - 1.0).abs() < 1e-9, "t_{p}({nu}) = {q}, table {t}");
            assert!((student_t_cdf(q, nu) - p).abs() < 1e-13);
        }
    }

    #[test]
    fn jcgm_100_table_g2() {
        // JCGM 100 Table G.2 (ν, k at 68.27, 90, 95, 95.45, 99, 99.73 %), printed to 2 decimals.
        let table: [(f64, [f64; 6]); 8] = [
            // GUM prints 235.80 for ν = 1 at 99.73 %; the exact tan(π·0.9973/2) = 235.784 (a
            // rounding in the table): compared with 235.78 here.
            (1.0, [1.84, 6.31, 12.71, 13.97, 63.66, 235.78]),
            (2.0, [1.32, 2.92, 4.30, 4.53, 9.92, 19.21]),
            (3.0, [1.20, 2.35, 3.18, 3.31, 5.84, 9.22]),
            (5.0, [1.11, 2.02, 2.57, 2.65, 4.03, 5.51]),
            (10.0, [1.05, 1.81, 2.23, 2.28, 3.17, 3.96]),
            (20.0, [1.03, 1.72, 2.09, 2.13, 2.85, 3.42]),
            (50.0, [1.01, 1.68, 2.01, 2.05, 2.68, 3.16]),
            (f64::INFINITY, [1.000, 1.645, 1.960, 2.000, 2.576, 3.000]),
        ];
        for (nu, ks) in table {
            for (&p, &k) in PS.iter().zip(&ks) {
                let got = coverage_factor(p, nu);
                assert!(
                    (got - k).abs() <= 0.005 + 1e-9,
                    "ν={nu} p={p}: {got} vs {k}"
                );
            }
        }
    }

    #[test]
    fn expansion_and_beta_agree_near_the_switch() {
        for &nu in &[1e3, 1e4, 99_999.0] {
            for &p in &PS {
                let alpha = 0.5 - p / 2.0;
                let z = -normal_quantile(alpha);
                let a = upper_quantile(alpha, nu, z);
                let b = cornish_fisher(z, nu);
                // Near 10⁵ the beta path loses ~1e-10 to ln Γ of large arguments: the reason
                // for switching to the expansion there.
                assert!((a / b - 1.0).abs() < 1e-9, "nu={nu} p={p}: {a} vs {b}");
            }
        }
        // Continuity across the switch and monotone approach to the normal value.
        let below = coverage_factor(0.95, EXPANSION_NU);
        let above = coverage_factor(0.95, EXPANSION_NU * 1.000_001);
        assert!((below - above).abs() < 1e-9 * below);
        assert!(coverage_factor(0.95, 1e12) - 1.959963984540054 < 1e-11);
    }

    #[test]
    fn bad_arguments_give_nan_not_a_hang() {
        assert!(coverage_factor(1.0, 5.0).is_nan());
        assert!(coverage_factor(0.0, 5.0).is_nan());
        assert!(coverage_factor(0.95, 0.0).is_nan());
        assert!(coverage_factor(0.95, -1.0).is_nan());
        assert!(student_t_quantile(f64::NAN, 3.0).is_nan());
        assert_eq!(student_t_quantile(1.0, 3.0), f64::INFINITY);
        // Fractional ν works (the Welch–Satterthwaite ν may be below 1).
        let k = coverage_factor(0.95, 0.5);
        assert!((student_t_cdf(k, 0.5) - 0.975).abs() < 1e-12 && k > 12.7);
    }
}
