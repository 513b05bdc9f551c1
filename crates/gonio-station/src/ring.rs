//! The ring's roundness carried from one turn of a part to the next: the roundness harmonics a
//! trusted turn fitted, with their standard uncertainties, px.
//!
//! The ring's roundness error belongs to the ring, and the ring turns with the shaft: in
//! servo-angle coordinates it is the same on every turn of the part (a push moves the grating
//! sideways, it does not turn it; the parallax of a 100 µm move on a 20 mm ring shifts an order-4
//! phase by ≈ 1.2°, 0.01 px). A later turn's least-squares fit takes it as the prior of its
//! roundness coefficients (a Gaussian centred on the carried value, of its uncertainty), so a
//! turn over part of a revolution still separates the eccentricity from the roundness
//! (`docs/station-timing.md`). Without it, a 270° arc leaves e ≈ 4× less certain than a full
//! turn (the information bound of that arc), with it ≈ 1.5×.
//!
//! What does change with the part's position is the ring's chord: the camera sees the ring
//! where its row line crosses it, at e·cos φ − e²·sin²φ/(2R) (φ = θ − θ_e, R the ring's radius),
//! whose order-2 part e²/(4R)·cos 2φ a turn fits as roundness (0.17 px at e = 100 µm on a
//! 20 mm ring). A carried prior exchanges the chord of the turn it came from for the one
//! expected on the next turn ([`RoundnessPrior::rechorded`]).
//!
//! ```
//! use gonio_station::ring::RoundnessPrior;
//! let p = RoundnessPrior { orders: vec![2], coefficients_px: vec![[0.3, -0.4]], u_px: vec![[0.03, 0.03]] };
//! assert_eq!(p.term(2), Some(([0.3, -0.4], [0.03, 0.03])));
//! assert_eq!(p.term(3), None);
//! assert!(p.validate().is_ok());
//! ```

use crate::StationError;
use serde::{Deserialize, Serialize};

/// The roundness harmonics of a ring as one turn measured them.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RoundnessPrior {
    /// Harmonic orders (2 and up).
    pub orders: Vec<u32>,
    /// Per order, the coefficients `[a_k, b_k]` of `a_k·cos kθ + b_k·sin kθ`, px.
    pub coefficients_px: Vec<[f64; 2]>,
    /// Per order, the standard uncertainties of `a_k` and `b_k`, px.
    pub u_px: Vec<[f64; 2]>,
}

/// The order-2 coefficients `[a₂, b₂]` (of cos 2θ and sin 2θ) the ring's chord adds to the
/// column at eccentricity `e_px` toward `theta_e_deg`, on a ring of `radius_px`: e²/(4R) along
/// 2θ_e, px.
pub fn chord_px(e_px: f64, theta_e_deg: f64, radius_px: f64) -> [f64; 2] {
    let k = e_px * e_px / (4.0 * radius_px);
    let t = (2.0 * theta_e_deg).to_radians();
    [k * t.cos(), k * t.sin()]
}

impl RoundnessPrior {
    /// The prior of a turn expected at eccentricity `to` (e px, θ_e degrees) from one fitted on
    /// a turn at `from`: the order-2 centre loses the chord of `from` and gains that of `to`
    /// (the ring's own shape stays), on a ring of `radius_px`.
    pub fn rechorded(&self, from: (f64, f64), to: (f64, f64), radius_px: f64) -> RoundnessPrior {
        let mut p = self.clone();
        if let Some(i) = p.orders.iter().position(|&k| k == 2) {
            let (a, b) = (
                chord_px(from.0, from.1, radius_px),
                chord_px(to.0, to.1, radius_px),
            );
            let c = &mut p.coefficients_px[i];
            c[0] += b[0] - a[0];
            c[1] += b[1] - a[1];
        }
        p
    }

    /// The coefficients and their uncertainties of order `k`, if carried.
    pub fn term(&self, k: u32) -> Option<([f64; 2], [f64; 2])> {
        let i = self.orders.iter().position(|&o| o == k)?;
        Some((*self.coefficients_px.get(i)?, *self.u_px.get(i)?))
    }

    /// Checks the prior: one coefficient pair and one uncertainty pair per order, finite,
    /// uncertainties above 0.
    ///
    /// # Errors
    /// [`StationError::OutOfRange`] naming what is wrong (`roundness prior`).
    pub fn validate(&self) -> Result<(), StationError> {
        let n = self.orders.len();
        if self.coefficients_px.len() != n || self.u_px.len() != n {
            return Err(StationError::OutOfRange {
                name: "roundness prior",
                value: n as f64,
                expected: "one coefficient pair and one uncertainty pair per order",
            });
        }
        for (c, u) in self.coefficients_px.iter().zip(&self.u_px) {
            if !c.iter().all(|v| v.is_finite()) {
                return Err(StationError::OutOfRange {
                    name: "roundness prior",
                    value: c[0] + c[1],
                    expected: "finite coefficients",
                });
            }
            if let Some(&v) = u.iter().find(|v| !(v.is_finite() && **v > 0.0)) {
                return Err(StationError::OutOfRange {
                    name: "roundness prior",
                    value: v,
                    expected: "uncertainties that are finite and > 0",
                });
            }
        }
        Ok(())
    }
}
