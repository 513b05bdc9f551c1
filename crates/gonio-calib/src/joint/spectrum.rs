//! Which harmonic orders the joint estimate can see, and the joint harmonic table.
//!
//! An order the heads cannot see (`q_k = 0`, e.g. multiples of 84 for SelfA) can still be seen
//! by the polygon through its pattern at the polygon's angles, unless that pattern is constant on
//! every shift's angles (order a multiple of N: it merges into the setup errors) or it repeats
//! the pattern of another such order already estimated (aliasing on the polygon's angle grid).
//! Those orders, up to a cap (by default half the number of distinct polygon angles, the
//! Nyquist order of a regular angle grid), become unknowns of the joint solve, estimated from
//! the polygon alone; the rest are invisible and reported.

use super::heads_block::HeadsBlock;
use super::polygon_block::PolygonGrid;
use gonio_core::harmonic::HarmonicTerm;
use nalgebra::{DMatrix, DVector};

/// Why an order the heads cannot see is absent from the joint estimate.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case", tag = "reason")]
pub enum Invisible {
    /// The polygon cannot see it either: constant on every shift's angles (a multiple of N).
    BothBlind,
    /// Above the highest order the polygon's angles are asked to resolve.
    AboveCap {
        /// The cap.
        cap: u32,
    },
    /// Its cosine or sine pattern at the polygon's angles is not independent of the orders
    /// already estimated and the setup errors (aliasing on the polygon's angle grid).
    Unresolved {
        /// The estimated order it is mostly confused with, if any.
        alias_of: Option<u32>,
    },
}

/// The outcome of the selection.
pub(crate) struct BlindSelection {
    /// Heads-blind orders estimated from the polygon, ascending.
    pub estimated: Vec<u32>,
    /// Heads-blind orders not estimated, with the reason, ascending (up to the listing order).
    pub invisible: Vec<(u32, Invisible)>,
    /// `(cos, sin)` columns of the estimated orders at the distinct polygon angles (nq × 2·nb).
    pub design: DMatrix<f64>,
}

/// The pattern of `term` at the distinct polygon angles.
pub(crate) fn pattern(grid: &PolygonGrid, term: HarmonicTerm) -> DVector<f64> {
    DVector::from_iterator(
        grid.len(),
        grid.angles_deg.iter().map(|a| term.basis(a.to_radians())),
    )
}

/// Subtracts the projections on an orthonormal basis; returns the remainder.
fn reject(basis: &[DVector<f64>], v: &DVector<f64>) -> DVector<f64> {
    let mut r = v.clone();
    for b in basis {
        let c = b.dot(&r);
        r.axpy(-c, b, 1.0);
    }
    r
}

/// Selects the heads-blind orders the polygon can resolve, up to `cap`, and lists every
/// heads-blind order up to `list_to` that stays invisible.
pub(crate) fn select_blind(
    heads: &HeadsBlock,
    grid: &PolygonGrid,
    cap: u32,
    list_to: u32,
) -> BlindSelection {
    let nq = grid.len();
    let tol = 1e-6 * (nq as f64).sqrt();
    // The polygon cannot see a constant on one shift's angles: orthonormal basis of those.
    let mut basis: Vec<DVector<f64>> = Vec::new();
    for q in &grid.q_of {
        let mut v = DVector::zeros(nq);
        for &i in q {
            v[i] = 1.0;
        }
        let r = reject(&basis, &v);
        let norm = r.norm();
        if norm > tol {
            basis.push(r / norm);
        }
    }
    let n_const = basis.len();
    let mut estimated = Vec::new();
    let mut owner: Vec<u32> = Vec::new(); // order of each accepted basis vector
    let mut invisible = Vec::new();
    let last = (heads.nbins.saturating_sub(1) as u32).min(list_to.max(cap));
    for k in 1..=last {
        if heads.sees(k as usize) {
            continue;
        }
        if k > cap {
            invisible.push((k, Invisible::AboveCap { cap }));
            continue;
        }
        let c = pattern(grid, HarmonicTerm::Cos(k));
        let s = pattern(grid, HarmonicTerm::Sin(k));
        let const_only = |v: &DVector<f64>| reject(&basis[..n_const], v).norm() <= tol;
        if const_only(&c) && const_only(&s) {
            invisible.push((k, Invisible::BothBlind));
            continue;
        }
        let rc = reject(&basis, &c);
        if rc.norm() <= tol {
            invisible.push((
                k,
                Invisible::Unresolved {
                    alias_of: alias(&basis, &owner, n_const, &c),
                },
            ));
            continue;
        }
        let mut trial = basis.clone();
        trial.push(rc.normalize());
        let rs = reject(&trial, &s);
        if rs.norm() <= tol {
            invisible.push((
                k,
                Invisible::Unresolved {
                    alias_of: alias(&basis, &owner, n_const, &s),
                },
            ));
            continue;
        }
        trial.push(rs.normalize());
        basis = trial;
        owner.extend([k, k]);
        estimated.push(k);
    }
    let mut design = DMatrix::zeros(nq, 2 * estimated.len());
    for (e, &k) in estimated.iter().enumerate() {
        design.set_column(2 * e, &pattern(grid, HarmonicTerm::Cos(k)));
        design.set_column(2 * e + 1, &pattern(grid, HarmonicTerm::Sin(k)));
    }
    BlindSelection {
        estimated,
        invisible,
        design,
    }
}

/// The accepted order whose basis vector carries most of `v` (for the message), if any carries
/// a noticeable part.
fn alias(basis: &[DVector<f64>], owner: &[u32], n_const: usize, v: &DVector<f64>) -> Option<u32> {
    let vn = v.norm();
    if vn <= 1e-9 * (v.len() as f64).sqrt() {
        return None; // the pattern vanishes at every polygon angle
    }
    basis[n_const..]
        .iter()
        .zip(owner)
        .map(|(b, &k)| (b.dot(v).abs(), k))
        .filter(|&(c, _)| c > 1e-3 * vn)
        .max_by(|a, b| a.0.total_cmp(&b.0))
        .map(|(_, k)| k)
}

/// Inputs of [`harmonic_table`].
pub(crate) struct TableInputs<'a> {
    pub heads: &'a HeadsBlock,
    pub grid: &'a PolygonGrid,
    pub selection: &'a BlindSelection,
    pub prior: &'a super::solve::HeadsPrior,
    pub solution: &'a super::solve::Solution,
    /// Size of the (α, γ) part of the unknowns.
    pub nyg: usize,
    pub sigma_heads: f64,
    pub faces: usize,
    pub max_order: u32,
}

/// The joint harmonic table, orders 1..=max_order.
///
/// Orders the heads see: the heads-alone coefficients updated by the polygon through the
/// covariance between a coefficient and α at the polygon angles (`Cov(c_k, α_q) = σ²·g_k·cos kθ_q`):
///
/// ```text
/// c_k = ĉ_k + g_k·Φ_kᵀ·W·(y_V − ŷ),    Cov(c_k, s_k) = σ²·g_k·I − g_k²·Φ_kᵀ·(σ²·W − W·P·W)·Φ_k
/// ```
///
/// with `Φ_k` the (cos, sin) pattern at the polygon angles, `y_V` the joint α there less the
/// heads-blind orders, `W` the heads' weight and `P = Cov(y_V)`. Heads-blind orders resolved by
/// the polygon come straight from the solve.
pub(crate) fn harmonic_table(t: &TableInputs) -> Vec<super::JointHarmonic> {
    use super::{JointHarmonic, SeenBy};
    let nq = t.grid.len();
    let sol = t.solution;
    let design = &t.selection.design;
    let nb = design.ncols();
    let y = sol.x.rows(0, nq);
    let b = sol.x.rows(t.nyg, nb);
    let yv = y - design * b;
    let r = &t.prior.w_krig * (&yv - &t.prior.yhat);
    // P = Cov(y − H_B·b).
    let cyy = sol.cov.view((0, 0), (nq, nq));
    let cyb = sol.cov.view((0, t.nyg), (nq, nb));
    let cbb = sol.cov.view((t.nyg, t.nyg), (nb, nb));
    let cross = cyb * design.transpose();
    let p = cyy - &cross - cross.transpose() + design * cbb * design.transpose();
    let s2 = t.sigma_heads * t.sigma_heads;
    let w = &t.prior.w_krig;
    let last = t.max_order.min(t.heads.nbins.saturating_sub(1) as u32);
    let visible: Vec<u32> = (1..=last).filter(|&k| t.heads.sees(k as usize)).collect();
    let mut phi = DMatrix::zeros(nq, 2 * visible.len());
    for (e, &k) in visible.iter().enumerate() {
        phi.set_column(2 * e, &pattern(t.grid, HarmonicTerm::Cos(k)));
        phi.set_column(2 * e + 1, &pattern(t.grid, HarmonicTerm::Sin(k)));
    }
    // Φᵀ·(σ²·W − W·P·W)·Φ, column pair by column pair, through WΦ (no nq³ product).
    let wphi = w * &phi;
    let pwphi = &p * &wphi;
    let phir = phi.transpose() * &r;
    let quad =
        |i: usize| s2 * phi.column(i).dot(&wphi.column(i)) - wphi.column(i).dot(&pwphi.column(i));
    let mut rows = Vec::with_capacity(t.max_order as usize);
    let mut vi = 0usize;
    for k in 1..=t.max_order {
        let heads_see = t.heads.sees(k as usize);
        let polygon_sees = !(k as usize).is_multiple_of(t.faces);
        let seen_by = match (heads_see, polygon_sees) {
            (true, true) => SeenBy::Both,
            (true, false) => SeenBy::Heads,
            (false, true) => SeenBy::Polygon,
            (false, false) => SeenBy::Neither,
        };
        let row = |c: f64, s: f64, uc: f64, us: f64, alone: Option<f64>, hs: f64| {
            let h = gonio_core::Harmonic::from_cos_sin(k, c, s);
            JointHarmonic {
                order: k,
                estimated: true,
                seen_by,
                cos_arcsec: c,
                sin_arcsec: s,
                amplitude_arcsec: h.amplitude,
                phase_rad: h.phase_rad,
                u_cos_arcsec: uc,
                u_sin_arcsec: us,
                u_heads_alone_arcsec: alone,
                heads_share: hs,
                polygon_share: 1.0 - hs,
                invisible: None,
            }
        };
        if heads_see {
            let g = t.heads.gain[k as usize];
            let (c0, s0) = t.heads.coef[k as usize];
            let (ic, is) = (2 * vi, 2 * vi + 1);
            let c = c0 + g * phir[ic];
            let s = s0 + g * phir[is];
            let vc = (s2 * g - g * g * quad(ic)).max(0.0);
            let vs = (s2 * g - g * g * quad(is)).max(0.0);
            let share = if g > 0.0 {
                (0.5 * (vc + vs) / (s2 * g)).clamp(0.0, 1.0)
            } else {
                0.0
            };
            rows.push(row(
                c,
                s,
                vc.sqrt(),
                vs.sqrt(),
                Some((s2 * g).sqrt()),
                share,
            ));
            vi += 1;
        } else if let Some(e) = t.selection.estimated.iter().position(|&o| o == k) {
            let (ic, is) = (t.nyg + 2 * e, t.nyg + 2 * e + 1);
            rows.push(row(
                sol.x[ic],
                sol.x[is],
                sol.cov[(ic, ic)].max(0.0).sqrt(),
                sol.cov[(is, is)].max(0.0).sqrt(),
                None,
                0.0,
            ));
        } else {
            let reason = t
                .selection
                .invisible
                .iter()
                .find(|(o, _)| *o == k)
                .map(|&(_, r)| r);
            rows.push(JointHarmonic {
                order: k,
                estimated: false,
                seen_by,
                cos_arcsec: 0.0,
                sin_arcsec: 0.0,
                amplitude_arcsec: 0.0,
                phase_rad: 0.0,
                u_cos_arcsec: 0.0,
                u_sin_arcsec: 0.0,
                u_heads_alone_arcsec: None,
                heads_share: 0.0,
                polygon_share: 0.0,
                invisible: reason,
            });
        }
    }
    rows
}
