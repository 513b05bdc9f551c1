//! The readings CSV of `gonio shift-angle` and `gonio joint`, as the lab bench writes it:
//! `shift_deg,start_face,step,reading_arcsec`, or with a `repeat` column before the reading
//! when the plan repeats a reading (or has closure readings), after one `#` comment line.
//! Readings in arcseconds, written with the decimals they were measured with.
//!
//! ```
//! use gonio_lab::plan::PlannedReading;
//! use gonio_lab::readings::{Row, csv};
//! let planned = PlannedReading { shift_deg: 5.0, start_face: 2, step: 3, repeat: 1, closure: false };
//! let rows = [Row { planned, value_arcsec: -0.25, decimals: 3 }];
//! assert_eq!(csv("# x", true, &rows), "# x\nshift_deg,start_face,step,repeat,reading_arcsec\n5,2,3,1,-0.250\n");
//! ```

use crate::plan::{Plan, PlannedReading};
use std::fmt::Write as _;

/// One reading of the CSV (of a shift-angle plan by default; `P` the plan's position).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Row<P = PlannedReading> {
    /// Which reading of the plan it is.
    pub planned: P,
    /// The reading (the plan's `x_sign` applied), arcsec.
    pub value_arcsec: f64,
    /// Decimals to write it with.
    pub decimals: usize,
}

/// The CSV text: `comment` (one `#` line), the header, one line a row.
pub fn csv(comment: &str, with_repeat: bool, rows: &[Row]) -> String {
    let mut csv = String::with_capacity(rows.len() * 24 + comment.len() + 64);
    csv.push_str(comment);
    csv.push('\n');
    csv.push_str(if with_repeat {
        "shift_deg,start_face,step,repeat,reading_arcsec\n"
    } else {
        "shift_deg,start_face,step,reading_arcsec\n"
    });
    for r in rows {
        let (p, v, d) = (&r.planned, r.value_arcsec, r.decimals);
        if with_repeat {
            let _ = writeln!(
                csv,
                "{},{},{},{},{v:.d$}",
                p.shift_deg, p.start_face, p.step, p.repeat
            );
        } else {
            let _ = writeln!(csv, "{},{},{},{v:.d$}", p.shift_deg, p.start_face, p.step);
        }
    }
    csv
}

/// A planned reading in words: `shift 5°, start face 2, step 3`, `…, step 25 (closure)`,
/// `…, repeat 2`.
pub fn describe(plan: &Plan, p: &PlannedReading) -> String {
    format!(
        "shift {}°, start face {}, step {}{}",
        p.shift_deg,
        p.start_face,
        if p.closure {
            format!("{} (closure)", plan.faces + 1)
        } else {
            p.step.to_string()
        },
        if p.repeat > 1 && !p.closure {
            format!(", repeat {}", p.repeat)
        } else {
            String::new()
        }
    )
}
