//! An autocollimator log and its measuring plan → the readings of the shift-angle CSV
//! (`gonio import elcomat`): the plan says which reading each line of the log is.
//!
//! The log must hold one kind of reading (absolute or relative; the plan's `mode` may name it)
//! and exactly as many readings as the plan; X is multiplied by the plan's `x_sign` and keeps
//! the decimals the instrument sent. Errors are [`ImportError`]s naming the log's line.
//!
//! ```
//! use gonio_lab::{import, log, plan::Plan};
//! let plan = Plan::parse_text("p.toml", "faces = 3\nshifts_deg = [0]\nstart_faces = [1]\n").unwrap();
//! let log = log::parse("log", "4 003 +1.0 0\r4 003 -0.5 0\r4 003 +0.25 0\r").unwrap();
//! let rows = import::assign(&plan, "p.toml", "log", &log).unwrap();
//! assert_eq!(rows[1].planned.step, 2);
//! let csv = gonio_lab::readings::csv("# test", plan.has_repeats(), &rows);
//! assert_eq!(csv, "# test\nshift_deg,start_face,step,reading_arcsec\n0,1,1,1.0\n0,1,2,-0.5\n0,1,3,0.25\n");
//! ```

use crate::log::{LogReading, Mode};
use crate::plan::{ModeRule, Plan};
use crate::readings::Row;

/// A log that does not fit its plan.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum ImportError {
    /// A reading of the other kind than the log's (or the plan's) first.
    #[error("{log}:{line}:1: a {} reading, expected {} readings only ({})", found.name(), expected.name(), if *plan_says { format!("the plan says mode = \"{}\"", expected.name()) } else { format!("line {first_line} is {}", expected.name()) })]
    MixedModes {
        /// The log's name.
        log: String,
        /// Line of the offending reading.
        line: usize,
        /// Its kind.
        found: Mode,
        /// The kind expected.
        expected: Mode,
        /// Whether the plan's `mode` says so (else the log's first reading does).
        plan_says: bool,
        /// Line of the log's first reading.
        first_line: usize,
    },
    /// More readings than the plan has.
    #[error("{log}:{line}:1: reading {} is beyond the plan's {planned} readings (the plan ends with {last})", planned + 1)]
    BeyondPlan {
        /// The log's name.
        log: String,
        /// Line of the first reading too many.
        line: usize,
        /// Readings the plan has.
        planned: usize,
        /// The plan's last reading, described.
        last: String,
    },
    /// Fewer readings than the plan has.
    #[error(
        "{log}: {found} readings, the plan {plan} expects {planned}: {last}; the next planned reading is {next}"
    )]
    Short {
        /// The log's name.
        log: String,
        /// The plan's name.
        plan: String,
        /// Readings in the log.
        found: usize,
        /// Readings the plan has.
        planned: usize,
        /// The log's last reading, described.
        last: String,
        /// The first planned reading missing, described.
        next: String,
    },
}

/// Pairs every reading of `log` with its planned reading.
///
/// # Errors
/// [`ImportError`]: mixed kinds of reading, or more or fewer readings than planned.
pub fn assign(
    plan: &Plan,
    plan_name: &str,
    log_name: &str,
    log: &[LogReading],
) -> Result<Vec<Row>, ImportError> {
    let planned = plan.readings();
    // One kind of reading, the one the plan allows.
    if let Some(first) = log.first() {
        let wanted = match plan.mode {
            ModeRule::Absolute => Some(Mode::Absolute),
            ModeRule::Relative => Some(Mode::Relative),
            ModeRule::Any => None,
        };
        let expected = wanted.unwrap_or(first.mode);
        if let Some(r) = log.iter().find(|r| r.mode != expected) {
            return Err(ImportError::MixedModes {
                log: log_name.to_string(),
                line: r.line,
                found: r.mode,
                expected,
                plan_says: wanted.is_some(),
                first_line: first.line,
            });
        }
    }
    let where_in_plan = |k: usize| crate::readings::describe(plan, &planned[k]);
    if log.len() > planned.len() {
        return Err(ImportError::BeyondPlan {
            log: log_name.to_string(),
            line: log[planned.len()].line,
            planned: planned.len(),
            last: where_in_plan(planned.len() - 1),
        });
    }
    if log.len() < planned.len() {
        return Err(ImportError::Short {
            log: log_name.to_string(),
            plan: plan_name.to_string(),
            found: log.len(),
            planned: planned.len(),
            last: log.last().map_or("no readings".to_string(), |r| {
                format!(
                    "its last reading (line {}) is {}",
                    r.line,
                    where_in_plan(log.len() - 1)
                )
            }),
            next: where_in_plan(log.len()),
        });
    }
    Ok(planned
        .iter()
        .zip(log)
        .map(|(p, r)| Row {
            planned: *p,
            value_arcsec: plan.x_sign * r.x_arcsec,
            decimals: r.x_decimals,
        })
        .collect())
}
