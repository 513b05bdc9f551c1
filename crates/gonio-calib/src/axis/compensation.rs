//! The controller's compensation table of an axis: the correction to add to the commanded
//! position at each target, per direction of approach (−x̄↑, −x̄↓), and one value for a
//! controller that compensates both directions alike (−x̄_i, the mean of the two; its backlash
//! compensation takes B̄). Arcseconds.

use super::parameters::{Evaluation, TargetStats};
use serde::{Deserialize, Serialize};

/// One target's corrections.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct AxisCompensation {
    /// Target, degrees.
    pub target_deg: f64,
    /// −x̄↑, arcsec (`null` without positive approaches).
    pub correction_up_arcsec: Option<f64>,
    /// −x̄↓, arcsec (`null` without negative approaches).
    pub correction_down_arcsec: Option<f64>,
    /// −(x̄↑ + x̄↓)/2, or the one direction's correction in a unidirectional test, arcsec.
    pub correction_mean_arcsec: f64,
}

/// The table of an evaluated test, one row a target.
pub fn compensation(eval: &Evaluation) -> Vec<AxisCompensation> {
    eval.targets.iter().map(row).collect()
}

fn row(t: &TargetStats) -> AxisCompensation {
    let up = t.up.as_ref().map(|c| -c.mean_arcsec);
    let down = t.down.as_ref().map(|c| -c.mean_arcsec);
    AxisCompensation {
        target_deg: t.target_deg,
        correction_up_arcsec: up,
        correction_down_arcsec: down,
        correction_mean_arcsec: match (up, down) {
            (Some(u), Some(d)) => (u + d) / 2.0,
            (Some(v), None) | (None, Some(v)) => v,
            (None, None) => 0.0,
        },
    }
}
