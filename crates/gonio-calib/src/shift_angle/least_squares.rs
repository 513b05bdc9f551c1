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
//! Each A_s (size ≤ 2N−1) is factorised on its own; the shared unknowns come from the Schur
//! complement S = D − Σ B_sᵀ A_s⁻¹ B_s (size N−1). The cost grows linearly with the number of
//! shifts and readings instead of cubically with all unknowns. The gauges are then moved to the
//! paper's conventions (Σα = 0 per shift, Σβ = 0) by a linear map applied to the estimates and
//! to their covariance, which is exact: both gauges fix only directions the data cannot see.
//!
//! Covariance (in units of σ²): Cov(γ) = S⁻¹, Cov(x_s, x_t) = δ_st·A_s⁻¹ + W_s S⁻¹ W_tᵀ and
//! Cov(x_s, γ) = −W_s S⁻¹, with W_s = A_s⁻¹ B_s.

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
        let gi = gamma_index(wrap1((o.i + o.j + 1) as i64, n), n);
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

/// Solves the joint least-squares problem.
pub(crate) fn solve(set: &ReadingSet, opts: &Options) -> Result<Calibration, ShiftAngleError> {
    let n = set.faces();
    let g = n - 1;
    let ns = set.shifts_deg().len();
    let lay = layouts(set, true);
    let ne = accumulate(set, &lay);

    // Per shift: A⁻¹, W = A⁻¹B, w = A⁻¹b; Schur complement on the shared unknowns.
    let mut a_inv = Vec::with_capacity(ns);
    let mut w_mat = Vec::with_capacity(ns);
    let mut w_vec = Vec::with_capacity(ns);
    let mut schur = ne.d.clone();
    let mut rhs = ne.rhs_shared.clone();
    for s in 0..ns {
        let Some(ch) = cholesky(ne.a[s].clone()) else {
            return Err(diagnose(set, &lay, &ne));
        };
        let inv = ch.inverse();
        let w = &inv * &ne.b[s];
        let wv = &inv * &ne.rhs_local[s];
        schur -= ne.b[s].transpose() * &w;
        rhs -= ne.b[s].transpose() * &wv;
        a_inv.push(inv);
        w_mat.push(w);
        w_vec.push(wv);
    }
    let Some(sch) = cholesky(schur) else {
        return Err(diagnose(set, &lay, &ne));
    };
    let gamma = sch.solve(&rhs);
    let sg = sch.inverse();

    // Estimates in the solve's gauge, then in the paper's conventions.
    let mut alpha = Vec::with_capacity(ns);
    let mut means = Vec::with_capacity(ns);
    let mut x_all = Vec::with_capacity(ns);
    for s in 0..ns {
        let x = &w_vec[s] - &w_mat[s] * &gamma;
        let m = x.rows(0, n).sum() / n as f64;
        alpha.push((0..n).map(|i| x[i] - m).collect::<Vec<f64>>());
        means.push(m);
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

    let mut shifts = Vec::with_capacity(ns);
    let mut setup = Vec::with_capacity(setup_vals.len());
    let mut y_blocks = Vec::with_capacity(ns); // P·W_α per shift, for the full covariance
    for s in 0..ns {
        let wa = w_mat[s].rows(0, n).clone_owned();
        // W S⁻¹ (len × g), once per shift: its α rows give Cov(α) and its V rows the setup
        // errors' variances, so that each run costs O(N) instead of a product with A⁻¹.
        let ws = &w_mat[s] * &sg;
        let t = ws.rows(0, n);
        let mut c = a_inv[s].view((0, 0), (n, n)).clone_owned();
        c += t * wa.transpose();
        let u_alpha = centred_diag(&c)
            .into_iter()
            .map(|v| (s2 * v).sqrt())
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
        let mut m = DVector::zeros(lay[s].len);
        m.rows_mut(0, n).fill(1.0 / n as f64);
        let am = &a_inv[s] * &m;
        let m_am = m.dot(&am);
        let q0 = w_mat[s].transpose() * &m;
        let sq0 = &sg * &q0;
        let q0_sq0 = q0.dot(&sq0);
        for &j in &lay[s].runs {
            let (t_at, q_sq, sq_row) = match lay[s].v_index[j] {
                Some(k) => {
                    let wk = w_mat[s].row(k);
                    let wsk = ws.row(k);
                    (
                        m_am + 2.0 * am[k] + a_inv[s][(k, k)],
                        q0_sq0 + 2.0 * wk.transpose().dot(&sq0) + wsk.dot(&wk),
                        Some(k),
                    )
                }
                None => (m_am, q0_sq0, None),
            };
            let mut var = t_at + q_sq;
            if j > 0 {
                // (S⁻¹q)_(j−1) = (S⁻¹q₀)_(j−1) + (W S⁻¹)_(k, j−1) (S⁻¹ is symmetric).
                let sq = sq0[j - 1] + sq_row.map_or(0.0, |k| ws[(k, j - 1)]);
                var += sg[(j - 1, j - 1)] - 2.0 * sq;
            }
            setup.push(SetupError {
                shift_deg,
                start_face: j + 1,
                value_arcsec: setup_grid[s][j].expect("estimated"),
                u_arcsec: (s2 * var.max(0.0)).sqrt(),
            });
        }
        if opts.covariance == CovarianceLevel::Full {
            y_blocks.push(centre_rows(&wa));
        }
    }

    let covariance = (opts.covariance == CovarianceLevel::Full).then(|| {
        let mut ca = DMatrix::zeros(ns * n, ns * n);
        let z: Vec<DMatrix<f64>> = y_blocks.iter().map(|y| y * &sg).collect();
        for s in 0..ns {
            for (t, yt) in y_blocks.iter().enumerate().skip(s) {
                let mut blk = &z[s] * yt.transpose();
                if s == t {
                    let ai = a_inv[s].view((0, 0), (n, n)).clone_owned();
                    blk += centre_both(&ai);
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

/// Diagonal of P·C·P with P = I − 11ᵀ/n (the covariance of the zero-mean version).
fn centred_diag(c: &DMatrix<f64>) -> Vec<f64> {
    let n = c.nrows();
    let row_mean: Vec<f64> = (0..n).map(|i| c.row(i).sum() / n as f64).collect();
    let grand = row_mean.iter().sum::<f64>() / n as f64;
    (0..n)
        .map(|i| (c[(i, i)] - 2.0 * row_mean[i] + grand).max(0.0))
        .collect()
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
fn diagnose(set: &ReadingSet, lay: &[ShiftLayout], ne: &Normal) -> ShiftAngleError {
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
