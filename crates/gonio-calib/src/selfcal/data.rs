//! Input of self-calibration: one turn of head differences, and its validation.

use super::{Heads, SelfcalError};

/// One turn of readings at NS equally spaced rotation positions.
#[derive(Debug, Clone, PartialEq)]
pub struct Turn {
    /// Rotation positions θ_i in degrees, `θ_0 + i·360°/NS`.
    pub positions_deg: Vec<f64>,
    /// `differences_arcsec[h − 2][i]` = D_h(θ_i) for heads h = 2..M, arcsec.
    pub differences_arcsec: Vec<Vec<f64>>,
}

impl Turn {
    /// A turn from raw head readings in degrees: `raw_deg[h − 1][i]` is head h's reading at
    /// position i. D_h = (r_h − r_1 − φ_h), wrapped to (−180°, 180°], in arcsec.
    ///
    /// # Errors
    /// [`SelfcalError::ChannelCount`] if there is not one column per head,
    /// [`SelfcalError::ChannelLength`] for a column of the wrong length.
    pub fn from_raw(
        heads: &Heads,
        positions_deg: Vec<f64>,
        raw_deg: &[Vec<f64>],
    ) -> Result<Turn, SelfcalError> {
        let m = heads.len();
        if raw_deg.len() != m {
            return Err(SelfcalError::ChannelCount {
                turn: 1,
                expected: m,
                heads: m,
                found: raw_deg.len(),
            });
        }
        let ns = positions_deg.len();
        for (h, col) in raw_deg.iter().enumerate() {
            if col.len() != ns {
                return Err(SelfcalError::ChannelLength {
                    turn: 1,
                    head: h + 1,
                    expected: ns,
                    found: col.len(),
                });
            }
        }
        let differences_arcsec = (1..m)
            .map(|h| {
                (0..ns)
                    .map(|i| {
                        let d = raw_deg[h][i] - raw_deg[0][i] - heads.angles_deg()[h];
                        let d = d - 360.0 * ((d + 180.0) / 360.0).ceil() + 360.0;
                        d * 3600.0
                    })
                    .collect()
            })
            .collect();
        Ok(Turn {
            positions_deg,
            differences_arcsec,
        })
    }
}

/// Minimum rotation positions per turn.
pub const MIN_POSITIONS: usize = 8;

pub(super) fn validate(heads: &Heads, turns: &[Turn]) -> Result<(usize, f64), SelfcalError> {
    let first = turns.first().ok_or(SelfcalError::NoReadings)?;
    let ns = first.positions_deg.len();
    let m1 = heads.len() - 1;
    let step = 360.0 / ns.max(1) as f64;
    let tol = 1e-3 * step;
    let theta0 = first.positions_deg.first().copied().unwrap_or(0.0);
    for (t, turn) in turns.iter().enumerate() {
        let tn = t + 1;
        if turn.positions_deg.len() < MIN_POSITIONS {
            return Err(SelfcalError::TooFewPositions {
                turn: tn,
                expected: MIN_POSITIONS,
                found: turn.positions_deg.len(),
            });
        }
        if turn.differences_arcsec.len() != m1 {
            return Err(SelfcalError::ChannelCount {
                turn: tn,
                expected: m1,
                heads: heads.len(),
                found: turn.differences_arcsec.len(),
            });
        }
        for (i, &p) in turn.positions_deg.iter().enumerate() {
            if !p.is_finite() {
                return Err(SelfcalError::NotFinite {
                    turn: tn,
                    head: 1,
                    index: i,
                    value: p,
                });
            }
            let want = theta0 + i as f64 * step;
            if turn.positions_deg.len() != ns || (p - want).abs() > tol {
                return Err(SelfcalError::Spacing {
                    turn: tn,
                    index: i,
                    found_deg: p,
                    expected_deg: want,
                });
            }
        }
        for (c, col) in turn.differences_arcsec.iter().enumerate() {
            if col.len() != ns {
                return Err(SelfcalError::ChannelLength {
                    turn: tn,
                    head: c + 2,
                    expected: ns,
                    found: col.len(),
                });
            }
            if let Some((i, &v)) = col.iter().enumerate().find(|(_, v)| !v.is_finite()) {
                return Err(SelfcalError::NotFinite {
                    turn: tn,
                    head: c + 2,
                    index: i,
                    value: v,
                });
            }
        }
    }
    Ok((ns, theta0))
}
