//! The ISO 230-2 parameters of an axis from its readings: per target the mean unidirectional
//! deviations x̄↑, x̄↓ and their sample standard deviations s↑, s↓ (n − 1), the reversal value
//! B_i and the repeatabilities R_i↑ = 4s↑, R_i↓, R_i; over the axis A, B, B̄, E, M and R with
//! their unidirectional variants. Arcseconds throughout.
//!
//! A test with approaches in one direction only is the standard's unidirectional test: its
//! bidirectional parameters (and the other direction's) are `None`.

use super::data::{
    AxisReading, Direction, MAX_DEVIATION_ARCSEC, MAX_RUNS, MAX_TARGET_DEG, MAX_TARGETS, TargetKey,
};
use super::error::AxisError;
use serde::{Deserialize, Serialize};
use std::collections::{BTreeMap, BTreeSet, HashMap};

/// The runs the standard's test cycle has in each direction.
pub const STANDARD_RUNS: usize = 5;

/// One target's approaches from one direction.
#[derive(Debug, Clone, PartialEq)]
pub struct Cell {
    /// The deviations x_ij in run order, arcsec.
    pub deviations_arcsec: Vec<f64>,
    /// Their mean x̄, arcsec.
    pub mean_arcsec: f64,
    /// Their sample standard deviation s (n − 1), arcsec.
    pub s_arcsec: f64,
}

impl Cell {
    fn of(deviations_arcsec: Vec<f64>) -> Cell {
        let n = deviations_arcsec.len() as f64;
        let mean_arcsec = deviations_arcsec.iter().sum::<f64>() / n;
        let ss: f64 = deviations_arcsec
            .iter()
            .map(|x| (x - mean_arcsec).powi(2))
            .sum();
        Cell {
            s_arcsec: (ss / (n - 1.0)).sqrt(),
            mean_arcsec,
            deviations_arcsec,
        }
    }

    /// Approaches n.
    pub fn n(&self) -> usize {
        self.deviations_arcsec.len()
    }

    /// The unidirectional repeatability R↑ (or R↓) = 4s, arcsec.
    pub fn repeatability_arcsec(&self) -> f64 {
        4.0 * self.s_arcsec
    }

    /// x̄ + 2s, arcsec.
    pub fn upper_arcsec(&self) -> f64 {
        self.mean_arcsec + 2.0 * self.s_arcsec
    }

    /// x̄ − 2s, arcsec.
    pub fn lower_arcsec(&self) -> f64 {
        self.mean_arcsec - 2.0 * self.s_arcsec
    }
}

/// One target's statistics.
#[derive(Debug, Clone, PartialEq)]
pub struct TargetStats {
    /// Target P_i, degrees.
    pub target_deg: f64,
    /// Approaches in the positive direction.
    pub up: Option<Cell>,
    /// Approaches in the negative direction.
    pub down: Option<Cell>,
}

impl TargetStats {
    /// The approaches from `d`.
    pub fn cell(&self, d: Direction) -> Option<&Cell> {
        match d {
            Direction::Up => self.up.as_ref(),
            Direction::Down => self.down.as_ref(),
        }
    }

    /// The mean bidirectional deviation x̄_i = (x̄↑ + x̄↓)/2, arcsec.
    pub fn mean_arcsec(&self) -> Option<f64> {
        Some((self.up.as_ref()?.mean_arcsec + self.down.as_ref()?.mean_arcsec) / 2.0)
    }

    /// The reversal value B_i = x̄↑ − x̄↓, arcsec.
    pub fn reversal_arcsec(&self) -> Option<f64> {
        Some(self.up.as_ref()?.mean_arcsec - self.down.as_ref()?.mean_arcsec)
    }

    /// The bidirectional repeatability R_i = max(2s↑ + 2s↓ + |B_i|, R_i↑, R_i↓), arcsec.
    pub fn repeatability_arcsec(&self) -> Option<f64> {
        let (u, d) = (self.up.as_ref()?, self.down.as_ref()?);
        let b = self.reversal_arcsec()?;
        Some(
            (2.0 * u.s_arcsec + 2.0 * d.s_arcsec + b.abs())
                .max(u.repeatability_arcsec())
                .max(d.repeatability_arcsec()),
        )
    }
}

/// Which approaches the test has.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Approach {
    /// Both directions at every target.
    Bidirectional,
    /// One direction only: the standard's unidirectional test.
    Unidirectional(Direction),
}

/// The axis's parameters, arcsec; `None` (JSON `null`) where the test has no approaches to
/// define one. The JSON names are the standard's letters: `A_arcsec`, `A_up_arcsec`, ….
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct Parameters {
    /// Bidirectional accuracy A.
    #[serde(rename = "A_arcsec", default)]
    pub a: Option<f64>,
    /// Unidirectional accuracy A↑.
    #[serde(rename = "A_up_arcsec", default)]
    pub a_up: Option<f64>,
    /// Unidirectional accuracy A↓.
    #[serde(rename = "A_down_arcsec", default)]
    pub a_down: Option<f64>,
    /// Reversal value B = max |B_i|.
    #[serde(rename = "B_arcsec", default)]
    pub b: Option<f64>,
    /// Mean reversal value B̄ = mean of B_i.
    #[serde(rename = "B_mean_arcsec", default)]
    pub b_mean: Option<f64>,
    /// Bidirectional systematic positioning error E.
    #[serde(rename = "E_arcsec", default)]
    pub e: Option<f64>,
    /// Unidirectional systematic positioning error E↑.
    #[serde(rename = "E_up_arcsec", default)]
    pub e_up: Option<f64>,
    /// Unidirectional systematic positioning error E↓.
    #[serde(rename = "E_down_arcsec", default)]
    pub e_down: Option<f64>,
    /// Range of the mean bidirectional positioning error M.
    #[serde(rename = "M_arcsec", default)]
    pub m: Option<f64>,
    /// Bidirectional repeatability R = max R_i.
    #[serde(rename = "R_arcsec", default)]
    pub r: Option<f64>,
    /// Unidirectional repeatability R↑ = max R_i↑.
    #[serde(rename = "R_up_arcsec", default)]
    pub r_up: Option<f64>,
    /// Unidirectional repeatability R↓ = max R_i↓.
    #[serde(rename = "R_down_arcsec", default)]
    pub r_down: Option<f64>,
}

impl Parameters {
    /// Every parameter with its name (`A`, `A_up`, …), in the standard's order.
    pub fn named(&self) -> [(&'static str, Option<f64>); 12] {
        [
            ("A", self.a),
            ("A_up", self.a_up),
            ("A_down", self.a_down),
            ("B", self.b),
            ("B_mean", self.b_mean),
            ("E", self.e),
            ("E_up", self.e_up),
            ("E_down", self.e_down),
            ("M", self.m),
            ("R", self.r),
            ("R_up", self.r_up),
            ("R_down", self.r_down),
        ]
    }

    /// A, E, R of one direction.
    pub fn of(&self, d: Direction) -> (Option<f64>, Option<f64>, Option<f64>) {
        match d {
            Direction::Up => (self.a_up, self.e_up, self.r_up),
            Direction::Down => (self.a_down, self.e_down, self.r_down),
        }
    }
}

/// An evaluated test.
#[derive(Debug, Clone, PartialEq)]
pub struct Evaluation {
    /// Every target, ascending.
    pub targets: Vec<TargetStats>,
    /// The parameters.
    pub parameters: Parameters,
    /// The runs, ascending (the same at every target and direction).
    pub runs: Vec<u32>,
    /// Bidirectional, or one direction only.
    pub approach: Approach,
}

impl Evaluation {
    /// Runs n in each direction.
    pub fn n(&self) -> usize {
        self.runs.len()
    }

    /// The directions the test has.
    pub fn directions(&self) -> Vec<Direction> {
        match self.approach {
            Approach::Bidirectional => Direction::BOTH.to_vec(),
            Approach::Unidirectional(d) => vec![d],
        }
    }
}

/// `1–5`, or `1, 3, 4` when the runs are not consecutive.
pub fn runs_text(runs: &[u32]) -> String {
    match (runs.first(), runs.last()) {
        (Some(a), Some(b)) if (b - a) as usize + 1 == runs.len() && runs.len() > 2 => {
            format!("{a}–{b}")
        }
        _ => runs
            .iter()
            .map(u32::to_string)
            .collect::<Vec<_>>()
            .join(", "),
    }
}

fn check(r: &AxisReading, index: usize) -> Result<(), AxisError> {
    let bad = |what, value: f64, expected: String| {
        Err(AxisError::OutOfRange {
            index,
            what,
            value,
            expected,
        })
    };
    if !(r.target_deg.is_finite() && r.target_deg.abs() <= MAX_TARGET_DEG) {
        return bad(
            "target_deg",
            r.target_deg,
            format!("−{MAX_TARGET_DEG} to {MAX_TARGET_DEG}"),
        );
    }
    if !(1..=MAX_RUNS).contains(&r.run) {
        return bad("run", f64::from(r.run), format!("1 to {MAX_RUNS}"));
    }
    if !(r.deviation_arcsec.is_finite() && r.deviation_arcsec.abs() <= MAX_DEVIATION_ARCSEC) {
        return bad(
            "deviation_arcsec",
            r.deviation_arcsec,
            format!("−{MAX_DEVIATION_ARCSEC} to {MAX_DEVIATION_ARCSEC}"),
        );
    }
    Ok(())
}

/// Evaluates an ISO 230-2 test.
///
/// # Errors
/// [`AxisError`]: no readings, a number out of range, a duplicate (target, direction, run), a
/// target without the approaches the others have (a direction or a run), fewer than 2 runs or 2
/// targets, more than [`MAX_TARGETS`] targets.
///
/// ```
/// use gonio_calib::axis::{AxisReading, Direction, evaluate};
/// let mut r = Vec::new();
/// for (t, up, down) in [(0.0, [1.0, 2.0], [-1.0, 0.0]), (90.0, [3.0, 3.0], [1.0, 2.0])] {
///     for run in 1..=2 {
///         r.push(AxisReading { target_deg: t, direction: Direction::Up, run, deviation_arcsec: up[run as usize - 1] });
///         r.push(AxisReading { target_deg: t, direction: Direction::Down, run, deviation_arcsec: down[run as usize - 1] });
///     }
/// }
/// let e = evaluate(&r).unwrap();
/// // x̄↑ = 1.5, 3; x̄↓ = −0.5, 1.5: E = 3 − (−0.5).
/// assert_eq!(e.parameters.e, Some(3.5));
/// assert_eq!(e.parameters.b, Some(2.0));
/// ```
pub fn evaluate(readings: &[AxisReading]) -> Result<Evaluation, AxisError> {
    if readings.is_empty() {
        return Err(AxisError::Empty);
    }
    // (target, direction) → run → reading index.
    let mut cells: BTreeMap<(TargetKey, Direction), BTreeMap<u32, usize>> = BTreeMap::new();
    let mut target_of: HashMap<TargetKey, f64> = HashMap::new();
    for (index, r) in readings.iter().enumerate() {
        check(r, index)?;
        let key = TargetKey::of(r.target_deg);
        target_of.entry(key).or_insert(r.target_deg);
        if target_of.len() > MAX_TARGETS {
            return Err(AxisError::TooManyTargets {
                targets: target_of.len(),
                max: MAX_TARGETS,
            });
        }
        let runs = cells.entry((key, r.direction)).or_default();
        if let Some(&first) = runs.get(&r.run) {
            return Err(AxisError::Duplicate {
                index,
                first,
                target_deg: r.target_deg,
                direction: r.direction,
                run: r.run,
            });
        }
        runs.insert(r.run, index);
    }
    let mut keys: Vec<TargetKey> = target_of.keys().copied().collect();
    keys.sort();
    let directions: BTreeSet<Direction> = cells.keys().map(|(_, d)| *d).collect();
    let approach = if directions.len() == 2 {
        Approach::Bidirectional
    } else {
        Approach::Unidirectional(*directions.first().expect("a reading"))
    };
    let wanted: Vec<Direction> = directions.iter().copied().collect();
    for &k in &keys {
        for &d in &wanted {
            if !cells.contains_key(&(k, d)) {
                return Err(AxisError::MissingDirection {
                    target_deg: target_of[&k],
                    direction: d,
                });
            }
        }
    }
    let runs: BTreeSet<u32> = cells.values().flat_map(|r| r.keys().copied()).collect();
    let runs: Vec<u32> = runs.into_iter().collect();
    for &k in &keys {
        for &d in &wanted {
            let have = &cells[&(k, d)];
            if let Some(&run) = runs.iter().find(|r| !have.contains_key(r)) {
                return Err(AxisError::MissingRun {
                    target_deg: target_of[&k],
                    direction: d,
                    run,
                    runs: runs_text(&runs),
                });
            }
        }
    }
    if runs.len() < 2 {
        return Err(AxisError::TooFewRuns { runs: runs.len() });
    }
    if keys.len() < 2 {
        return Err(AxisError::TooFewTargets {
            targets: keys.len(),
        });
    }
    let cell = |k: TargetKey, d: Direction| {
        cells.get(&(k, d)).map(|runs| {
            Cell::of(
                runs.values()
                    .map(|&i| readings[i].deviation_arcsec)
                    .collect(),
            )
        })
    };
    let targets: Vec<TargetStats> = keys
        .iter()
        .map(|&k| TargetStats {
            target_deg: target_of[&k],
            up: cell(k, Direction::Up),
            down: cell(k, Direction::Down),
        })
        .collect();
    Ok(Evaluation {
        parameters: parameters(&targets, &wanted),
        targets,
        runs,
        approach,
    })
}

fn max(v: impl Iterator<Item = f64>) -> Option<f64> {
    v.reduce(f64::max)
}

fn min(v: impl Iterator<Item = f64>) -> Option<f64> {
    v.reduce(f64::min)
}

fn range(v: impl Iterator<Item = f64> + Clone) -> Option<f64> {
    Some(max(v.clone())? - min(v)?)
}

/// The parameters of targets that have approaches from `directions` at every target.
fn parameters(targets: &[TargetStats], directions: &[Direction]) -> Parameters {
    let one = |d: Direction| {
        let cells = || targets.iter().filter_map(move |t| t.cell(d));
        if cells().next().is_none() {
            return (None, None, None);
        }
        let a = max(cells().map(Cell::upper_arcsec))
            .zip(min(cells().map(Cell::lower_arcsec)))
            .map(|(hi, lo)| hi - lo);
        let e = range(cells().map(|c| c.mean_arcsec));
        let r = max(cells().map(Cell::repeatability_arcsec));
        (a, e, r)
    };
    let (a_up, e_up, r_up) = one(Direction::Up);
    let (a_down, e_down, r_down) = one(Direction::Down);
    let mut p = Parameters {
        a_up,
        a_down,
        e_up,
        e_down,
        r_up,
        r_down,
        ..Parameters::default()
    };
    if directions.len() == 2 {
        let both = || {
            targets
                .iter()
                .flat_map(|t| t.up.iter().chain(t.down.iter()))
        };
        let reversals = || targets.iter().filter_map(TargetStats::reversal_arcsec);
        p.a = max(both().map(Cell::upper_arcsec))
            .zip(min(both().map(Cell::lower_arcsec)))
            .map(|(hi, lo)| hi - lo);
        p.b = max(reversals().map(f64::abs));
        p.b_mean = Some(reversals().sum::<f64>() / targets.len() as f64);
        p.e = range(both().map(|c| c.mean_arcsec));
        p.m = range(targets.iter().filter_map(TargetStats::mean_arcsec));
        p.r = max(targets.iter().filter_map(TargetStats::repeatability_arcsec));
    }
    p
}
