//! The polygon's block of the joint least squares: the shift-angle method's block-arrow normal
//! equations, with every run's setup term eliminated shift by shift, so that what remains is the
//! polygon's information on α at its (distinct) angles and on the pitch sums γ.
//!
//! Per shift s the local unknowns are α_s (N steps) and V_s (one per run; the block of V is
//! diagonal, one reading touches one V). Eliminating V_s:
//!
//! ```text
//! H_αα += A_αα − P·D⁻¹·Pᵀ,   H_αγ += B_α − P·D⁻¹·B_V,   H_γγ += −B_Vᵀ·D⁻¹·B_V
//! ```
//!
//! (P the α–V block, D the diagonal V block), scattered onto the distinct angles: α_s(i) is the
//! encoder error at grid position q(s, i), shared by every shift that reads that angle.

use super::JointError;
use super::heads_block::HeadsBlock;
use crate::shift_angle::least_squares::{Normal, ShiftLayout, accumulate, big_b, layouts};
use crate::shift_angle::{ReadingSet, SetupError};
use nalgebra::{DMatrix, DVector};

/// The distinct polygon angles on the encoder grid.
pub(crate) struct PolygonGrid {
    /// Grid index of each distinct angle, ascending.
    pub grid: Vec<usize>,
    /// The angles, degrees in [0, 360).
    pub angles_deg: Vec<f64>,
    /// `q_of[s][i]`: index into `grid` of step i (0-based) of shift s.
    pub q_of: Vec<Vec<usize>>,
}

impl PolygonGrid {
    /// Places every polygon angle on the heads' grid.
    ///
    /// # Errors
    /// [`JointError::OffGrid`] for an angle further than 10⁻⁶ grid steps from a grid position.
    pub(crate) fn new(set: &ReadingSet, heads: &HeadsBlock) -> Result<PolygonGrid, JointError> {
        let ns = heads.ns;
        let step = heads.step_deg();
        let n = set.faces();
        let mut raw = Vec::with_capacity(set.shifts_deg().len());
        for s in 0..set.shifts_deg().len() {
            let mut row = Vec::with_capacity(n);
            for i in 1..=n {
                let angle = set.angle_deg(s, i);
                let pos = (angle - heads.theta0_deg) / step;
                let m = pos.round();
                if (pos - m).abs() > 1e-6 {
                    return Err(JointError::OffGrid {
                        angle_deg: angle,
                        shift_deg: set.shifts_deg()[s],
                        step: i,
                        positions: ns,
                        start_deg: heads.theta0_deg,
                        step_deg: step,
                    });
                }
                row.push((m as i64).rem_euclid(ns as i64) as usize);
            }
            raw.push(row);
        }
        let mut grid: Vec<usize> = raw.iter().flatten().copied().collect();
        grid.sort_unstable();
        grid.dedup();
        let q_of = raw
            .iter()
            .map(|row| {
                row.iter()
                    .map(|m| grid.binary_search(m).expect("listed"))
                    .collect()
            })
            .collect();
        let angles_deg = grid
            .iter()
            .map(|&m| {
                gonio_core::Degrees(heads.theta0_deg + m as f64 * step)
                    .normalized()
                    .0
            })
            .collect();
        Ok(PolygonGrid {
            grid,
            angles_deg,
            q_of,
        })
    }

    /// Number of distinct angles.
    pub(crate) fn len(&self) -> usize {
        self.grid.len()
    }
}

/// The polygon's reduced normal equations on (α at the distinct angles, γ), unit weight per
/// reading, and what is needed to recover the setup errors.
pub(crate) struct PolygonSystem {
    /// Information matrix, size nq + N − 1: α first, then γ_1..γ_(N−1).
    pub h: DMatrix<f64>,
    /// Right-hand side.
    pub rhs: DVector<f64>,
    lay: Vec<ShiftLayout>,
    ne: Normal,
}

impl PolygonSystem {
    /// Accumulates and reduces the polygon readings.
    pub(crate) fn new(set: &ReadingSet, grid: &PolygonGrid) -> PolygonSystem {
        let n = set.faces();
        let g = n - 1;
        let nq = grid.len();
        let lay = layouts(set, false);
        let ne = accumulate(set, &lay);
        let mut h = DMatrix::zeros(nq + g, nq + g);
        let mut rhs = DVector::zeros(nq + g);
        h.view_mut((nq, nq), (g, g)).copy_from(&ne.d);
        rhs.rows_mut(nq, g).copy_from(&ne.rhs_shared);
        for (s, l) in lay.iter().enumerate() {
            let r = l.len - n;
            let a = &ne.a[s];
            let b = &ne.b[s];
            let bl = &ne.rhs_local[s];
            // P·D⁻¹ (N × R), with D the diagonal V block.
            let mut pd = a.view((0, n), (n, r)).clone_owned();
            for c in 0..r {
                let d = a[(n + c, n + c)];
                pd.column_mut(c).scale_mut(1.0 / d);
            }
            let p = a.view((0, n), (n, r));
            let bv = b.view((n, 0), (r, g));
            let haa = -&pd * p.transpose();
            let hag = b.view((0, 0), (n, g)) - &pd * bv;
            let mut dinv_bv = bv.clone_owned();
            for c in 0..r {
                let d = a[(n + c, n + c)];
                dinv_bv.row_mut(c).scale_mut(1.0 / d);
            }
            let hgg = -(bv.transpose() * &dinv_bv);
            let ha = bl.rows(0, n) - &pd * bl.rows(n, r);
            let hg = -(dinv_bv.transpose() * bl.rows(n, r));
            let q = &grid.q_of[s];
            for i in 0..n {
                h[(q[i], q[i])] += a[(i, i)];
                for j in 0..n {
                    h[(q[i], q[j])] += haa[(i, j)];
                }
                for c in 0..g {
                    h[(q[i], nq + c)] += hag[(i, c)];
                    h[(nq + c, q[i])] += hag[(i, c)];
                }
                rhs[q[i]] += ha[i];
            }
            let mut hv = h.view_mut((nq, nq), (g, g));
            hv += hgg;
            let mut rv = rhs.rows_mut(nq, g);
            rv += hg;
        }
        PolygonSystem { h, rhs, lay, ne }
    }

    /// The setup error U of every run from α (at the distinct angles) and γ, with its standard
    /// uncertainty from `cov_wg`, the covariance of (α, γ) (arcsec²), and the polygon σ.
    ///
    /// `V = D⁻¹·(b_V − Pᵀ·α_s − B_V·γ)`, `U_(s,j) = V_(s,j) + B(j−1)`;
    /// `Var U = σ²/d_j + tᵀ·Cov(α_s, γ)·t` with `t = −(P, B_V)_jᵀ/d_j + e_B(j−1)`.
    pub(crate) fn setup_errors(
        &self,
        set: &ReadingSet,
        grid: &PolygonGrid,
        alpha: &[f64],
        gamma: &DVector<f64>,
        cov_wg: &DMatrix<f64>,
        sigma: f64,
    ) -> Vec<Vec<Option<SetupError>>> {
        let n = set.faces();
        let g = n - 1;
        let nq = grid.len();
        let mut out = Vec::with_capacity(self.lay.len());
        for (s, l) in self.lay.iter().enumerate() {
            let a = &self.ne.a[s];
            let b = &self.ne.b[s];
            let bl = &self.ne.rhs_local[s];
            let q = &grid.q_of[s];
            let mut row = vec![None; n];
            for &j in &l.runs {
                let v = l.v_index[j].expect("every run has a V");
                let d = a[(v, v)];
                // t over (α at the distinct angles, γ), sparse: (index, value).
                let mut t: Vec<(usize, f64)> = Vec::with_capacity(n + g);
                let mut value = bl[v];
                for i in 0..n {
                    let pij = a[(i, v)];
                    value -= pij * alpha[q[i]];
                    if pij != 0.0 {
                        t.push((q[i], -pij / d));
                    }
                }
                for c in 0..g {
                    value -= b[(v, c)] * gamma[c];
                    let e = if c + 1 == j { 1.0 } else { 0.0 };
                    let tc = e - b[(v, c)] / d;
                    if tc != 0.0 {
                        t.push((nq + c, tc));
                    }
                }
                let value = value / d + big_b(gamma, j, n);
                let var = sigma * sigma / d
                    + t.iter()
                        .map(|&(p, tp)| {
                            tp * t.iter().map(|&(r, tr)| cov_wg[(p, r)] * tr).sum::<f64>()
                        })
                        .sum::<f64>();
                row[j] = Some(SetupError {
                    shift_deg: set.shifts_deg()[s],
                    start_face: j + 1,
                    value_arcsec: value,
                    u_arcsec: var.max(0.0).sqrt(),
                });
            }
            out.push(row);
        }
        out
    }
}
