//! The selection's result types: a ring candidate and the selection's outcome.

use super::pair::PairFit;
use super::tracks::Track;
use crate::result::InvalidReason;

/// A ring candidate: a rising track and a falling track to its right, with both edges
/// re-fitted from their own pixels.
#[derive(Debug, Clone, PartialEq)]
pub struct Candidate {
    /// Index of the left (rising) track.
    pub left: usize,
    /// Index of the right (falling) track.
    pub right: usize,
    /// Both edges re-fitted together from their own pixels.
    pub fit: PairFit,
    /// Mean separation over the shared rows, px.
    pub separation_px: f64,
    /// Rows where both edges have pixels after the refit.
    pub shared_rows: u32,
    /// The weaker edge's mean gradient.
    pub gradient: f64,
    /// The weaker edge's strong-pixel share.
    pub strong_share: f64,
    /// The weaker edge's gradient over the stronger's.
    pub balance: f64,
    /// Score, 0 … 1.
    pub score: f64,
    /// The candidate's c (mean of the two curves over the window), px.
    pub c_px: f64,
}

/// The selection's outcome.
#[derive(Debug, Clone, PartialEq)]
pub struct Selection {
    /// The tracks of the frame.
    pub tracks: Vec<Track>,
    /// The best candidate, if any.
    pub best: Option<Candidate>,
    /// Its margin over the runner-up, 0 … 1.
    pub margin: Option<f64>,
    /// Why there is no usable candidate (or why it is not trusted).
    pub reason: Option<InvalidReason>,
}
