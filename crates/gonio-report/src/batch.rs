//! A mounting batch (`gonio mount … --json`) as the report reads it: only the fields it plots,
//! every other field ignored, so that records which gain fields stay readable.

use gonio_station::fit::Sample;
use serde::{Deserialize, Deserializer};

fn nan() -> f64 {
    f64::NAN
}

fn nan_or<'de, D: Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
    Ok(Option::<f64>::deserialize(d)?.unwrap_or(f64::NAN))
}

/// One measuring turn.
#[derive(Debug, Clone, PartialEq, Deserialize)]
pub struct TurnView {
    /// The valid frames' (θ, c).
    #[serde(default)]
    pub samples: Vec<Sample>,
    /// Eccentricity, µm.
    #[serde(default)]
    pub e_um: Option<f64>,
    /// Why the turn was measured (`initial`, `verify`, `remeasure`), if recorded.
    #[serde(default)]
    pub kind: Option<String>,
}

/// One push.
#[derive(Debug, Clone, PartialEq, Deserialize)]
pub struct PushView {
    /// Eccentricity before the push, µm.
    #[serde(deserialize_with = "nan_or")]
    pub e_before_um: f64,
}

/// One part.
#[derive(Debug, Clone, PartialEq, Deserialize)]
pub struct PartView {
    /// Serial number.
    pub serial: String,
    /// First measured eccentricity, µm (NaN if never measured).
    #[serde(deserialize_with = "nan_or", default)]
    pub initial_e_um: f64,
    /// Last measured eccentricity, µm (NaN if never measured).
    #[serde(deserialize_with = "nan_or", default)]
    pub final_e_um: f64,
    /// Pushes made.
    pub pushes: u32,
    /// Time for the part, s (NaN: `null`, the clock failed).
    #[serde(deserialize_with = "nan_or", default = "nan")]
    pub time_s: f64,
    /// How it ended (`accepted`, `rejected_…`).
    pub result: String,
    /// Measuring turns.
    #[serde(default)]
    pub turns: Vec<TurnView>,
    /// Pushes.
    #[serde(default)]
    pub push_log: Vec<PushView>,
}

impl PartView {
    /// The measured e before each push, then the final e (µm), finite values only.
    pub fn e_sequence(&self) -> Vec<f64> {
        self.push_log
            .iter()
            .map(|p| p.e_before_um)
            .chain(std::iter::once(self.final_e_um))
            .filter(|e| e.is_finite())
            .collect()
    }
}

/// The batch summary.
#[derive(Debug, Clone, PartialEq, Deserialize)]
pub struct SummaryView {
    /// Parts.
    pub parts: usize,
    /// Mean time per part, s (NaN: `null`, no part's time known).
    #[serde(deserialize_with = "nan_or", default = "nan")]
    pub mean_time_s: f64,
    /// Mean final e, µm (NaN: `null`, no part measured by a trusted turn).
    #[serde(deserialize_with = "nan_or", default = "nan")]
    pub mean_final_e_um: f64,
    /// Mean pushes per part.
    pub mean_pushes: f64,
    /// Most pushes on one part.
    pub max_pushes: u32,
    /// Parts rejected.
    #[serde(default)]
    pub rejected: usize,
}

/// A mounting batch.
#[derive(Debug, Clone, PartialEq, Deserialize)]
pub struct BatchView {
    /// Seed of a simulated batch.
    #[serde(default)]
    pub seed: Option<u64>,
    /// Push strategy.
    #[serde(default)]
    pub strategy: String,
    /// Recipe name.
    #[serde(default)]
    pub recipe: String,
    /// Every part.
    pub parts: Vec<PartView>,
    /// Summary.
    pub summary: SummaryView,
}
