//! The paper's algorithm (Hsieh et al., 2022, §2.2, Tables 1–2, Eq. 7), kept as the reference
//! baseline.
//!
//! 1. β_k from the full N×N matrix of one shift: the mean over i of ε(i+1, n) − ε(i, n) with
//!    n ≡ k − i (mod N), ε(N+1, n) read as ε(1, n) (Table 2; the α differences telescope away).
//! 2. For every complete row (shift S, start face j): U = (Σ_i ε_ij − Σ_i C(j, i)) / N (Eq. 7,
//!    using Σα = 0).
//! 3. α(θ_i) = ε_ij − C(j, i) − U from one row per shift (start face 1 when it is complete).
//!
//! Repeated readings are averaged first. The estimator is linear in the readings, so its
//! uncertainties are propagated exactly through the linear map (see `solve`), Var = σ²·Σ (response)² / repeats.

use super::result::{PitchSums, max_listed_order, residual_stats};
use super::{
    Calibration, Method, Options, ReadingSet, SetupError, ShiftAngleError, ShiftResult,
    undetectable_orders,
};
use gonio_core::closure::wrap1;

/// Averaged readings: `cell[s][j][i]` = (sum, count).
struct Grid {
    n: usize,
    cells: Vec<Vec<Vec<(f64, u32)>>>,
}

impl Grid {
    fn complete_row(&self, s: usize, j: usize) -> bool {
        self.cells[s][j].iter().all(|c| c.1 > 0)
    }
    fn full_matrix(&self, s: usize) -> bool {
        (0..self.n).all(|j| self.complete_row(s, j))
    }
}

/// Which cells the algorithm reads: the reference shift's full matrix and the complete rows.
struct CellsRead {
    reference: usize,
    /// Complete rows per shift (0-based faces); the first one listed is used for α.
    rows: Vec<Vec<usize>>,
}

struct Estimate {
    beta: Vec<f64>,
    alpha: Vec<Vec<f64>>,
    /// U per shift per complete row, in `CellsRead::rows` order.
    setup: Vec<Vec<f64>>,
}

/// Runs the algorithm on values given by `eps(s, j, i)` (0-based).
fn estimate(n: usize, plan: &CellsRead, eps: &dyn Fn(usize, usize, usize) -> f64) -> Estimate {
    let r = plan.reference;
    let beta: Vec<f64> = (1..=n)
        .map(|k| {
            let mut acc = 0.0;
            for i in 1..=n {
                let m = wrap1(k as i64 - i as i64, n) - 1;
                let next = if i == n { 0 } else { i };
                acc += eps(r, m, next) - eps(r, m, i - 1);
            }
            acc / n as f64
        })
        .collect();
    let sums = PitchSums::new(&beta);
    let mut alpha = Vec::with_capacity(plan.rows.len());
    let mut setup = Vec::with_capacity(plan.rows.len());
    for (s, rows) in plan.rows.iter().enumerate() {
        let mut us = Vec::with_capacity(rows.len());
        for &j in rows {
            let total: f64 = (0..n).map(|i| eps(s, j, i) - sums.c(j, i + 1)).sum();
            us.push(total / n as f64);
        }
        let j = rows[0];
        alpha.push(
            (0..n)
                .map(|i| eps(s, j, i) - sums.c(j, i + 1) - us[0])
                .collect(),
        );
        setup.push(us);
    }
    Estimate { beta, alpha, setup }
}

/// Runs the paper's algorithm with exact propagation of uncertainty.
pub(crate) fn solve(set: &ReadingSet, opts: &Options) -> Result<Calibration, ShiftAngleError> {
    let n = set.faces();
    let ns = set.shifts_deg().len();
    let mut grid = Grid {
        n,
        cells: vec![vec![vec![(0.0, 0); n]; n]; ns],
    };
    for o in &set.obs {
        let c = &mut grid.cells[o.s][o.j][o.i];
        c.0 += o.value;
        c.1 += 1;
    }
    let reference =
        (0..ns)
            .find(|&s| grid.full_matrix(s))
            .ok_or_else(|| ShiftAngleError::PaperNeeds {
                needs: format!(
                    "a full {n}×{n} matrix (every start face at every step) at one shift angle"
                ),
            })?;
    let mut rows = Vec::with_capacity(ns);
    for s in 0..ns {
        let mut complete: Vec<usize> = (0..n).filter(|&j| grid.complete_row(s, j)).collect();
        if complete.is_empty() {
            return Err(ShiftAngleError::PaperNeeds {
                needs: format!(
                    "a complete row (all {n} steps of one start face) at shift {}°",
                    set.shifts_deg()[s]
                ),
            });
        }
        // Start face 1 first when complete (the seed's row), else the lowest complete face.
        complete.sort_unstable();
        rows.push(complete);
    }
    let plan = CellsRead { reference, rows };
    let mean = |s: usize, j: usize, i: usize| {
        let c = grid.cells[s][j][i];
        c.0 / c.1 as f64
    };
    let est = estimate(n, &plan, &mean);

    // σ: stated, or σ̂ of the least-squares fit of the same readings (the paper's algorithm has
    // no residuals of its own that estimate σ without bias).
    let sigma = match opts.sigma_arcsec {
        Some(s) => s,
        None => super::least_squares::solve(set, opts)
            .map(|c| c.residuals.sigma_hat_arcsec)
            .unwrap_or(f64::NAN),
    };

    // Exact propagation. Every output is d·ε(own row) + e·β, and β = R·ε(reference matrix),
    // so Var = σ²·[Σ w d² + eᵀ(R W Rᵀ)e + 2 Σ w d (Rᵀe)] with w = 1/repeats of each cell (the
    // cross term only where the row lies in the reference matrix).
    let w = |s: usize, j: usize, i: usize| 1.0 / grid.cells[s][j][i].1 as f64;
    // Columns of R: the (at most two) β's each reference cell (j, i) enters, with weight ±1/N.
    let mut r_cols: Vec<Vec<(usize, f64)>> = vec![Vec::new(); n * n];
    for k in 0..n {
        for i in 1..=n {
            let m = wrap1(k as i64 + 1 - i as i64, n) - 1;
            let next = i % n;
            r_cols[m * n + next].push((k, 1.0 / n as f64));
            r_cols[m * n + i - 1].push((k, -1.0 / n as f64));
        }
    }
    let mut k_beta = vec![vec![0.0; n]; n];
    for (c, col) in r_cols.iter().enumerate() {
        let wc = w(reference, c / n, c % n);
        for &(k1, v1) in col {
            for &(k2, v2) in col {
                k_beta[k1][k2] += wc * v1 * v2;
            }
        }
    }
    let quad = |e: &[f64]| -> f64 {
        let mut acc = 0.0;
        for (k1, row) in k_beta.iter().enumerate() {
            acc += e[k1] * row.iter().zip(e).map(|(a, b)| a * b).sum::<f64>();
        }
        acc
    };
    // Variance of d·ε(row j at shift s) + e·β.
    let variance = |s: usize, j: usize, d: &[f64], e: &[f64]| -> f64 {
        let mut v = quad(e);
        for (i, di) in d.iter().enumerate() {
            let wi = w(s, j, i);
            v += wi * di * di;
            if s == reference {
                let rte: f64 = r_cols[j * n + i].iter().map(|&(k, rv)| rv * e[k]).sum();
                v += 2.0 * wi * di * rte;
            }
        }
        v.max(0.0)
    };
    // cnt_k(j): how many of C(j, 1..N) contain β_k: N − ((k − j) mod N).
    let offset = |k: usize, j: usize| (k + n - j) % n;
    let e_setup = |j: usize| -> Vec<f64> {
        (0..n)
            .map(|k| -((n - offset(k, j)) as f64) / n as f64)
            .collect()
    };
    let d_setup = vec![1.0 / n as f64; n];
    let var_beta: Vec<f64> = (0..n).map(|k| k_beta[k][k]).collect();
    let mut var_alpha = vec![vec![0.0; n]; ns];
    let mut var_setup: Vec<Vec<f64>> = Vec::with_capacity(ns);
    for (s, rows) in plan.rows.iter().enumerate() {
        var_setup.push(
            rows.iter()
                .map(|&j| variance(s, j, &d_setup, &e_setup(j)))
                .collect(),
        );
        let j0 = rows[0];
        let eu = e_setup(j0);
        for (i, va) in var_alpha[s].iter_mut().enumerate() {
            let e: Vec<f64> = (0..n)
                .map(|k| -(if offset(k, j0) <= i { 1.0 } else { 0.0 }) - eu[k])
                .collect();
            let d: Vec<f64> = (0..n)
                .map(|q| if q == i { 1.0 } else { 0.0 } - 1.0 / n as f64)
                .collect();
            *va = variance(s, j0, &d, &e);
        }
    }

    let mut setup_grid = vec![vec![None; n]; ns];
    let mut setup = Vec::new();
    for (s, rows) in plan.rows.iter().enumerate() {
        for (q, &j) in rows.iter().enumerate() {
            setup_grid[s][j] = Some(est.setup[s][q]);
            setup.push(SetupError {
                shift_deg: set.shifts_deg()[s],
                start_face: j + 1,
                value_arcsec: est.setup[s][q],
                u_arcsec: sigma * var_setup[s][q].sqrt(),
            });
        }
    }
    // Free unknowns of the paper's model over the rows it uses: α (N−1 per shift), β (N−1), U.
    let free = ns * (n - 1) + (n - 1) + setup.len();
    let residuals = residual_stats(
        set,
        &est.alpha,
        &est.beta,
        &setup_grid,
        free,
        opts.sigma_arcsec,
    );
    let shifts = (0..ns)
        .map(|s| ShiftResult {
            shift_deg: set.shifts_deg()[s],
            angles_deg: (1..=n).map(|i| set.angle_deg(s, i)).collect(),
            alpha_arcsec: est.alpha[s].clone(),
            u_alpha_arcsec: var_alpha[s].iter().map(|v| sigma * v.sqrt()).collect(),
        })
        .collect();
    Ok(Calibration {
        method: Method::Paper,
        faces: n,
        shifts,
        u_beta_arcsec: var_beta.iter().map(|v| sigma * v.sqrt()).collect(),
        beta_arcsec: est.beta,
        setup,
        residuals,
        sigma_used_arcsec: sigma,
        covariance: None,
        undetectable_harmonics: undetectable_orders(n, max_listed_order(set)),
        duplicates_ignored: set.duplicates_ignored(),
    })
}
