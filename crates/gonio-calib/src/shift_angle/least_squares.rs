//! The joint least-squares estimator of the shift-angle method (the project's default).
//!
//! Reparametrisation. With B(m) = β_1 + … + β_m (B(0) = B(N) = 0 because Σβ = 0), the pitch sum
//! is C(j, i) = B(n) − B(j−1) where n = j+i−1 wrapped to 1..N is the face at the autocollimator.
//! So every reading is
//!
//! ```text
//! ε = α_s(i) + γ_n + V_(s,j),     γ_m = B(m) (γ_N = 0),   V_(s,j) = U_(s,j) − B(j−1)
//! ```
//!
//! a three-way additive layout: per shift, α and V form a two-way layout (steps × runs); γ is
//! shared by all shifts. The normal matrix is therefore block-arrow shaped:
//!
//! ```text
//! ⎡A_1         B_1⎤   per shift s: x_s = (α_s, V_s) with the first run's V fixed at 0 (a gauge)
//! ⎢    ⋱       ⋮  ⎥   shared:      γ_1 … γ_(N−1)
//! ⎢        A_S B_S⎥
//! ⎣B_1ᵀ …  B_Sᵀ D ⎦
//! ```
//!
//! The shared unknowns come from the Schur complement S = D − Σ B_sᵀ A_s⁻¹ B_s (size N−1), D
//! diagonal. The gauges are then moved to the paper's conventions (Σα = 0 per shift, Σβ = 0) by
//! a linear map applied to the estimates and to their covariance, which is exact: both gauges fix
//! only directions the data cannot see.
//!
//! Inside A_s the two-way layout is kept: the α–α block D_α and the V–V block D_V are diagonal
//! (reading counts); only the α–V coupling C (readings of step i in run v) is a matrix. So α is
//! eliminated analytically and only the V's (R ≤ N−1 free runs, none for a shift read in one run)
//! are factorised, never A_s itself (with B_s = (B_α; B_V), r_s = (r_α; r_V)):
//!
//! ```text
//! G = D_α⁻¹C,   K = D_V − CᵀG (R × R, Cholesky-checked, inverted),   F = B_V − GᵀB_α
//! W_V = K⁻¹F,   W_α = D_α⁻¹B_α − G·W_V          (W_s = A_s⁻¹B_s)
//! B_sᵀA_s⁻¹B_s = B_αᵀD_α⁻¹B_α + FᵀW_V
//! (A_s⁻¹)_αα = D_α⁻¹ + G K⁻¹Gᵀ,  (A_s⁻¹)_αV = −G K⁻¹,  (A_s⁻¹)_VV = K⁻¹
//! V = K⁻¹(r_V − Gᵀr_α) − W_V γ,   α = D_α⁻¹(r_α − B_α γ) − G·V
//! ```
//!
//! Covariance (in units of σ²): Cov(γ) = S⁻¹, Cov(x_s, x_t) = δ_st·A_s⁻¹ + W_s S⁻¹ W_tᵀ and
//! Cov(x_s, γ) = −W_s S⁻¹. Only what is reported is formed: the diagonal and row sums of
//! Cov(α_s) (for the centred u(α)), the setup errors' variances from rows of W_V, W_V S⁻¹ and
//! K⁻¹, and the N × N blocks only when [`CovarianceLevel::Full`] asks for them.
//!
//! Cost, per shift with R free runs: O(N²R + NR² + R³) for the reduction (nothing cubic for a
//! one-run shift) plus O(N³) products with S⁻¹ (blocked matrix products); once, O(N³) for S.
//! Memory: O(N²) per shift at a time, W_V (R × N) kept per shift between the two passes. A
//! 1,000-face polygon at 10 shifts (full matrix at the first, 1,009,000 readings) solves in about
//! a second where the dense 2N × 2N factorisations took 15 s.

use super::data::Obs;
use super::result::{max_listed_order, residual_stats};
use super::{
    Calibration, CovarianceLevel, FullCovariance, Method, Options, ReadingSet, SetupError,
    ShiftAngleError, ShiftResult, undetectable_orders,
};
use gonio_core::closure::wrap1;
use nalgebra::{DMatrix, DVector};

/// Relative size below which a Cholesky pivot counts as zero (rank deficiency).
const PIVOT_TOL: f64 = 1e-10;

/// Per-shift layout of the local unknowns.
pub(crate) struct ShiftLayout {
    /// Start faces (0-based) measured at this shift, ascending.
    pub(crate) runs: Vec<usize>,
    /// For each face j (0-based): local index of V_(s,j), None for the gauge run or no run.
    pub(crate) v_index: Vec<Option<usize>>,
    /// Number of local unknowns: N α's + the free V's.
    pub(crate) len: usize,
}

/// The local unknowns of every shift: α at its N steps, then one V per run. With
/// `gauge_first_run` the first run's V is fixed at 0 (α absorbs the shift's constant, which the
/// polygon alone cannot see); without it every run's V is free (for a solver that ties α to
/// another instrument, which sees that constant).
pub(crate) fn layouts(set: &ReadingSet, gauge_first_run: bool) -> Vec<ShiftLayout> {
    let n = set.faces();
    let skip = usize::from(gauge_first_run);
    (0..set.shifts_deg().len())
        .map(|s| {
            let runs: Vec<usize> = set.runs(s).into_iter().map(|j| j - 1).collect();
            let mut v_index = vec![None; n];
            for (r, &j) in runs.iter().enumerate().skip(skip) {
                v_index[j] = Some(n + r - skip);
            }
            ShiftLayout {
                len: n + runs.len() - skip,
                runs,
                v_index,
            }
        })
        .collect()
}

/// The γ index (0-based, in 0..N−1) of face `face1` (1-based), None for face N (γ_N = 0).
#[inline]
pub(crate) fn gamma_index(face1: usize, n: usize) -> Option<usize> {
    (face1 < n).then(|| face1 - 1)
}

/// The γ index of reading `o`'s face at the autocollimator (face i + j + 1 in the layout's
/// 0-based step and start face, wrapped to 1..N), None for face N.
#[inline]
fn gamma_of(o: &Obs, n: usize) -> Option<usize> {
    gamma_index(wrap1((o.i + o.j + 1) as i64, n), n)
}

/// B(m) from the γ vector: B(0) = B(N) = 0.
#[inline]
pub(crate) fn big_b(gamma: &DVector<f64>, m: usize, n: usize) -> f64 {
    if m == 0 || m == n { 0.0 } else { gamma[m - 1] }
}

/// The normal equations in block-arrow form (unit weight per reading).
pub(crate) struct Normal {
    /// Per shift: the local block A_s (α_s, V_s).
    pub(crate) a: Vec<DMatrix<f64>>,
    /// Per shift: the coupling B_s of the local unknowns to γ.
    pub(crate) b: Vec<DMatrix<f64>>,
    /// Per shift: the local right-hand side.
    pub(crate) rhs_local: Vec<DVector<f64>>,
    /// The γ block D.
    pub(crate) d: DMatrix<f64>,
    /// The γ right-hand side.
    pub(crate) rhs_shared: DVector<f64>,
}

/// Accumulates the normal equations of all readings for the given layouts.
pub(crate) fn accumulate(set: &ReadingSet, lay: &[ShiftLayout]) -> Normal {
    let n = set.faces();
    let g = n - 1;
    let mut a: Vec<DMatrix<f64>> = lay.iter().map(|l| DMatrix::zeros(l.len, l.len)).collect();
    let mut b: Vec<DMatrix<f64>> = lay.iter().map(|l| DMatrix::zeros(l.len, g)).collect();
    let mut rhs_local: Vec<DVector<f64>> = lay.iter().map(|l| DVector::zeros(l.len)).collect();
    let mut d = DMatrix::zeros(g, g);
    let mut rhs_shared = DVector::zeros(g);
    for o in &set.obs {
        let (s, i) = (o.s, o.i);
        let v = lay[s].v_index[o.j];
        let gi = gamma_of(o, n);
        let am = &mut a[s];
        am[(i, i)] += 1.0;
        rhs_local[s][i] += o.value;
        if let Some(v) = v {
            am[(v, v)] += 1.0;
            am[(i, v)] += 1.0;
            am[(v, i)] += 1.0;
            rhs_local[s][v] += o.value;
        }
        if let Some(gi) = gi {
            d[(gi, gi)] += 1.0;
            rhs_shared[gi] += o.value;
            b[s][(i, gi)] += 1.0;
            if let Some(v) = v {
                b[s][(v, gi)] += 1.0;
            }
        }
    }
    Normal {
        a,
        b,
        rhs_local,
        d,
        rhs_shared,
    }
}

/// Cholesky factorisation with a relative pivot check; `None` when (numerically) singular.
pub(crate) fn cholesky(m: DMatrix<f64>) -> Option<nalgebra::Cholesky<f64, nalgebra::Dyn>> {
    let max_diag = m.diagonal().iter().fold(0.0f64, |a, &b| a.max(b.abs()));
    let c = m.cholesky()?;
    let l = c.l_dirty();
    let ok = (0..l.nrows()).all(|i| l[(i, i)] * l[(i, i)] > PIVOT_TOL * max_diag.max(1e-300));
    ok.then_some(c)
}

/// The normal-equation blocks of one shift, with its two-way layout kept apart: the α–α and
/// V–V blocks of A_s are diagonal (reading counts), only the α–V coupling C is a matrix.
struct ShiftBlocks {
    /// Readings per step i (the diagonal α–α block).
    d_alpha: Vec<f64>,
    /// Readings per free run (the diagonal V–V block).
    d_v: Vec<f64>,
    /// The α–V coupling C (N × R): readings of step i in run v.
    c: DMatrix<f64>,
    /// The α–γ coupling (N × (N−1)).
    b_alpha: DMatrix<f64>,
    /// The V–γ coupling (R × (N−1)).
    b_v: DMatrix<f64>,
    /// Right-hand side of the α's.
    r_alpha: DVector<f64>,
    /// Right-hand side of the V's.
    r_v: DVector<f64>,
}

impl ShiftBlocks {
    /// Accumulates the blocks of the readings `obs` (indices into `set.obs`) of one shift.
    fn new(set: &ReadingSet, lay: &ShiftLayout, obs: &[usize]) -> Self {
        let n = set.faces();
        let g = n - 1;
        let r = lay.len - n;
        let mut b = ShiftBlocks {
            d_alpha: vec![0.0; n],
            d_v: vec![0.0; r],
            c: DMatrix::zeros(n, r),
            b_alpha: DMatrix::zeros(n, g),
            b_v: DMatrix::zeros(r, g),
            r_alpha: DVector::zeros(n),
            r_v: DVector::zeros(r),
        };
        for &k in obs {
            let o = &set.obs[k];
            let i = o.i;
            let v = lay.v_index[o.j].map(|x| x - n);
            let gi = gamma_of(o, n);
            b.d_alpha[i] += 1.0;
            b.r_alpha[i] += o.value;
            if let Some(v) = v {
                b.d_v[v] += 1.0;
                b.c[(i, v)] += 1.0;
                b.r_v[v] += o.value;
            }
            if let Some(gi) = gi {
                b.b_alpha[(i, gi)] += 1.0;
                if let Some(v) = v {
                    b.b_v[(v, gi)] += 1.0;
                }
            }
        }
        b
    }

    /// Whether every step was read (else A_s is singular: an α without readings).
    fn steps_complete(&self) -> bool {
        self.d_alpha.iter().all(|&d| d > 0.0)
    }

    /// D_α⁻¹·`m`: `m`'s row i divided by the readings of step i.
    fn over_d_alpha(&self, m: &DMatrix<f64>) -> DMatrix<f64> {
        let mut out = m.clone();
        for (i, &d) in self.d_alpha.iter().enumerate() {
            out.row_mut(i).scale_mut(1.0 / d);
        }
        out
    }

    /// G = D_α⁻¹·C (N × R).
    fn g(&self) -> DMatrix<f64> {
        self.over_d_alpha(&self.c)
    }

    /// P = D_α⁻¹·B_α (N × (N−1)).
    fn p(&self) -> DMatrix<f64> {
        self.over_d_alpha(&self.b_alpha)
    }
}

/// The nonzeros (column, value) of every row of `m`, when at most one entry in 16 is nonzero
/// (else `None`: a dense product is then as cheap).
fn sparse_rows(m: &DMatrix<f64>) -> Option<Vec<Vec<(usize, f64)>>> {
    let nnz = m.iter().filter(|&&v| v != 0.0).count();
    if nnz * 16 > m.len() {
        return None;
    }
    let mut rows = vec![Vec::new(); m.nrows()];
    for (c, col) in m.column_iter().enumerate() {
        for (i, &v) in col.iter().enumerate() {
            if v != 0.0 {
                rows[i].push((c, v));
            }
        }
    }
    Some(rows)
}

/// What the first pass keeps of one shift's reduced system (V after eliminating α).
struct Reduced {
    /// K⁻¹, K = D_V − Cᵀ D_α⁻¹ C (R × R; 0 × 0 without free runs).
    k_inv: DMatrix<f64>,
    /// W_V = K⁻¹ F with F = B_V − Gᵀ B_α (R × (N−1)): the V rows of A_s⁻¹ B_s.
    w_v: DMatrix<f64>,
    /// K⁻¹ (r_V − Gᵀ r_α): the V rows of A_s⁻¹ b_s.
    wv_v: DVector<f64>,
}

/// Solves the joint least-squares problem.
pub(crate) fn solve(set: &ReadingSet, opts: &Options) -> Result<Calibration, ShiftAngleError> {
    let n = set.faces();
    let g = n - 1;
    let ns = set.shifts_deg().len();
    let lay = layouts(set, true);
    let mut by_shift: Vec<Vec<usize>> = vec![Vec::new(); ns];
    // The γ block D is diagonal (readings per face at the autocollimator).
    let mut schur = DMatrix::zeros(g, g);
    let mut rhs = DVector::zeros(g);
    for (k, o) in set.obs.iter().enumerate() {
        by_shift[o.s].push(k);
        if let Some(gi) = gamma_of(o, n) {
            schur[(gi, gi)] += 1.0;
            rhs[gi] += o.value;
        }
    }

    // Pass 1, per shift: eliminate the diagonal α block, factorise the reduced V system K and
    // subtract the shift's term Bᵀ A⁻¹ B = B_αᵀ D_α⁻¹ B_α + Fᵀ K⁻¹ F from the Schur complement.
    let mut reduced = Vec::with_capacity(ns);
    for s in 0..ns {
        let blk = ShiftBlocks::new(set, &lay[s], &by_shift[s]);
        if !blk.steps_complete() {
            return Err(diagnose(set, &lay));
        }
        // B_αᵀ D_α⁻¹ B_α: a sum of outer products when B_α is sparse (a shift read in few runs
        // reads each step at few faces), else one blocked product.
        match sparse_rows(&blk.b_alpha) {
            Some(rows) => {
                for (i, row) in rows.iter().enumerate() {
                    let w = 1.0 / blk.d_alpha[i];
                    for &(a, va) in row {
                        for &(b, vb) in row {
                            schur[(a, b)] -= va * vb * w;
                        }
                    }
                }
            }
            None => schur.gemm(-1.0, &blk.b_alpha.transpose(), &blk.p(), 1.0),
        }
        let ra_d = DVector::from_iterator(n, (0..n).map(|i| blk.r_alpha[i] / blk.d_alpha[i]));
        rhs.gemv_tr(-1.0, &blk.b_alpha, &ra_d, 1.0);
        let r = blk.d_v.len();
        if r == 0 {
            reduced.push(Reduced {
                k_inv: DMatrix::zeros(0, 0),
                w_v: DMatrix::zeros(0, g),
                wv_v: DVector::zeros(0),
            });
            continue;
        }
        let gm = blk.g();
        let mut k = DMatrix::from_diagonal(&DVector::from_column_slice(&blk.d_v));
        k.gemm(-1.0, &blk.c.transpose(), &gm, 1.0);
        // (nalgebra's gemm_tr is a dot-product loop; the explicit transpose reaches the
        // blocked kernel.)
        let mut f = blk.b_v.clone();
        f.gemm(-1.0, &gm.transpose(), &blk.b_alpha, 1.0);
        let mut rv = blk.r_v.clone();
        rv.gemv_tr(-1.0, &gm, &blk.r_alpha, 1.0);
        let Some(ch) = cholesky(k) else {
            return Err(diagnose(set, &lay));
        };
        // K⁻¹ once (pass 2 needs it too): W_V = K⁻¹F and Fᵀ K⁻¹ F = Fᵀ W_V are then blocked
        // products (nalgebra's triangular solves go one column at a time).
        let k_inv = ch.inverse();
        let w_v = &k_inv * &f;
        let wv_v = &k_inv * &rv;
        schur.gemm(-1.0, &f.transpose(), &w_v, 1.0);
        rhs.gemv_tr(-1.0, &f, &wv_v, 1.0);
        reduced.push(Reduced { k_inv, w_v, wv_v });
    }
    let Some(sch) = cholesky(schur) else {
        return Err(diagnose(set, &lay));
    };
    let gamma = sch.solve(&rhs);
    let sg = sch.inverse();

    // Pass 2, per shift: the local estimates x_s = A_s⁻¹(b_s − B_s γ) from the reduced system,
    // and the pieces of their covariance.
    let inv_n = 1.0 / n as f64;
    let mut alpha = Vec::with_capacity(ns);
    let mut means = Vec::with_capacity(ns);
    let mut x_all = Vec::with_capacity(ns);
    for s in 0..ns {
        let blk = ShiftBlocks::new(set, &lay[s], &by_shift[s]);
        let red = &reduced[s];
        let gm = blk.g();
        // V = K⁻¹(r_V − Gᵀr_α) − W_V γ;  α = D_α⁻¹(r_α − B_α γ) − G V.
        let mut v = red.wv_v.clone();
        v.gemv(-1.0, &red.w_v, &gamma, 1.0);
        let mut a = blk.r_alpha.clone();
        a.gemv(-1.0, &blk.b_alpha, &gamma, 1.0);
        for i in 0..n {
            a[i] /= blk.d_alpha[i];
        }
        a.gemv(-1.0, &gm, &v, 1.0);
        let m = a.sum() * inv_n;
        alpha.push((0..n).map(|i| a[i] - m).collect::<Vec<f64>>());
        means.push(m);
        let mut x = DVector::zeros(lay[s].len);
        x.rows_mut(0, n).copy_from(&a);
        x.rows_mut(n, v.len()).copy_from(&v);
        x_all.push(x);
    }
    let beta: Vec<f64> = (1..=n)
        .map(|k| big_b(&gamma, k, n) - big_b(&gamma, k - 1, n))
        .collect();
    let mut setup_grid = vec![vec![None; n]; ns];
    let mut setup_vals = Vec::new();
    for s in 0..ns {
        for &j in &lay[s].runs {
            let v = lay[s].v_index[j].map_or(0.0, |k| x_all[s][k]);
            let u = v + means[s] + big_b(&gamma, j, n);
            setup_grid[s][j] = Some(u);
            setup_vals.push((s, j, u));
        }
    }

    let free: usize = lay.iter().map(|l| l.len).sum::<usize>() + g;
    let residuals = residual_stats(set, &alpha, &beta, &setup_grid, free, opts.sigma_arcsec);
    let sigma = opts.sigma_arcsec.unwrap_or(residuals.sigma_hat_arcsec);
    let s2 = sigma * sigma;

    // Uncertainties.
    let sg_padded = |p: usize, q: usize| -> f64 {
        // Cov(B(p), B(q)) with B(0) = B(N) = 0.
        if p == 0 || p == n || q == 0 || q == n {
            0.0
        } else {
            sg[(p - 1, q - 1)]
        }
    };
    let u_beta: Vec<f64> = (1..=n)
        .map(|k| {
            (s2 * (sg_padded(k, k) + sg_padded(k - 1, k - 1) - 2.0 * sg_padded(k, k - 1))).sqrt()
        })
        .collect();

    let full = opts.covariance == CovarianceLevel::Full;
    let mut shifts = Vec::with_capacity(ns);
    let mut setup = Vec::with_capacity(setup_vals.len());
    // Per shift, for the full covariance: P·W_α and P·(A⁻¹)_αα·P.
    let mut y_blocks = Vec::with_capacity(if full { ns } else { 0 });
    let mut ai_blocks = Vec::with_capacity(if full { ns } else { 0 });
    for s in 0..ns {
        let blk = ShiftBlocks::new(set, &lay[s], &by_shift[s]);
        let gm = blk.g();
        let red = &reduced[s];
        let r = blk.d_v.len();
        // K⁻¹ and G K⁻¹: (A⁻¹)_αα = D_α⁻¹ + G K⁻¹ Gᵀ, (A⁻¹)_αV = −G K⁻¹, (A⁻¹)_VV = K⁻¹.
        let k_inv = &red.k_inv;
        let gk = &gm * k_inv;
        // W_α = D_α⁻¹ B_α − G W_V (the α rows of A_s⁻¹ B_s), and W S⁻¹ (T).
        let mut w_a = blk.p();
        w_a.gemm(-1.0, &gm, &red.w_v, 1.0);
        let t_v = &red.w_v * &sg;
        // Cov(α_s)/σ² = (A⁻¹)_αα + W_α S⁻¹ W_αᵀ: its diagonal and row sums, for the
        // diagonal of the centred covariance P·Cov·P. Without free runs W_α = D_α⁻¹B_α, whose
        // rows are sparse when the shift is read in few runs: then each diagonal term is a
        // short double sum instead of a row of the product W_α S⁻¹.
        let ones_g = gm.row_sum().transpose(); // Gᵀ1
        let wa_1 = w_a.row_sum().transpose(); // W_αᵀ1
        let mut row_sums = &gk * &ones_g;
        row_sums.gemv(1.0, &w_a, &(&sg * &wa_1), 1.0);
        let sparse = if r == 0 {
            sparse_rows(&blk.b_alpha)
        } else {
            None
        };
        let w_s_w: Vec<f64> = match &sparse {
            Some(rows) => rows
                .iter()
                .enumerate()
                .map(|(i, row)| {
                    let quad: f64 = row
                        .iter()
                        .map(|&(a, va)| {
                            va * row.iter().map(|&(b, vb)| vb * sg[(a, b)]).sum::<f64>()
                        })
                        .sum();
                    quad / (blk.d_alpha[i] * blk.d_alpha[i])
                })
                .collect(),
            None => {
                let t_a = &w_a * &sg;
                (0..n).map(|i| t_a.row(i).dot(&w_a.row(i))).collect()
            }
        };
        let diag: Vec<f64> = (0..n)
            .map(|i| 1.0 / blk.d_alpha[i] + gk.row(i).dot(&gm.row(i)) + w_s_w[i])
            .collect();
        for i in 0..n {
            row_sums[i] += 1.0 / blk.d_alpha[i];
        }
        let grand = row_sums.sum() * inv_n * inv_n;
        let u_alpha = (0..n)
            .map(|i| (s2 * (diag[i] - 2.0 * row_sums[i] * inv_n + grand).max(0.0)).sqrt())
            .collect();
        let shift_deg = set.shifts_deg()[s];
        shifts.push(ShiftResult {
            shift_deg,
            angles_deg: (1..=n).map(|i| set.angle_deg(s, i)).collect(),
            alpha_arcsec: alpha[s].clone(),
            u_alpha_arcsec: u_alpha,
        });
        // Setup errors: U = V_j + mean(α_s) + B(j) = tᵀx_s + B(j) with t = m + e_k (m: 1/N on
        // the α block, e_k: run j's V). x_s = w − W·γ, so
        // Var(U) = tᵀA⁻¹t + qᵀS⁻¹q − 2(S⁻¹q)_(j−1) + S⁻¹_(j−1,j−1), with q = Wᵀt = q₀ + W_k.
        // A⁻¹m = (z_α, z_V): z_V = −K⁻¹Gᵀm_α, z_α = D_α⁻¹m_α − G z_V.
        let z_v = -(gk.row_sum().transpose() * inv_n);
        let mut z_a = DVector::from_iterator(n, (0..n).map(|i| inv_n / blk.d_alpha[i]));
        z_a.gemv(-1.0, &gm, &z_v, 1.0);
        let m_am = z_a.sum() * inv_n;
        let q0 = wa_1 * inv_n;
        let sq0 = &sg * &q0;
        let q0_sq0 = q0.dot(&sq0);
        for &j in &lay[s].runs {
            let (t_at, q_sq, sq_row) = match lay[s].v_index[j] {
                Some(k) => {
                    let v = k - n;
                    let wk = red.w_v.row(v);
                    let wsk = t_v.row(v);
                    (
                        m_am + 2.0 * z_v[v] + k_inv[(v, v)],
                        q0_sq0 + 2.0 * wk.transpose().dot(&sq0) + wsk.dot(&wk),
                        Some(v),
                    )
                }
                None => (m_am, q0_sq0, None),
            };
            let mut var = t_at + q_sq;
            if j > 0 {
                // (S⁻¹q)_(j−1) = (S⁻¹q₀)_(j−1) + (W S⁻¹)_(k, j−1) (S⁻¹ is symmetric).
                let sq = sq0[j - 1] + sq_row.map_or(0.0, |v| t_v[(v, j - 1)]);
                var += sg[(j - 1, j - 1)] - 2.0 * sq;
            }
            setup.push(SetupError {
                shift_deg,
                start_face: j + 1,
                value_arcsec: setup_grid[s][j].expect("estimated"),
                u_arcsec: (s2 * var.max(0.0)).sqrt(),
            });
        }
        if full {
            let mut ai = DMatrix::from_diagonal(&DVector::from_iterator(
                n,
                blk.d_alpha.iter().map(|d| 1.0 / d),
            ));
            if r > 0 {
                ai.gemm(1.0, &gk, &gm.transpose(), 1.0);
            }
            ai_blocks.push(centre_both(&ai));
            y_blocks.push(centre_rows(&w_a));
        }
    }

    let covariance = full.then(|| {
        let mut ca = DMatrix::zeros(ns * n, ns * n);
        let z: Vec<DMatrix<f64>> = y_blocks.iter().map(|y| y * &sg).collect();
        for s in 0..ns {
            for (t, yt) in y_blocks.iter().enumerate().skip(s) {
                let mut blk = &z[s] * yt.transpose();
                if s == t {
                    blk += &ai_blocks[s];
                }
                blk *= s2;
                ca.view_mut((s * n, t * n), (n, n)).copy_from(&blk);
                if s != t {
                    ca.view_mut((t * n, s * n), (n, n))
                        .copy_from(&blk.transpose());
                }
            }
        }
        let mut cb = DMatrix::zeros(n, n);
        for k in 1..=n {
            for l in 1..=n {
                cb[(k - 1, l - 1)] = s2
                    * (sg_padded(k, l) - sg_padded(k - 1, l) - sg_padded(k, l - 1)
                        + sg_padded(k - 1, l - 1));
            }
        }
        FullCovariance {
            alpha: ca,
            beta: cb,
        }
    });

    Ok(Calibration {
        method: Method::LeastSquares,
        faces: n,
        shifts,
        beta_arcsec: beta,
        u_beta_arcsec: u_beta,
        setup,
        residuals,
        sigma_used_arcsec: sigma,
        covariance,
        undetectable_harmonics: undetectable_orders(n, max_listed_order(set)),
        duplicates_ignored: set.duplicates_ignored(),
    })
}

/// P·M: every column minus its mean.
fn centre_rows(m: &DMatrix<f64>) -> DMatrix<f64> {
    let mut out = m.clone();
    let n = m.nrows() as f64;
    for mut col in out.column_iter_mut() {
        let mean = col.sum() / n;
        col.add_scalar_mut(-mean);
    }
    out
}

/// P·M·P.
fn centre_both(m: &DMatrix<f64>) -> DMatrix<f64> {
    centre_rows(&centre_rows(m).transpose()).transpose()
}

/// Names the unknowns the readings leave undetermined (error path only).
fn diagnose(set: &ReadingSet, lay: &[ShiftLayout]) -> ShiftAngleError {
    let n = set.faces();
    let g = n - 1;
    let offsets: Vec<usize> = lay
        .iter()
        .scan(0, |acc, l| {
            let o = *acc;
            *acc += l.len;
            Some(o)
        })
        .collect();
    let local: usize = lay.iter().map(|l| l.len).sum();
    let total = local + g;
    let shift_name = |s: usize| format!("{}", set.shifts_deg()[s]);
    // Naming the undetermined unknowns takes an eigen-decomposition of the whole normal matrix
    // (cubic in the unknowns): done only where it is cheap (≤ 600 unknowns, about 0.1 s); beyond
    // that, and whenever there are fewer readings than unknowns, the message says so without it.
    if total > 600 && set.len() < total {
        return ShiftAngleError::Undetermined {
            count: total - set.len(),
            names: format!(
                "at least that many of the {total} unknowns ({} readings for {n} faces and {} shifts: every shift needs every step and every face read)",
                set.len(),
                lay.len()
            ),
        };
    }
    if total > 600 {
        return ShiftAngleError::Undetermined {
            count: 0,
            names: "some unknowns (too many to analyse: check that every shift has every step \
                    and every face is read)"
                .into(),
        };
    }
    let ne = accumulate(set, lay);
    let mut m = DMatrix::zeros(total, total);
    for s in 0..lay.len() {
        let o = offsets[s];
        let l = lay[s].len;
        m.view_mut((o, o), (l, l)).copy_from(&ne.a[s]);
        m.view_mut((o, local), (l, g)).copy_from(&ne.b[s]);
        m.view_mut((local, o), (g, l))
            .copy_from(&ne.b[s].transpose());
    }
    m.view_mut((local, local), (g, g)).copy_from(&ne.d);
    let eig = m.symmetric_eigen();
    let lmax = eig.eigenvalues.iter().fold(0.0f64, |a, &b| a.max(b.abs()));
    let null: Vec<usize> = (0..total)
        .filter(|&k| eig.eigenvalues[k].abs() <= 1e-9 * lmax.max(1e-300))
        .collect();
    let undetermined = |t: &DVector<f64>| -> bool {
        let tn = t.norm();
        null.iter()
            .map(|&k| eig.eigenvectors.column(k).dot(t).powi(2))
            .sum::<f64>()
            .sqrt()
            > 1e-6 * tn
    };
    let mut names = Vec::new();
    // β_k = B(k) − B(k−1).
    for k in 1..=n {
        let mut t = DVector::zeros(total);
        if k < n {
            t[local + k - 1] += 1.0;
        }
        if k > 1 {
            t[local + k - 2] -= 1.0;
        }
        if undetermined(&t) {
            names.push(format!("β_{k}"));
        }
    }
    for (s, l) in lay.iter().enumerate() {
        let o = offsets[s];
        for i in 0..n {
            let mut t = DVector::zeros(total);
            for q in 0..n {
                t[o + q] = -1.0 / n as f64;
            }
            t[o + i] += 1.0;
            if undetermined(&t) {
                names.push(format!(
                    "α({}°) [shift {}°, step {}]",
                    set.angle_deg(s, i + 1),
                    shift_name(s),
                    i + 1
                ));
            }
        }
        for &j in &l.runs {
            let mut t = DVector::zeros(total);
            for q in 0..n {
                t[o + q] = 1.0 / n as f64;
            }
            if let Some(k) = l.v_index[j] {
                t[o + k] += 1.0;
            }
            if j > 0 {
                t[local + j - 1] += 1.0;
            }
            if undetermined(&t) {
                names.push(format!(
                    "U [shift {}°, start face {}]",
                    shift_name(s),
                    j + 1
                ));
            }
        }
    }
    let count = names.len();
    let shown = if count > 12 {
        format!("{}, … and {} more", names[..12].join(", "), count - 12)
    } else {
        names.join(", ")
    };
    ShiftAngleError::Undetermined {
        count,
        names: if count == 0 {
            "(numerically ill-conditioned system)".into()
        } else {
            shown
        },
    }
}

#[cfg(test)]
mod tests {
    //! The structured solver against a plain dense one: the minimally constrained least squares
    //! of the paper's own parameters (α per shift and step, β, U per run) with the constraints
    //! Σα = 0 per shift and Σβ = 0 bordering the normal matrix, inverted whole.
    use super::super::{Reading, calibrate};
    use super::*;
    use rand::{RngExt, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    struct Dense {
        alpha: Vec<f64>,
        beta: Vec<f64>,
        setup: Vec<(usize, usize, f64, f64)>,
        cov_alpha: DMatrix<f64>,
        cov_beta: DMatrix<f64>,
    }

    fn dense_reference(set: &ReadingSet, sigma: f64) -> Dense {
        let n = set.faces();
        let ns = set.shifts_deg().len();
        let runs: Vec<(usize, usize)> = (0..ns)
            .flat_map(|s| set.runs(s).into_iter().map(move |j| (s, j - 1)))
            .collect();
        let (na, nb) = (ns * n, n);
        let p = na + nb + runs.len();
        let nc = ns + 1;
        let mut kkt = DMatrix::zeros(p + nc, p + nc);
        let mut rhs = DVector::zeros(p + nc);
        for o in &set.obs {
            let mut row = DVector::zeros(p);
            row[o.s * n + o.i] = 1.0;
            for t in 0..=o.i {
                row[na + (o.j + t) % n] += 1.0;
            }
            let u = runs.iter().position(|&r| r == (o.s, o.j)).unwrap();
            row[na + nb + u] = 1.0;
            let mut xtx = kkt.view_mut((0, 0), (p, p));
            xtx.ger(1.0, &row, &row, 1.0);
            rhs.rows_mut(0, p).axpy(o.value, &row, 1.0);
        }
        for s in 0..ns {
            for i in 0..n {
                kkt[(p + s, s * n + i)] = 1.0;
                kkt[(s * n + i, p + s)] = 1.0;
            }
        }
        for k in 0..n {
            kkt[(p + ns, na + k)] = 1.0;
            kkt[(na + k, p + ns)] = 1.0;
        }
        let inv = kkt.try_inverse().expect("determined");
        let x = &inv * &rhs;
        let cov = inv.view((0, 0), (p, p)).clone_owned() * (sigma * sigma);
        Dense {
            alpha: x.rows(0, na).iter().copied().collect(),
            beta: x.rows(na, nb).iter().copied().collect(),
            setup: runs
                .iter()
                .enumerate()
                .map(|(u, &(s, j))| {
                    let k = na + nb + u;
                    (s, j + 1, x[k], cov[(k, k)].sqrt())
                })
                .collect(),
            cov_alpha: cov.view((0, 0), (na, na)).clone_owned(),
            cov_beta: cov.view((na, na), (nb, nb)).clone_owned(),
        }
    }

    /// Random incomplete readings: 4–8 faces, 1–3 shifts, random runs, repeats and gaps.
    fn random_set(rng: &mut ChaCha8Rng) -> ReadingSet {
        let n = rng.random_range(4..=8usize);
        let ns = rng.random_range(1..=3usize);
        let drop = rng.random_range(0.0..0.25);
        let mut readings = Vec::new();
        for s in 0..ns {
            let shift = s as f64 * 7.5;
            for j in 1..=n {
                if s > 0 && j > 1 && rng.random_bool(0.5) {
                    continue;
                }
                for i in 1..=n {
                    for repeat in 1..=rng.random_range(1..=2u32) {
                        if rng.random_bool(drop) {
                            continue;
                        }
                        readings.push(Reading {
                            shift_deg: shift,
                            start_face: j,
                            step: i,
                            repeat,
                            value_arcsec: rng.random_range(-2.0..2.0),
                        });
                    }
                }
            }
        }
        ReadingSet::new(n, readings).unwrap()
    }

    fn close(a: f64, b: f64, what: &str) {
        assert!(
            (a - b).abs() <= 1e-9 * (1.0 + b.abs()),
            "{what}: structured {a} vs dense {b}"
        );
    }

    #[test]
    fn structured_solver_equals_the_dense_constrained_solve() {
        let mut rng = ChaCha8Rng::seed_from_u64(29);
        let mut compared = 0;
        for case in 0..200 {
            let set = random_set(&mut rng);
            let sigma = 0.3;
            let opts = Options {
                sigma_arcsec: Some(sigma),
                covariance: CovarianceLevel::Full,
                ..Options::default()
            };
            let Ok(cal) = calibrate(&set, &opts) else {
                continue;
            };
            compared += 1;
            let d = dense_reference(&set, sigma);
            let n = set.faces();
            for (s, sh) in cal.shifts.iter().enumerate() {
                for i in 0..n {
                    let k = s * n + i;
                    close(sh.alpha_arcsec[i], d.alpha[k], &format!("case {case} α"));
                    close(
                        sh.u_alpha_arcsec[i],
                        d.cov_alpha[(k, k)].sqrt(),
                        &format!("case {case} u(α)"),
                    );
                }
            }
            for k in 0..n {
                close(cal.beta_arcsec[k], d.beta[k], &format!("case {case} β"));
                close(
                    cal.u_beta_arcsec[k],
                    d.cov_beta[(k, k)].sqrt(),
                    &format!("case {case} u(β)"),
                );
            }
            assert_eq!(cal.setup.len(), d.setup.len());
            for (u, &(s, j, v, uv)) in cal.setup.iter().zip(&d.setup) {
                assert_eq!((u.shift_deg, u.start_face), (set.shifts_deg()[s], j));
                close(u.value_arcsec, v, &format!("case {case} U"));
                close(u.u_arcsec, uv, &format!("case {case} u(U)"));
            }
            let full = cal.covariance.as_ref().expect("asked for");
            for (a, b) in full.alpha.iter().zip(d.cov_alpha.iter()) {
                close(*a, *b, &format!("case {case} Cov(α)"));
            }
            for (a, b) in full.beta.iter().zip(d.cov_beta.iter()) {
                close(*a, *b, &format!("case {case} Cov(β)"));
            }
            let diag = calibrate(
                &set,
                &Options {
                    covariance: CovarianceLevel::Diagonal,
                    ..opts
                },
            )
            .unwrap();
            assert_eq!(diag.shifts, cal.shifts);
            assert!(diag.covariance.is_none());
        }
        assert!(compared >= 100, "only {compared} determined cases");
    }
}
