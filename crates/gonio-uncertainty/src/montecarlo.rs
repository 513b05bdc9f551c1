//! Monte Carlo propagation of distributions (JCGM 101:2008): adaptive, seeded, with
//! probabilistically symmetric and shortest coverage intervals, and the GUM validation of §8.
//!
//! Each input is drawn from its distribution (JCGM 101 §6.4: normal; rectangular; symmetric
//! triangular; arcsine; scaled-and-shifted t for a Type A input with ν degrees of freedom), the
//! measurement function supplied by the caller maps each draw to a value of the output, and the
//! sorted values give the coverage intervals (§7.7). Inputs that take part in a correlation are
//! drawn jointly from a multivariate normal with their standard uncertainties (§6.4.8), whatever
//! their declared shape.
//!
//! Adaptive mode (§7.9.4): batches of M = max(⌈100/(1−p)⌉, 10⁴) trials are added until twice the
//! standard deviation of the batch means, standard uncertainties and interval end points is below
//! the numerical tolerance δ = ½·10^l of u(y) written with `ndig` significant digits (§7.9.2).
//! Draws come from ChaCha20 seeded with the configured seed: the same seed gives the same result,
//! bit for bit. Inputs are generated a batch at a time, column by column, and the model is called
//! with one reused slice, so the trial loop never allocates.
//!
//! ```
//! use gonio_uncertainty::{InputDistribution, McConfig, monte_carlo};
//! // Y = X1 + X2 with two standard normal inputs: u(y) = √2.
//! let inputs = [InputDistribution::Normal { mean: 0.0, sd: 1.0 }; 2];
//! let r = monte_carlo(&inputs, &[], |x: &[f64]| x[0] + x[1], &McConfig::default()).unwrap();
//! assert!(r.converged);
//! assert!((r.std_uncertainty - 2f64.sqrt()).abs() < 0.01);
//! ```

use crate::envelope::Envelope;
use crate::{UncertaintyError, check_coverage, limits};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha20Rng;
use rand_distr::{ChiSquared, Distribution, StandardNormal};
use serde::Serialize;

/// The probability distribution of one input quantity.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
#[serde(tag = "distribution", rename_all = "snake_case")]
#[non_exhaustive]
pub enum InputDistribution {
    /// Normal N(mean, sd²).
    Normal {
        /// Expectation.
        mean: f64,
        /// Standard deviation.
        sd: f64,
    },
    /// Rectangular on [mean − a, mean + a].
    Rectangular {
        /// Centre.
        mean: f64,
        /// Half-width a.
        half_width: f64,
    },
    /// Symmetric triangular on [mean − a, mean + a].
    Triangular {
        /// Centre.
        mean: f64,
        /// Half-width a.
        half_width: f64,
    },
    /// Arcsine (U-shaped) on [mean − a, mean + a].
    Arcsine {
        /// Centre.
        mean: f64,
        /// Half-width a.
        half_width: f64,
    },
    /// Scaled and shifted t: mean + scale·T_ν (JCGM 101 §6.4.9; for n observations, mean x̄,
    /// scale s/√n, ν = n − 1). Its standard deviation is scale·√(ν/(ν − 2)) for ν > 2.
    StudentT {
        /// Location.
        mean: f64,
        /// Scale.
        scale: f64,
        /// Degrees of freedom (> 0; infinite gives the normal).
        nu: f64,
    },
}

impl InputDistribution {
    /// The distribution's expectation.
    pub fn mean(&self) -> f64 {
        match *self {
            InputDistribution::Normal { mean, .. }
            | InputDistribution::Rectangular { mean, .. }
            | InputDistribution::Triangular { mean, .. }
            | InputDistribution::Arcsine { mean, .. }
            | InputDistribution::StudentT { mean, .. } => mean,
        }
    }

    /// The standard deviation used when the input is drawn as part of a correlated (normal) group:
    /// the GUM standard uncertainty (for the t, its scale).
    pub fn std_uncertainty(&self) -> f64 {
        match *self {
            InputDistribution::Normal { sd, .. } => sd,
            InputDistribution::Rectangular { half_width, .. } => half_width / 3f64.sqrt(),
            InputDistribution::Triangular { half_width, .. } => half_width / 6f64.sqrt(),
            InputDistribution::Arcsine { half_width, .. } => half_width / 2f64.sqrt(),
            InputDistribution::StudentT { scale, .. } => scale,
        }
    }

    /// A bound of |x| over the draws: the end of the support for the bounded shapes, 40 standard
    /// uncertainties beyond the mean for the normal and the t (draws beyond it are possible for
    /// the t but not expected; a run that meets one still fails cleanly).
    pub(crate) fn reach(&self) -> f64 {
        match *self {
            InputDistribution::Rectangular { mean, half_width }
            | InputDistribution::Triangular { mean, half_width }
            | InputDistribution::Arcsine { mean, half_width } => mean.abs() + half_width,
            InputDistribution::Normal { mean, sd } => mean.abs() + 40.0 * sd,
            InputDistribution::StudentT { mean, scale, .. } => mean.abs() + 40.0 * scale,
        }
    }

    fn check(&self, i: usize) -> Result<(), UncertaintyError> {
        let ok = |x: f64| x.is_finite() && x >= 0.0;
        let good = self.mean().is_finite()
            && match *self {
                InputDistribution::Normal { sd, .. } => ok(sd),
                InputDistribution::Rectangular { half_width, .. }
                | InputDistribution::Triangular { half_width, .. }
                | InputDistribution::Arcsine { half_width, .. } => ok(half_width),
                InputDistribution::StudentT { scale, nu, .. } => ok(scale) && nu > 0.0,
            };
        if good {
            Ok(())
        } else {
            Err(UncertaintyError::MonteCarlo {
                what: format!("input {i}: invalid distribution {self:?}"),
            })
        }
    }

    /// Fills `out` with draws.
    ///
    /// The rectangular, triangular and arcsine shapes take a fixed number of 64-bit words per
    /// draw (1, 2 and 1), so their words are generated in one block (`fill`, the same stream as
    /// one `random::<u64>()` after the other) and turned into values in a loop of plain arithmetic:
    /// the same values as drawing them one at a time with `random::<f64>()`.
    fn fill(&self, rng: &mut ChaCha20Rng, scratch: &mut Scratch, out: &mut [f64]) {
        match *self {
            InputDistribution::Normal { mean, sd } => {
                for v in out {
                    let z: f64 = StandardNormal.sample(rng);
                    *v = mean + sd * z;
                }
            }
            InputDistribution::Rectangular { mean, half_width } => {
                let w = scratch.words(rng, out.len());
                for (v, &x) in out.iter_mut().zip(w) {
                    *v = mean + half_width * (2.0 * unit(x) - 1.0);
                }
            }
            InputDistribution::Triangular { mean, half_width } => {
                let w = scratch.words(rng, 2 * out.len());
                for (v, x) in out.iter_mut().zip(w.chunks_exact(2)) {
                    let s = unit(x[0]) + unit(x[1]);
                    *v = mean + half_width * (s - 1.0);
                }
            }
            InputDistribution::Arcsine { mean, half_width } => {
                let w = scratch.words(rng, out.len());
                for (v, &x) in out.iter_mut().zip(w) {
                    *v = mean + half_width * sin_two_pi(unit(x));
                }
            }
            InputDistribution::StudentT { mean, scale, nu } => match ChiSquared::new(nu) {
                Ok(chi) if nu.is_finite() => {
                    // rand_distr's StudentT::sample, in two passes: the draws (a standard normal,
                    // then a χ²_ν, for each value), then norm·√(ν/χ²) for all of them, so that
                    // the divisions and square roots overlap instead of waiting one by one.
                    // Same draws, same arithmetic, same bits (tested against StudentT).
                    let (norm, chis) = scratch.pair(out.len());
                    for (z, c) in norm.iter_mut().zip(chis.iter_mut()) {
                        *z = StandardNormal.sample(rng);
                        *c = chi.sample(rng);
                    }
                    for ((v, z), c) in out.iter_mut().zip(norm.iter()).zip(chis.iter()) {
                        *v = mean + scale * (z * (nu / c).sqrt());
                    }
                }
                _ => {
                    for v in out {
                        let z: f64 = StandardNormal.sample(rng);
                        *v = mean + scale * z;
                    }
                }
            },
        }
    }
}

/// Reusable buffers of the draws: random words, and two columns of intermediate values.
#[derive(Debug, Default)]
struct Scratch {
    words: Vec<u64>,
    a: Vec<f64>,
    b: Vec<f64>,
}

impl Scratch {
    /// n random words, drawn in one block.
    fn words(&mut self, rng: &mut ChaCha20Rng, n: usize) -> &[u64] {
        self.words.resize(n, 0);
        rng.fill(&mut self.words[..n]);
        &self.words[..n]
    }

    /// Two columns of n values.
    fn pair(&mut self, n: usize) -> (&mut [f64], &mut [f64]) {
        self.a.resize(n, 0.0);
        self.b.resize(n, 0.0);
        (&mut self.a[..n], &mut self.b[..n])
    }
}

/// A uniform draw in [0, 1) from a 64-bit word: its 53 high bits times 2⁻⁵³, as rand's
/// `random::<f64>()` makes it.
#[inline]
fn unit(x: u64) -> f64 {
    (x >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
}

/// Taylor coefficients of sin(π w) in w: (−1)ᵏ π²ᵏ⁺¹/(2k+1)!, k = 0…10 (correctly rounded). For
/// |w| ≤ ½ the first omitted term is below 1.3·10⁻¹⁸.
const SIN_PI: [f64; 11] = [
    std::f64::consts::PI,
    -5.16771278004997,
    2.5501640398773455,
    -0.5992645293207921,
    0.08214588661112823,
    -0.0073704309457143504,
    0.00046630280576761255,
    -2.1915353447830217e-05,
    7.952054001475513e-07,
    -2.2948428997269873e-08,
    5.392664662608129e-10,
];

/// sin(2πr) for r in [0, 1), within a few units in the last place, in plain arithmetic (the same
/// bits on every platform, unlike the C library's `sin`, and about ten times faster).
///
/// The reduction is exact: y = 2(r − ½) ∈ [−1, 1) and sin(2πr) = −sin(πy); for |y| > ½,
/// sin(πy) = sin(π(±1 − y)), so the polynomial only sees |w| ≤ ½.
#[inline]
fn sin_two_pi(r: f64) -> f64 {
    let y = 2.0 * (r - 0.5);
    let w = if y > 0.5 {
        1.0 - y
    } else if y < -0.5 {
        -1.0 - y
    } else {
        y
    };
    let w2 = w * w;
    let mut p = SIN_PI[10];
    for c in SIN_PI[..10].iter().rev() {
        p = p * w2 + c;
    }
    -(w * p)
}

/// The most trials one run may use (memory: 8 bytes per trial).
pub const MAX_TRIALS: usize = 100_000_000;

/// A fixed number of trials ([`McTrials::Fixed`]): at most [`MAX_TRIALS`] (the coverage asks
/// for a lower bound of its own, checked by the run).
pub const TRIALS: gonio_core::bound::Bound =
    gonio_core::bound::Bound::new(1.0, MAX_TRIALS as f64, "trials");

/// Significant digits of u regarded as meaningful ([`McConfig::ndig`], JCGM 101 §7.9.2: 1 or 2
/// in practice); beyond 6 the adaptive run's tolerance asks for more trials than it may use.
pub const NDIG: gonio_core::bound::Bound = gonio_core::bound::Bound::new(1.0, 6.0, "");

/// How many trials to run.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum McTrials {
    /// JCGM 101 §7.9 adaptive procedure, stopping at `max_trials` at the latest (then
    /// [`McResult::converged`] is false).
    Adaptive {
        /// Upper limit on the number of trials.
        max_trials: usize,
    },
    /// Exactly this many trials (no stability check).
    Fixed(usize),
}

/// Monte Carlo settings.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct McConfig {
    /// Coverage probability p (0 < p < 1).
    pub coverage: f64,
    /// Seed of the ChaCha20 generator.
    pub seed: u64,
    /// Significant decimal digits of u(y) regarded as meaningful (JCGM 101 §7.9.2; usually 1 or 2).
    pub ndig: u32,
    /// Adaptive or fixed number of trials.
    pub trials: McTrials,
}

impl Default for McConfig {
    /// p = 0.95, seed 1, ndig = 2, adaptive up to 10⁷ trials.
    fn default() -> McConfig {
        McConfig {
            coverage: 0.95,
            seed: 1,
            ndig: 2,
            trials: McTrials::Adaptive {
                max_trials: 10_000_000,
            },
        }
    }
}

/// A coverage interval [low, high].
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Interval {
    /// Lower end point.
    pub low: f64,
    /// Upper end point.
    pub high: f64,
}

/// Monte Carlo summary of the output quantity.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct McResult {
    /// Estimate y: the mean of the model values.
    pub estimate: f64,
    /// Standard uncertainty u(y): their standard deviation.
    pub std_uncertainty: f64,
    /// Coverage probability p.
    pub coverage: f64,
    /// Probabilistically symmetric coverage interval.
    pub symmetric: Interval,
    /// Shortest coverage interval.
    pub shortest: Interval,
    /// Number of trials used.
    pub trials: usize,
    /// Number of batches (1 for a fixed run).
    pub batches: usize,
    /// Whether the adaptive procedure reached its tolerance (true for fixed runs).
    pub converged: bool,
    /// Numerical tolerance δ of u(y) at `ndig` digits.
    pub tolerance: f64,
    /// The seed used.
    pub seed: u64,
}

/// The numerical tolerance δ = ½·10^l where u = c·10^l and c has `ndig` digits (JCGM 101 §7.9.2).
///
/// ```
/// use gonio_uncertainty::montecarlo::numerical_tolerance;
/// assert!((numerical_tolerance(0.0692, 2) - 0.0005).abs() < 1e-15);
/// assert!((numerical_tolerance(32.0, 1) - 5.0).abs() < 1e-12);
/// ```
pub fn numerical_tolerance(u: f64, ndig: u32) -> f64 {
    if u.is_nan() || u <= 0.0 || !u.is_finite() {
        return 0.0;
    }
    let l = u.log10().floor() as i32 - (ndig.max(1) as i32 - 1);
    0.5 * 10f64.powi(l)
}

/// (q, r) of JCGM 101 §7.7: q values cover p; the symmetric interval starts at the r-th (1-based).
fn interval_indices(m: usize, p: f64) -> (usize, usize) {
    let pm = p * m as f64;
    let q = if pm.fract() == 0.0 {
        pm as usize
    } else {
        (pm + 0.5).floor() as usize
    };
    // JCGM 101 §7.7: r = (M − q)/2 for M − q even, (M − q + 1)/2 for odd, i.e. ⌈(M − q)/2⌉.
    let r = (m - q).div_ceil(2);
    (q, r.max(1))
}

/// Puts in place the order statistics that the coverage intervals read: the m − q smallest values
/// in order at the start and the m − q largest in order at the end (m values, q of them covering
/// p). The middle is left partitioned but unsorted: a selection (`select_nth_unstable`) and two
/// sorts of 5 % of the values each at p = 95 %, instead of a sort of all of them. The values at
/// those indices are exactly those of a full sort.
fn order_tails(v: &mut [f64], q: usize) {
    let m = v.len();
    let k = m - q;
    if k == 0 || 2 * k >= m {
        v.sort_unstable_by(f64::total_cmp);
        return;
    }
    v.select_nth_unstable_by(k, f64::total_cmp);
    v[..k].sort_unstable_by(f64::total_cmp);
    if q > k {
        v[k + 1..].select_nth_unstable_by(q - k - 1, f64::total_cmp);
    }
    v[q + 1..].sort_unstable_by(f64::total_cmp);
}

/// Intervals from values ordered by [`order_tails`] (or fully sorted).
fn intervals(sorted: &[f64], p: f64) -> (Interval, Interval) {
    let m = sorted.len();
    let (q, r) = interval_indices(m, p);
    let sym = Interval {
        low: sorted[r - 1],
        high: sorted[(r + q - 1).min(m - 1)],
    };
    let mut best = (f64::INFINITY, 0usize);
    for s in 0..m - q {
        let w = sorted[s + q] - sorted[s];
        if w < best.0 {
            best = (w, s);
        }
    }
    let shortest = Interval {
        low: sorted[best.1],
        high: sorted[best.1 + q],
    };
    (sym, shortest)
}

/// Coverage intervals of `values`, which are reordered.
fn intervals_of(values: &mut [f64], p: f64) -> (Interval, Interval) {
    let (q, _) = interval_indices(values.len(), p);
    order_tails(values, q);
    intervals(values, p)
}

fn mean_sd_plain(v: &[f64], scale: f64) -> (f64, f64) {
    let n = v.len() as f64;
    let mean = v.iter().map(|x| x * scale).sum::<f64>() / n;
    let ss: f64 = v.iter().map(|x| (x * scale - mean).powi(2)).sum();
    (
        mean,
        if v.len() > 1 {
            (ss / (n - 1.0)).sqrt()
        } else {
            0.0
        },
    )
}

/// Mean and sample standard deviation. When the sums would overflow (values beyond about
/// 1e150), the values are scaled by a power of two first, which is exact.
fn mean_sd(v: &[f64]) -> (f64, f64) {
    let (mean, sd) = mean_sd_plain(v, 1.0);
    if mean.is_finite() && sd.is_finite() {
        return (mean, sd);
    }
    let big = v.iter().fold(0.0f64, |a, x| a.max(x.abs()));
    if !big.is_finite() || big == 0.0 {
        return (mean, sd);
    }
    let e = big.log2().ceil() as i32;
    let (mean, sd) = mean_sd_plain(v, 2f64.powi(-e));
    let back = 2f64.powi(e);
    (mean * back, sd * back)
}

/// The sampler: inputs, the correlated group's Cholesky factor (envelope storage), and reusable
/// buffers.
struct Sampler<'a> {
    inputs: &'a [InputDistribution],
    /// Whether each input is drawn as part of the correlated group.
    in_group: Vec<bool>,
    /// Indices of the correlated inputs (ascending) and the lower Cholesky factor of their
    /// correlation matrix.
    group: Vec<usize>,
    chol: Option<Envelope>,
    z: Vec<f64>,
    columns: Vec<f64>,
    scratch: Scratch,
    rng: ChaCha20Rng,
}

impl Sampler<'_> {
    /// Draws `m` trials into column-major `columns` (input i at `i*m..(i+1)*m`): each independent
    /// input's column in turn, then the correlated group trial by trial.
    fn draw(&mut self, m: usize) {
        let n = self.inputs.len();
        self.columns.resize(n * m, 0.0);
        for (i, d) in self.inputs.iter().enumerate() {
            if !self.in_group[i] {
                d.fill(
                    &mut self.rng,
                    &mut self.scratch,
                    &mut self.columns[i * m..(i + 1) * m],
                );
            }
        }
        let Some(chol) = &self.chol else { return };
        for j in 0..m {
            for zk in self.z.iter_mut() {
                *zk = StandardNormal.sample(&mut self.rng);
            }
            for (a, &i) in self.group.iter().enumerate() {
                let (first, row) = chol.row(a);
                let mut s = 0.0;
                for (l, zb) in row.iter().zip(&self.z[first..]) {
                    s += l * zb;
                }
                let d = &self.inputs[i];
                self.columns[i * m + j] = d.mean() + d.std_uncertainty() * s;
            }
        }
    }
}

/// Runs the Monte Carlo method for `model` with independent `inputs` except for the correlations
/// `(i, j, r_ij)`.
///
/// # Errors
/// [`UncertaintyError::MonteCarlo`] for no inputs, an invalid distribution or trial count, a
/// non-finite model value, or a bad correlation; [`UncertaintyError::BadCoverage`];
/// [`UncertaintyError::NotPositiveDefinite`]; [`UncertaintyError::TooLarge`] beyond
/// [`limits::MAX_MC_DRAWS`] or [`limits::MAX_CORRELATION_ENVELOPE`];
/// [`UncertaintyError::NonFinite`] when u(y) overflows.
pub fn monte_carlo<F>(
    inputs: &[InputDistribution],
    correlations: &[(usize, usize, f64)],
    model: F,
    cfg: &McConfig,
) -> Result<McResult, UncertaintyError>
where
    F: Fn(&[f64]) -> f64,
{
    monte_carlo_with_progress(inputs, correlations, model, cfg, |_| {})
}

/// As [`monte_carlo`], calling `progress(trials_so_far)` as the trials are drawn: after every
/// chunk of at most 16,384 trials (fewer for models of more than 256 inputs, see
/// [`limits::MAX_MC_BUFFER`]).
///
/// # Errors
/// As [`monte_carlo`].
pub fn monte_carlo_with_progress<F, P>(
    inputs: &[InputDistribution],
    correlations: &[(usize, usize, f64)],
    model: F,
    cfg: &McConfig,
    progress: P,
) -> Result<McResult, UncertaintyError>
where
    F: Fn(&[f64]) -> f64,
    P: FnMut(usize),
{
    let n = inputs.len();
    let mut x = vec![0.0; n];
    run(
        inputs,
        correlations,
        cfg,
        progress,
        |cols: &[f64], m: usize, out: &mut Vec<f64>| {
            for j in 0..m {
                for (i, xi) in x.iter_mut().enumerate() {
                    *xi = cols[i * m + j];
                }
                out.push(model(&x));
            }
        },
    )
}

/// Monte Carlo for the linear model y = Σ c_i x_i, evaluated a chunk of trials at a time, column
/// by column (the same sums, in the same order, as `x.iter().zip(c).map(|(x, c)| x * c).sum()`
/// per trial, so the results are those of [`monte_carlo`] with that closure, bit for bit).
pub(crate) fn monte_carlo_linear<P: FnMut(usize)>(
    inputs: &[InputDistribution],
    correlations: &[(usize, usize, f64)],
    coefficients: &[f64],
    cfg: &McConfig,
    progress: P,
) -> Result<McResult, UncertaintyError> {
    if coefficients.len() != inputs.len() {
        return Err(UncertaintyError::MonteCarlo {
            what: format!(
                "{} coefficients for {} inputs",
                coefficients.len(),
                inputs.len()
            ),
        });
    }
    run(
        inputs,
        correlations,
        cfg,
        progress,
        |cols: &[f64], m: usize, out: &mut Vec<f64>| {
            let start = out.len();
            let c0 = coefficients[0];
            out.extend(cols[..m].iter().map(|x| x * c0));
            let y = &mut out[start..];
            for (i, &ci) in coefficients.iter().enumerate().skip(1) {
                for (yj, x) in y.iter_mut().zip(&cols[i * m..(i + 1) * m]) {
                    *yj += x * ci;
                }
            }
        },
    )
}

/// The number of draws and correlation products per trial: the inputs, plus the off-diagonal
/// entries of the correlated group's Cholesky factor (its envelope). `Err` when the envelope is
/// beyond [`limits::MAX_CORRELATION_ENVELOPE`]. Also returns the group and its correlation
/// matrix (not yet factorised).
#[allow(clippy::type_complexity)]
fn correlated_group(
    n: usize,
    correlations: &[(usize, usize, f64)],
) -> Result<(Vec<usize>, Option<Envelope>, u64), UncertaintyError> {
    let mut slot = vec![usize::MAX; n];
    let mut group: Vec<usize> = Vec::new();
    for &(i, j, r) in correlations {
        if i >= n || j >= n || i == j || r.is_nan() || r.abs() > 1.0 {
            return Err(UncertaintyError::MonteCarlo {
                what: format!("bad correlation ({i}, {j}, {r}) for {n} inputs"),
            });
        }
        for k in [i, j] {
            if slot[k] == usize::MAX {
                slot[k] = 0;
                group.push(k);
            }
        }
    }
    if group.is_empty() {
        return Ok((group, None, n as u64));
    }
    group.sort_unstable();
    for (a, &k) in group.iter().enumerate() {
        slot[k] = a;
    }
    let pairs: Vec<(usize, usize, f64)> = correlations
        .iter()
        .map(|&(i, j, r)| (slot[i], slot[j], r))
        .collect();
    let g = group.len();
    let env = Envelope::correlation(g, &pairs, limits::MAX_CORRELATION_ENVELOPE).map_err(
        |entries| UncertaintyError::TooLarge {
            budget: None,
            what: "Monte Carlo: the correlation matrix's envelope (for each correlated input, the entries from its first correlated input to itself)".into(),
            found: entries as u64,
            limit: limits::MAX_CORRELATION_ENVELOPE as u64,
            hint: "; list correlated rows next to each other".into(),
        },
    )?;
    let work = n as u64 + (env.entries() - g) as u64;
    Ok((group, Some(env), work))
}

/// The most trials a run of these inputs may use: [`MAX_TRIALS`], and at most
/// [`limits::MAX_MC_DRAWS`] draws and correlation products in all.
///
/// # Errors
/// A bad correlation, or one beyond [`limits::MAX_CORRELATION_ENVELOPE`].
///
/// ```
/// use gonio_uncertainty::montecarlo::{InputDistribution, max_trials};
/// let inputs = vec![InputDistribution::Normal { mean: 0.0, sd: 1.0 }; 10_000];
/// assert_eq!(max_trials(&inputs, &[]).unwrap(), 200_000);
/// ```
pub fn max_trials(
    inputs: &[InputDistribution],
    correlations: &[(usize, usize, f64)],
) -> Result<usize, UncertaintyError> {
    let (_, _, work) = correlated_group(inputs.len(), correlations)?;
    Ok(MAX_TRIALS.min((limits::MAX_MC_DRAWS / work.max(1)) as usize))
}

/// The engine: draws chunks of trials and lets `eval(columns, m, values)` append the m model
/// values of each chunk.
fn run<P, E>(
    inputs: &[InputDistribution],
    correlations: &[(usize, usize, f64)],
    cfg: &McConfig,
    mut progress: P,
    mut eval: E,
) -> Result<McResult, UncertaintyError>
where
    P: FnMut(usize),
    E: FnMut(&[f64], usize, &mut Vec<f64>),
{
    let p = check_coverage(cfg.coverage)?;
    let n = inputs.len();
    if n == 0 {
        return Err(UncertaintyError::MonteCarlo {
            what: "no input quantities".into(),
        });
    }
    for (i, d) in inputs.iter().enumerate() {
        d.check(i)?;
    }
    let (group, chol, work) = correlated_group(n, correlations)?;
    let chol = match chol {
        Some(mut c) => {
            if c.cholesky().is_none() {
                return Err(UncertaintyError::NotPositiveDefinite {
                    context: "Monte Carlo inputs".into(),
                });
            }
            Some(c)
        }
        None => None,
    };
    let draw_limit = MAX_TRIALS.min((limits::MAX_MC_DRAWS / work.max(1)) as usize);
    let too_many = |trials: usize, what: &str| UncertaintyError::TooLarge {
        budget: None,
        what: format!(
            "Monte Carlo: {what} ({trials} trials × {work} draws and correlation products per trial, {n} inputs)"
        ),
        found: trials as u64 * work,
        limit: limits::MAX_MC_DRAWS,
        hint: format!("; use at most {draw_limit} trials, or fewer rows"),
    };
    let min_batch = ((1.0 / (1.0 - p)).ceil() as usize).max(2);
    let (batch, fixed_total, max_trials) = match cfg.trials {
        McTrials::Fixed(m) => {
            if m < min_batch {
                return Err(UncertaintyError::MonteCarlo {
                    what: format!(
                        "{m} trials are too few for a {p} coverage interval (need ≥ {min_batch})"
                    ),
                });
            }
            if m > MAX_TRIALS {
                return Err(UncertaintyError::MonteCarlo {
                    what: format!("{m} trials is more than the limit of {MAX_TRIALS}"),
                });
            }
            if m as u64 * work > limits::MAX_MC_DRAWS {
                return Err(too_many(m, "the draws of the trials asked for"));
            }
            (m.min(16_384), Some(m), m)
        }
        McTrials::Adaptive { max_trials } => {
            let b = ((100.0 / (1.0 - p)).ceil() as usize).max(10_000);
            let max_trials = max_trials.min(MAX_TRIALS);
            if 2 * b > max_trials {
                return Err(UncertaintyError::MonteCarlo {
                    what: format!(
                        "coverage {p} needs batches of {b} trials (100/(1 − p)); the limit of {max_trials} trials allows fewer than 2"
                    ),
                });
            }
            if (2 * b) as u64 * work > limits::MAX_MC_DRAWS {
                return Err(too_many(
                    2 * b,
                    "the first two batches of the adaptive procedure",
                ));
            }
            (b, None, max_trials.min(draw_limit))
        }
    };
    // Chunks of trials drawn at once: the whole batch unless the buffer of n columns would exceed
    // MAX_MC_BUFFER values.
    let chunk = batch.min((limits::MAX_MC_BUFFER / n).max(1));
    let mut sampler = Sampler {
        inputs,
        in_group: {
            let mut v = vec![false; n];
            group.iter().for_each(|&i| v[i] = true);
            v
        },
        z: vec![0.0; group.len()],
        group,
        chol,
        columns: Vec::new(),
        scratch: Scratch::default(),
        rng: ChaCha20Rng::seed_from_u64(cfg.seed),
    };
    let mut values: Vec<f64> = Vec::with_capacity(fixed_total.unwrap_or(4 * batch));
    let mut scratch: Vec<f64> = Vec::with_capacity(batch);
    // Per-batch statistics for the adaptive stop: mean, u, symmetric and shortest end points.
    let mut stats: Vec<[f64; 6]> = Vec::new();
    // (count, mean, sum of squared deviations) of all values so far.
    let mut run = (0.0f64, 0.0f64, 0.0f64);
    let mut converged = fixed_total.is_some();
    let mut batches = 0usize;
    loop {
        let todo = match fixed_total {
            Some(total) => (total - values.len()).min(batch),
            None => batch,
        };
        if todo == 0 {
            break;
        }
        let start = values.len();
        let mut done = 0;
        while done < todo {
            let m = chunk.min(todo - done);
            sampler.draw(m);
            let at = values.len();
            eval(&sampler.columns, m, &mut values);
            if let Some(k) = values[at..].iter().position(|v| !v.is_finite()) {
                return Err(UncertaintyError::MonteCarlo {
                    what: format!(
                        "trial {}: the measurement function returned {} (an input draw or the model overflowed)",
                        at + k + 1,
                        values[at + k]
                    ),
                });
            }
            done += m;
            progress(values.len());
        }
        batches += 1;
        if fixed_total.is_some() {
            continue;
        }
        scratch.clear();
        scratch.extend_from_slice(&values[start..]);
        let (m, s) = mean_sd(&scratch);
        let (sym, short) = intervals_of(&mut scratch, p);
        stats.push([m, s, sym.low, sym.high, short.low, short.high]);
        // Running mean and sum of squared deviations of all values (Chan et al.'s update).
        let nb = todo as f64;
        let n_all = run.0 + nb;
        let delta_mean = m - run.1;
        run.2 += s * s * (nb - 1.0) + delta_mean * delta_mean * run.0 * nb / n_all;
        run.1 += delta_mean * nb / n_all;
        run.0 = n_all;
        let h = stats.len();
        if h >= 2 {
            let u_all = (run.2 / (run.0 - 1.0)).sqrt();
            let delta = numerical_tolerance(u_all, cfg.ndig);
            let stable = (0..6).all(|c| {
                let col: Vec<f64> = stats.iter().map(|st| st[c]).collect();
                let (_, sd) = mean_sd(&col);
                2.0 * sd / (h as f64).sqrt() <= delta
            });
            if stable {
                converged = true;
                break;
            }
        }
        if values.len() + batch > max_trials {
            break;
        }
    }
    let (estimate, std_uncertainty) = mean_sd(&values);
    if !(estimate.is_finite() && std_uncertainty.is_finite()) {
        return Err(UncertaintyError::NonFinite {
            budget: String::new(),
            contribution: None,
            quantity: format!(
                "the Monte Carlo estimate y = {estimate:e} or its standard uncertainty u(y) = {std_uncertainty:e}"
            ),
        });
    }
    let (symmetric, shortest) = intervals_of(&mut values, p);
    Ok(McResult {
        estimate,
        std_uncertainty,
        coverage: p,
        symmetric,
        shortest,
        trials: values.len(),
        batches,
        converged,
        tolerance: numerical_tolerance(std_uncertainty, cfg.ndig),
        seed: cfg.seed,
    })
}

/// The GUM-vs-Monte-Carlo comparison of JCGM 101 §8.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Validation {
    /// GUM interval y ± U.
    pub gum: Interval,
    /// Monte Carlo probabilistically symmetric interval.
    pub monte_carlo: Interval,
    /// |y − U − y_low|.
    pub d_low: f64,
    /// |y + U − y_high|.
    pub d_high: f64,
    /// Numerical tolerance δ of the GUM u_c at `ndig` digits.
    pub tolerance: f64,
    /// Both differences within δ: the GUM result is validated and is the one to report;
    /// otherwise report the Monte Carlo result.
    pub passed: bool,
}

/// Compares the GUM interval y ± U with the Monte Carlo probabilistically symmetric interval
/// (JCGM 101 §8.2): validated when both end points differ by no more than δ, the numerical
/// tolerance of u_c at `ndig` significant digits.
///
/// ```
/// use gonio_uncertainty::montecarlo::{Interval, McResult, validate};
/// let mc = McResult { estimate: 0.0, std_uncertainty: 1.0, coverage: 0.95,
///     symmetric: Interval { low: -1.962, high: 1.958 }, shortest: Interval { low: -1.96, high: 1.96 },
///     trials: 100_000, batches: 10, converged: true, tolerance: 0.05, seed: 1 };
/// assert!(validate(0.0, 1.0, 1.96, &mc, 2).passed);
/// assert!(!validate(0.0, 1.0, 2.10, &mc, 2).passed);
/// ```
pub fn validate(y: f64, u_c: f64, expanded: f64, mc: &McResult, ndig: u32) -> Validation {
    let d_low = (y - expanded - mc.symmetric.low).abs();
    let d_high = (y + expanded - mc.symmetric.high).abs();
    let tolerance = numerical_tolerance(u_c, ndig);
    Validation {
        gum: Interval {
            low: y - expanded,
            high: y + expanded,
        },
        monte_carlo: mc.symmetric,
        d_low,
        d_high,
        tolerance,
        passed: d_low <= tolerance && d_high <= tolerance,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::student::coverage_factor;
    use gonio_core::special::normal_quantile;
    use rand_distr::StudentT;

    #[test]
    fn same_seed_same_bits_other_seed_differs() {
        let inputs = [
            InputDistribution::Normal { mean: 1.0, sd: 0.1 },
            InputDistribution::Rectangular {
                mean: 0.0,
                half_width: 0.2,
            },
            InputDistribution::StudentT {
                mean: 0.0,
                scale: 0.05,
                nu: 5.0,
            },
        ];
        let f = |x: &[f64]| x[0] * x[0] + x[1] - x[2];
        let cfg = McConfig::default();
        let a = monte_carlo(&inputs, &[], f, &cfg).unwrap();
        let b = monte_carlo(&inputs, &[], f, &cfg).unwrap();
        assert_eq!(a, b);
        let c = monte_carlo(&inputs, &[], f, &McConfig { seed: 2, ..cfg }).unwrap();
        assert_ne!(a.estimate.to_bits(), c.estimate.to_bits());
    }

    #[test]
    fn input_distributions_have_their_moments() {
        // Each distribution alone through Y = X: the standard deviation of 10⁶ draws must match the
        // GUM u within 4 standard errors (se(s) ≈ s·√((κ − 1)/(4M)), κ ≤ 9 here for t₅).
        let m = 1_000_000;
        let cases = [
            (InputDistribution::Normal { mean: 2.0, sd: 0.5 }, 0.5, 3.0),
            (
                InputDistribution::Rectangular {
                    mean: 2.0,
                    half_width: 1.0,
                },
                1.0 / 3f64.sqrt(),
                1.8,
            ),
            (
                InputDistribution::Triangular {
                    mean: 2.0,
                    half_width: 1.0,
                },
                1.0 / 6f64.sqrt(),
                2.4,
            ),
            (
                InputDistribution::Arcsine {
                    mean: 2.0,
                    half_width: 1.0,
                },
                1.0 / 2f64.sqrt(),
                1.5,
            ),
            (
                InputDistribution::StudentT {
                    mean: 2.0,
                    scale: 1.0,
                    nu: 10.0,
                },
                (10.0f64 / 8.0).sqrt(),
                4.0,
            ),
        ];
        for (d, u, kurtosis) in cases {
            let r = monte_carlo(
                &[d],
                &[],
                |x: &[f64]| x[0],
                &McConfig {
                    trials: McTrials::Fixed(m),
                    ..McConfig::default()
                },
            )
            .unwrap();
            let se_s = u * ((kurtosis - 1.0) / (4.0 * m as f64)).sqrt();
            assert!((r.std_uncertainty - u).abs() < 4.0 * se_s, "{d:?}: {r:?}");
            assert!(
                (r.estimate - 2.0).abs() < 4.0 * u / (m as f64).sqrt(),
                "{d:?}"
            );
        }
    }

    /// JCGM 101 §9.2.2: Y = X1 + X2 + X3 + X4, Xi ~ N(0, 1): GUM and Monte Carlo agree
    /// (the GUM interval ±1.96·2 is exact here), so the validation must pass.
    #[test]
    fn linear_normal_model_validates() {
        let inputs = [InputDistribution::Normal { mean: 0.0, sd: 1.0 }; 4];
        let r = monte_carlo(
            &inputs,
            &[],
            |x: &[f64]| x.iter().sum(),
            &McConfig::default(),
        )
        .unwrap();
        assert!(r.converged);
        let k = coverage_factor(0.95, f64::INFINITY);
        let v = validate(0.0, 2.0, 2.0 * k, &r, 2);
        assert!(v.passed, "{v:?} {r:?}");
    }

    /// A ten-input linear model of mixed distributions (rectangular, triangular, arcsine, normal)
    /// with no dominant term: the output is close to normal and the GUM (ν = ∞) validates at
    /// ndig = 1 (JCGM 101 §8: a coarser tolerance accepts the small non-normality).
    #[test]
    fn linear_mixed_model_validates_at_one_digit() {
        let mut inputs = Vec::new();
        let mut var = 0.0;
        for i in 0..10 {
            let a = 1.0 + 0.1 * i as f64;
            let d = match i % 4 {
                0 => InputDistribution::Rectangular {
                    mean: 0.0,
                    half_width: a,
                },
                1 => InputDistribution::Triangular {
                    mean: 0.0,
                    half_width: a,
                },
                2 => InputDistribution::Arcsine {
                    mean: 0.0,
                    half_width: a,
                },
                _ => InputDistribution::Normal { mean: 0.0, sd: a },
            };
            var += d.std_uncertainty().powi(2);
            inputs.push(d);
        }
        let r = monte_carlo(
            &inputs,
            &[],
            |x: &[f64]| x.iter().sum(),
            &McConfig::default(),
        )
        .unwrap();
        let u = var.sqrt();
        let v = validate(0.0, u, 1.959964 * u, &r, 1);
        assert!(v.passed, "{v:?}");
    }

    /// A non-linear model where the GUM must fail: Y = exp(X), X ~ N(0, 0.5²). The GUM gives
    /// y = 1, u = 0.5 and a symmetric interval 1 ± 0.98; the true 95 % interval of the log-normal
    /// is [e^(−0.98), e^(0.98)] = [0.375, 2.66]. Monte Carlo must find the true interval (within its
    /// tolerance) and the validation must fail.
    #[test]
    fn nonlinear_model_fails_validation_and_mc_finds_the_truth() {
        let s = 0.5;
        let inputs = [InputDistribution::Normal { mean: 0.0, sd: s }];
        let r = monte_carlo(&inputs, &[], |x: &[f64]| x[0].exp(), &McConfig::default()).unwrap();
        assert!(r.converged);
        let z = normal_quantile(0.975);
        let (lo, hi) = ((-z * s).exp(), (z * s).exp());
        // Tolerance: 4 times the stopping criterion's standard deviation of an end point (δ/2).
        assert!((r.symmetric.low - lo).abs() < 2.0 * r.tolerance, "{r:?}");
        assert!((r.symmetric.high - hi).abs() < 2.0 * r.tolerance, "{r:?}");
        // Log-normal moments: mean e^(s²/2), sd mean·√(e^(s²) − 1).
        let mean = (s * s / 2.0).exp();
        assert!((r.estimate - mean).abs() < 2.0 * r.tolerance);
        assert!(
            (r.std_uncertainty - mean * ((s * s).exp() - 1.0).sqrt()).abs() < 2.0 * r.tolerance
        );
        // The shortest interval of a right-skewed output lies left of the symmetric one.
        assert!(r.shortest.low < r.symmetric.low && r.shortest.high < r.symmetric.high);
        assert!(r.shortest.high - r.shortest.low < r.symmetric.high - r.symmetric.low);
        let (y, c, gum) = crate::budget::gum_for_model(
            |x: &[f64]| x[0].exp(),
            &[0.0],
            &[s],
            &[f64::INFINITY],
            0.95,
        )
        .unwrap();
        assert!((y - 1.0).abs() < 1e-15 && (c[0] - 1.0).abs() < 1e-8);
        assert!((gum.expanded - z * s).abs() < 1e-8);
        let v = validate(y, gum.u_c, gum.expanded, &r, 2);
        // The end points differ by |1 − zs − e^(−zs)| = 0.355 and |1 + zs − e^(zs)| = 0.684, far
        // beyond δ = 0.005.
        assert!(!v.passed, "{v:?}");
        assert!(
            (v.d_low - (1.0 - z * s - lo).abs()).abs() < 2.0 * r.tolerance,
            "{v:?}"
        );
        assert!(
            (v.d_high - (1.0 + z * s - hi).abs()).abs() < 2.0 * r.tolerance,
            "{v:?}"
        );
    }

    #[test]
    fn correlated_inputs_follow_their_correlation() {
        let inputs = [
            InputDistribution::Normal { mean: 0.0, sd: 3.0 },
            InputDistribution::Normal { mean: 0.0, sd: 4.0 },
        ];
        let r = monte_carlo(
            &inputs,
            &[(0, 1, 0.5)],
            |x: &[f64]| x[0] + x[1],
            &McConfig::default(),
        )
        .unwrap();
        // u² = 9 + 16 + 2·0.5·12 = 37.
        let u = 37f64.sqrt();
        assert!((r.std_uncertainty - u).abs() < 2.0 * r.tolerance, "{r:?}");
        assert!(matches!(
            monte_carlo(
                &inputs,
                &[(0, 1, 1.5)],
                |x: &[f64]| x[0],
                &McConfig::default()
            ),
            Err(UncertaintyError::MonteCarlo { .. })
        ));
    }

    /// The arcsine draw's sine agrees with the C library's sin(2πr) within 2·10⁻¹⁶ over a fine
    /// grid and at the end points, and is odd about r = ½ as sin(2πr) is.
    #[test]
    fn sin_two_pi_is_sin() {
        let mut worst = 0.0f64;
        for k in 0..=(1 << 20) {
            let r = k as f64 / (1u64 << 20) as f64 * (1.0 - f64::EPSILON / 2.0);
            let d = (sin_two_pi(r) - (std::f64::consts::TAU * r).sin()).abs();
            worst = worst.max(d);
        }
        // The reference itself carries the rounding of 2π·r (up to 4.4e-16 · cos).
        assert!(worst < 1e-15, "{worst:e}");
        for (r, s) in [(0.25, 1.0), (0.75, -1.0), (0.5, 0.0), (0.0, 0.0)] {
            assert!((sin_two_pi(r) - s).abs() < 2e-16, "{r}");
        }
        for k in 1..2048 {
            let r = k as f64 / 2048.0;
            assert_eq!(sin_two_pi(r), -sin_two_pi(1.0 - r), "{r}");
        }
    }

    /// Words drawn in one block and turned into values give what one draw at a time gives.
    #[test]
    fn block_words_are_the_draw_by_draw_stream() {
        let mut a = ChaCha20Rng::seed_from_u64(7);
        let mut b = a.clone();
        let mut scratch = Scratch::default();
        let mut out = [0.0; 37];
        // An odd number of 32-bit words first, so that the blocks are not aligned.
        let _: u32 = a.random();
        let _: u32 = b.random();
        InputDistribution::Triangular {
            mean: 1.0,
            half_width: 2.0,
        }
        .fill(&mut a, &mut scratch, &mut out);
        for v in out {
            let s = b.random::<f64>() + b.random::<f64>();
            assert_eq!(v.to_bits(), (1.0 + 2.0 * (s - 1.0)).to_bits());
        }
        assert_eq!(a.random::<u64>(), b.random::<u64>());
        // The t in two passes is rand_distr's StudentT, draw for draw.
        for nu in [1.0, 2.5, 5.0, 30.0] {
            let t = StudentT::new(nu).unwrap();
            InputDistribution::StudentT {
                mean: 0.5,
                scale: 0.25,
                nu,
            }
            .fill(&mut a, &mut scratch, &mut out);
            for v in out {
                assert_eq!(
                    v.to_bits(),
                    (0.5 + 0.25 * t.sample(&mut b)).to_bits(),
                    "ν = {nu}"
                );
            }
        }
        assert_eq!(a.random::<u64>(), b.random::<u64>());
    }

    #[test]
    fn interval_indices_follow_jcgm_101() {
        // M = 10⁴, p = 0.95: q = 9500, r = 250 (1-based).
        assert_eq!(interval_indices(10_000, 0.95), (9500, 250));
        // M = 10001: pM = 9500.95 → q = 9501; M − q = 500 → r = 250.
        assert_eq!(interval_indices(10_001, 0.95), (9501, 250));
        let v: Vec<f64> = (1..=100).map(f64::from).collect();
        let (s, sh) = intervals(&v, 0.9);
        assert_eq!((s.low, s.high), (5.0, 95.0));
        assert_eq!(sh.high - sh.low, 90.0);
    }

    #[test]
    fn impractical_runs_are_errors_not_aborts() {
        let inputs = [InputDistribution::Normal { mean: 0.0, sd: 1.0 }];
        let f = |x: &[f64]| x[0];
        let too_many = McConfig {
            trials: McTrials::Fixed(MAX_TRIALS + 1),
            ..McConfig::default()
        };
        assert!(monte_carlo(&inputs, &[], f, &too_many).is_err());
        let too_close = McConfig {
            coverage: 1.0 - 1e-9,
            ..McConfig::default()
        };
        assert!(monte_carlo(&inputs, &[], f, &too_close).is_err());
        let too_few = McConfig {
            trials: McTrials::Fixed(10),
            ..McConfig::default()
        };
        assert!(monte_carlo(&inputs, &[], f, &too_few).is_err());
    }

    #[test]
    fn bad_model_value_is_an_error() {
        let inputs = [InputDistribution::Normal { mean: 0.0, sd: 1.0 }];
        let e = monte_carlo(&inputs, &[], |x: &[f64]| x[0].ln(), &McConfig::default());
        assert!(matches!(e, Err(UncertaintyError::MonteCarlo { .. })));
    }
}
