//! GUM uncertainty budgets: contributions, combined standard uncertainty, Welch–Satterthwaite,
//! coverage factor, expanded uncertainty and shares (JCGM 100:2008 §5, §6, Annex G).
//!
//! For inputs x_i with standard uncertainties u_i, sensitivity coefficients c_i, degrees of freedom
//! ν_i and correlation coefficients r_ij,
//!
//! ```text
//! u_c² = Σ (c_i u_i)² + 2 Σ_{i<j} c_i c_j u_i u_j r_ij
//! ν_eff = u_c⁴ / Σ (c_i u_i)⁴ / ν_i        (Welch–Satterthwaite, G.2b)
//! k = t_{(1+p)/2}(⌊ν_eff⌋)                 (G.4.1: ν_eff truncated to the next lower integer)
//! U = k · u_c
//! ```
//!
//! Infinite degrees of freedom are `f64::INFINITY`. The share of a row is (c_i u_i)² / u_c²; with
//! correlations the shares do not add up to 1 (the cross terms are not attributed to any row), and
//! Welch–Satterthwaite is then only an approximation (it assumes independent inputs).
//!
//! ```
//! use gonio_uncertainty::{Budget, Contribution};
//! let mut b = Budget::new("length");
//! b.push(Contribution::rectangular("resolution", 0.5));
//! b.push(Contribution::normal("certificate", 0.2, 2.0));
//! let r = b.evaluate(0.95).unwrap();
//! assert!((r.u_c - (0.25f64 / 3.0 + 0.01).sqrt()).abs() < 1e-15);
//! assert!(r.nu_eff.is_infinite() && (r.k - 1.959964).abs() < 1e-6);
//! ```

mod combine;
mod contribution;
mod graph;
mod model;
mod set;
mod shared;
mod single;

pub use combine::{
    Combined, Term, combine, deserialize_dof, deserialize_opt_dof, en, gum_for_model,
    serialize_dof, serialize_opt_dof, truncate_dof,
};
pub use contribution::{Contribution, Source};
pub use model::LinearModel;
pub use set::{BudgetResult, BudgetSet, Row};
pub use single::{Budget, Correlation};

#[cfg(test)]
mod tests;
