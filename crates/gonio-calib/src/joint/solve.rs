//! The joint solve: the heads' information on α at the polygon angles (from the FFT-diagonal
//! block, through one inverse FFT), the polygon's reduced block, and the heads-blind orders the
//! polygon resolves, in one dense system of size (distinct angles + N − 1 + 2·estimated blind
//! orders), never the NS × NS one.

use super::JointError;
use super::polygon_block::{PolygonGrid, PolygonSystem};
use crate::shift_angle::least_squares::cholesky;
use nalgebra::{DMatrix, DVector};

/// The heads' estimate at the polygon angles and its weight.
pub(crate) struct HeadsPrior {
    /// The heads-alone estimate ŷ at the distinct polygon angles, arcsec.
    pub yhat: DVector<f64>,
    /// Weight used in the solve, per unit σ²: C̃⁻¹ (C̃ the covariance of ŷ per unit σ²); where
    /// C̃ is singular (the heads' model fixes a combination exactly, e.g. equally divided heads
    /// and a polygon angle grid sharing a divisor), its pseudo-inverse plus a stiff weight
    /// (10⁶ times the strongest) on the fixed combinations.
    pub w_solve: DMatrix<f64>,
    /// C̃⁺ alone (the two coincide when C̃ is regular).
    pub w_krig: DMatrix<f64>,
}

impl HeadsPrior {
    /// From the kernel c(m) and the heads-alone estimate on the grid.
    pub(crate) fn new(kernel: &[f64], estimate: &[f64], grid: &PolygonGrid) -> HeadsPrior {
        let nq = grid.len();
        let ns = kernel.len();
        let c = DMatrix::from_fn(nq, nq, |p, q| {
            let d = (grid.grid[p] + ns - grid.grid[q]) % ns;
            kernel[d]
        });
        let yhat = DVector::from_iterator(nq, grid.grid.iter().map(|&m| estimate[m]));
        if let Some(ch) = cholesky(c.clone()) {
            let w = ch.inverse();
            return HeadsPrior {
                yhat,
                w_solve: w.clone(),
                w_krig: w,
            };
        }
        let eig = c.symmetric_eigen();
        let lmax = eig.eigenvalues.iter().fold(0.0f64, |a, &b| a.max(b));
        let mut w_krig = DMatrix::zeros(nq, nq);
        let mut fixed = DMatrix::zeros(nq, nq);
        let mut strongest = 0.0f64;
        for (k, &l) in eig.eigenvalues.iter().enumerate() {
            let u = eig.eigenvectors.column(k);
            if l > 1e-10 * lmax {
                w_krig += (u * u.transpose()) / l;
                strongest = strongest.max(1.0 / l);
            } else {
                fixed += u * u.transpose();
            }
        }
        let w_solve = &w_krig + fixed * (1e6 * strongest);
        HeadsPrior {
            yhat,
            w_solve,
            w_krig,
        }
    }
}

/// The solution of the joint normal equations (arcsec, arcsec²).
pub(crate) struct Solution {
    /// (α at the distinct angles, γ, blind-order coefficients).
    pub x: DVector<f64>,
    /// Its covariance.
    pub cov: DMatrix<f64>,
    /// Diagonal of the part of `cov` due to the polygon's noise (the rest is the heads').
    pub var_polygon: DVector<f64>,
}

/// Assembles and solves `H·x = h` with `H = H_polygon/σ_p² + H_heads/σ_h²`.
///
/// The heads' term is `(y − H_B·b − ŷ)ᵀ·W·(y − H_B·b − ŷ)/σ_h²`: the heads measure α at the
/// polygon angles except for the heads-blind orders `b`, which only the polygon sees.
pub(crate) fn solve(
    poly: &PolygonSystem,
    prior: &HeadsPrior,
    design: &DMatrix<f64>,
    sigma_polygon: f64,
    sigma_heads: f64,
    names: impl Fn(usize) -> String,
) -> Result<Solution, JointError> {
    let nyg = poly.h.nrows();
    let nq = prior.yhat.len();
    let nb = design.ncols();
    let n = nyg + nb;
    let (ip, ih) = (
        1.0 / (sigma_polygon * sigma_polygon),
        1.0 / (sigma_heads * sigma_heads),
    );
    let w = &prior.w_solve;
    let wb = w * design; // nq × nb
    let mut h = DMatrix::zeros(n, n);
    let mut rhs = DVector::zeros(n);
    h.view_mut((0, 0), (nyg, nyg)).copy_from(&(&poly.h * ip));
    rhs.rows_mut(0, nyg).copy_from(&(&poly.rhs * ip));
    {
        let mut hyy = h.view_mut((0, 0), (nq, nq));
        hyy += w * ih;
    }
    h.view_mut((0, nyg), (nq, nb)).copy_from(&(&wb * -ih));
    h.view_mut((nyg, 0), (nb, nq))
        .copy_from(&(wb.transpose() * -ih));
    h.view_mut((nyg, nyg), (nb, nb))
        .copy_from(&(design.transpose() * &wb * ih));
    let wy = w * &prior.yhat;
    {
        let mut ry = rhs.rows_mut(0, nq);
        ry += &wy * ih;
    }
    rhs.rows_mut(nyg, nb)
        .copy_from(&(design.transpose() * &wy * -ih));
    let Some(ch) = cholesky(h.clone()) else {
        return Err(diagnose(&h, names));
    };
    let x = ch.solve(&rhs);
    let cov = ch.inverse();
    // Polygon part: diag(cov·(H_polygon/σ_p²)·cov), with H_polygon's nonzeros only (its α
    // block is block-diagonal by shift when shifts read different angles).
    let nonzeros: Vec<Vec<(usize, f64)>> = (0..nyg)
        .map(|j| {
            (0..nyg)
                .filter_map(|i| {
                    let v = poly.h[(i, j)];
                    (v != 0.0).then_some((i, v * ip))
                })
                .collect()
        })
        .collect();
    let var_polygon = DVector::from_fn(n, |r, _| {
        let row = cov.row(r);
        nonzeros
            .iter()
            .enumerate()
            .map(|(j, col)| row[j] * col.iter().map(|&(i, v)| row[i] * v).sum::<f64>())
            .sum::<f64>()
    });
    Ok(Solution {
        x,
        cov,
        var_polygon,
    })
}

/// Names the unknowns the joint system leaves undetermined (error path only).
fn diagnose(h: &DMatrix<f64>, names: impl Fn(usize) -> String) -> JointError {
    let n = h.nrows();
    if n > 600 {
        return JointError::Undetermined {
            count: 0,
            names: "some unknowns (too many to analyse: check that every face is read and \
                    every run has readings)"
                .into(),
        };
    }
    let eig = h.clone().symmetric_eigen();
    let lmax = eig.eigenvalues.iter().fold(0.0f64, |a, &b| a.max(b.abs()));
    let mut found: Vec<usize> = Vec::new();
    for (k, &l) in eig.eigenvalues.iter().enumerate() {
        if l.abs() > 1e-9 * lmax.max(1e-300) {
            continue;
        }
        let v = eig.eigenvectors.column(k);
        let vmax = v.iter().fold(0.0f64, |a, &b| a.max(b.abs()));
        for (i, &c) in v.iter().enumerate() {
            if c.abs() > 0.3 * vmax && !found.contains(&i) {
                found.push(i);
            }
        }
    }
    found.sort_unstable();
    let count = found.len();
    let mut list: Vec<String> = found.iter().take(12).map(|&i| names(i)).collect();
    if count > 12 {
        list.push(format!("… and {} more", count - 12));
    }
    JointError::Undetermined {
        count,
        names: if count == 0 {
            "(numerically ill-conditioned system)".into()
        } else {
            list.join(", ")
        },
    }
}
