//! The readings of an ISO 230-2 test of a rotary axis: one approach a reading, each with its
//! target (degrees), the direction it was approached from, its run and its deviation x_ij
//! (position reached − target, arcseconds).

use serde::{Deserialize, Serialize};

/// Largest |target|, degrees (100 turns of a multi-turn axis).
pub const MAX_TARGET_DEG: f64 = 36_000.0;

/// Largest run number.
pub const MAX_RUNS: u32 = 1_000;

/// Largest |deviation| or |reading|, arcsec (≈ 278°: far beyond any axis worth a test, small
/// enough that every sum of the evaluation stays finite).
pub const MAX_DEVIATION_ARCSEC: f64 = 1.0e6;

/// Most targets of one test.
pub const MAX_TARGETS: usize = 100_000;

/// The sense in which a target is approached.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
pub enum Direction {
    /// Positive sense (↑, `+`).
    #[serde(rename = "+")]
    Up,
    /// Negative sense (↓, `-`).
    #[serde(rename = "-")]
    Down,
}

impl Direction {
    /// Both, positive first.
    pub const BOTH: [Direction; 2] = [Direction::Up, Direction::Down];

    /// `+` or `-`, as files write it.
    pub fn sign(self) -> &'static str {
        match self {
            Direction::Up => "+",
            Direction::Down => "-",
        }
    }

    /// `positive` or `negative`.
    pub fn word(self) -> &'static str {
        match self {
            Direction::Up => "positive",
            Direction::Down => "negative",
        }
    }

    /// `+` (or `↑`) and `-` (or the Unicode minus, `↓`).
    pub fn parse(s: &str) -> Option<Direction> {
        match s {
            "+" | "↑" => Some(Direction::Up),
            "-" | "−" | "↓" => Some(Direction::Down),
            _ => None,
        }
    }

    /// +1 or −1.
    pub fn factor(self) -> f64 {
        match self {
            Direction::Up => 1.0,
            Direction::Down => -1.0,
        }
    }
}

/// One approach to a target.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AxisReading {
    /// Target position P_i, degrees.
    pub target_deg: f64,
    /// The sense it was approached in.
    pub direction: Direction,
    /// Run j (1-based).
    pub run: u32,
    /// Deviation x_ij = P_ij − P_i, arcsec.
    pub deviation_arcsec: f64,
}

/// A target as a key: its angle rounded to 1 µ° (two targets closer than that are one).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct TargetKey(pub i64);

impl TargetKey {
    /// The key of a target in degrees.
    pub fn of(target_deg: f64) -> TargetKey {
        TargetKey((target_deg * 1e6).round() as i64)
    }
}
