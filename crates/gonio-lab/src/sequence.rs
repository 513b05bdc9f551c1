//! What an acquisition walks: a measuring plan's positions in measuring order, how each is named
//! to the operator and in the logs, which earlier position each is checked against, and the CSV
//! its readings make. Two plans are sequences: the shift-angle plan ([`Plan`], implemented here)
//! and the ISO 230-2 test cycle of a rotary axis ([`crate::axis::AxisPlan`]).
//!
//! ```
//! use gonio_lab::plan::Plan;
//! use gonio_lab::sequence::Sequence;
//! let p = Plan::parse_text("p", "faces = 3\nshifts_deg = [0]\nstart_faces = [2]\n").unwrap();
//! let first = p.positions()[0];
//! assert_eq!(p.fields(&first), "shift_deg=0 start_face=2 step=1 repeat=1");
//! assert_eq!(p.instruction(&first), "shift 0°, start face 2, step 1: turn the polygon to face 2");
//! ```

use crate::plan::{ModeRule, Plan, PlannedReading};
use crate::readings::{self, Row};
use gonio_calib::shift_angle::ShiftKey;
use std::collections::HashMap;

/// Which check a position gets.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum CheckKind {
    /// A run's closure: the same face read again at the end of a turn.
    Closure,
    /// A repeat against the first.
    Drift,
}

/// A measuring plan an acquisition can walk.
pub trait Sequence {
    /// One position of the plan.
    type Position: Copy + PartialEq + std::fmt::Debug;

    /// The command that acquires it (`shift-angle`, `axis`), for titles and logs.
    fn command(&self) -> &'static str;

    /// Every position, in measuring order.
    fn positions(&self) -> Vec<Self::Position>;

    /// A fingerprint of what the plan asks for: a journal written for one plan is refused for
    /// another.
    fn fingerprint(&self) -> u64;

    /// +1, or −1 when the autocollimator's X counts against the readings' sign.
    fn x_sign(&self) -> f64;

    /// Which kind of reading the plan allows.
    fn mode(&self) -> ModeRule;

    /// A position in words, for the raw log (`shift 5°, start face 2, step 3`).
    fn describe(&self, p: &Self::Position) -> String;

    /// A position as `key=value` fields, for the line protocol (`NEXT …`, `READ …`).
    fn fields(&self, p: &Self::Position) -> String;

    /// What the operator does to reach a position.
    fn instruction(&self, p: &Self::Position) -> String;

    /// For each position (of [`Sequence::positions`]), the earlier one it is checked against.
    fn partners(&self, positions: &[Self::Position]) -> Vec<Option<(CheckKind, usize)>>;

    /// The limit of a check, arcsec, given the instrument's own (3·√2·σ/√K).
    fn check_limit_arcsec(&self, instrument_arcsec: f64) -> f64 {
        instrument_arcsec
    }

    /// The readings CSV: `comment` (one `#` line), the header, one line a row.
    fn csv(&self, comment: &str, rows: &[Row<Self::Position>]) -> String;
}

impl Sequence for Plan {
    type Position = PlannedReading;

    fn command(&self) -> &'static str {
        "shift-angle"
    }

    fn positions(&self) -> Vec<PlannedReading> {
        self.readings()
    }

    fn fingerprint(&self) -> u64 {
        Plan::fingerprint(self)
    }

    fn x_sign(&self) -> f64 {
        self.x_sign
    }

    fn mode(&self) -> ModeRule {
        self.mode
    }

    fn describe(&self, p: &PlannedReading) -> String {
        readings::describe(self, p)
    }

    fn fields(&self, p: &PlannedReading) -> String {
        format!(
            "shift_deg={} start_face={} step={} repeat={}",
            p.shift_deg, p.start_face, p.step, p.repeat
        )
    }

    fn instruction(&self, p: &PlannedReading) -> String {
        let step = if p.closure {
            format!("step {} (closure)", self.faces + 1)
        } else {
            format!("step {}", p.step)
        };
        format!(
            "shift {}°, start face {}, {step}: turn the polygon to face {}",
            p.shift_deg,
            p.start_face,
            self.face_at(p.start_face, p.step)
        )
    }

    /// A closure reading against its run's step 1; a repeat against repeat 1.
    fn partners(&self, positions: &[PlannedReading]) -> Vec<Option<(CheckKind, usize)>> {
        let lookup: HashMap<(ShiftKey, usize, usize, u32, bool), usize> = positions
            .iter()
            .enumerate()
            .map(|(i, p)| {
                let key = (
                    ShiftKey::of(p.shift_deg),
                    p.start_face,
                    p.step,
                    p.repeat,
                    p.closure,
                );
                (key, i)
            })
            .collect();
        positions
            .iter()
            .map(|p| {
                let key = ShiftKey::of(p.shift_deg);
                if p.closure {
                    let repeats = self
                        .shifts
                        .iter()
                        .find(|s| ShiftKey::of(s.shift_deg) == key)
                        .map_or(1, |s| s.repeats);
                    lookup
                        .get(&(key, p.start_face, 1, p.repeat - repeats, false))
                        .map(|&i| (CheckKind::Closure, i))
                } else if p.repeat > 1 {
                    lookup
                        .get(&(key, p.start_face, p.step, 1, false))
                        .map(|&i| (CheckKind::Drift, i))
                } else {
                    None
                }
            })
            .collect()
    }

    fn csv(&self, comment: &str, rows: &[Row]) -> String {
        readings::csv(comment, self.has_repeats(), rows)
    }
}
