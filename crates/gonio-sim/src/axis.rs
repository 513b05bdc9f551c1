//! A rotary axis under test (ISO 230-2): where it stops when told to go to a target from one
//! side, with a known systematic error, backlash and repeatability.
//!
//! ```text
//! x(P, d, j) = e(P) + d·b/2 + ε(P, d, j),   e(P) = Σ_k A_k·sin(k·P + φ_k) + c·P/360°   [arcsec]
//! ```
//!
//! d = +1 for a positive approach and −1 for a negative one, b the backlash (so that the reversal
//! value B_i is b at every target), ε normal with the repeatability σ, drawn from the seed and
//! the approach (target, direction, run) alone: the same approach stops at the same place in
//! whatever order the approaches come, and the same seed gives the same numbers. The axis's own
//! parameters ([`AxisModel::truth`]) are the standard's definitions applied to x̄↑ = e + b/2,
//! x̄↓ = e − b/2 and s = σ.
//!
//! ```
//! use gonio_calib::axis::Direction;
//! use gonio_sim::axis::AxisModel;
//! let m = AxisModel::default_with_seed(3);
//! let a = m.deviation_arcsec(90.0, Direction::Up, 2);
//! assert_eq!(a, m.deviation_arcsec(90.0, Direction::Up, 2));
//! let t = m.truth(&[0.0, 90.0, 180.0, 270.0]);
//! assert_eq!(t.parameters.b, Some(m.backlash_arcsec));
//! ```

use crate::SimError;
use crate::encoder::HarmonicArcsec;
use gonio_calib::axis::{AxisReading, Direction, Parameters, TargetKey};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};
use serde::{Deserialize, Serialize};

/// Largest backlash, repeatability or amplitude of a model, arcsec (one degree).
pub const MAX_AXIS_ARCSEC: f64 = 3600.0;

/// Most harmonics of an axis model.
pub const MAX_AXIS_HARMONICS: usize = 1000;

/// A rotary axis's positioning behaviour.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AxisModel {
    /// The periodic part of the systematic error e(P).
    pub harmonics: Vec<HarmonicArcsec>,
    /// A scale error: e grows by this much per turn, arcsec.
    pub scale_arcsec_per_turn: f64,
    /// x̄↑ − x̄↓ at every target, arcsec.
    pub backlash_arcsec: f64,
    /// Standard deviation σ of one approach, arcsec (R↑ = 4σ).
    pub repeatability_arcsec: f64,
    /// Seed of the approaches' scatter.
    pub seed: u64,
}

/// The true behaviour at one target.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct TrueTarget {
    /// Target, degrees.
    pub target_deg: f64,
    /// e(P), arcsec.
    pub systematic_arcsec: f64,
    /// x̄↑ = e + b/2, arcsec.
    pub mean_up_arcsec: f64,
    /// x̄↓ = e − b/2, arcsec.
    pub mean_down_arcsec: f64,
    /// s = σ, arcsec.
    pub s_arcsec: f64,
}

/// The axis's own parameters at a set of targets.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct AxisTruth {
    /// The model.
    pub model: AxisModel,
    /// Every target.
    pub targets: Vec<TrueTarget>,
    /// A, B, E, M, R … of the axis (arcsec, the JSON names of `gonio axis`).
    pub parameters: Parameters,
}

/// splitmix64: a well-mixed 64-bit value of `x`.
fn mix(mut x: u64) -> u64 {
    x = x.wrapping_add(0x9e37_79b9_7f4a_7c15);
    x = (x ^ (x >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    x = (x ^ (x >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    x ^ (x >> 31)
}

/// A generator for one approach: the seed, the approach and `stream` (what the draw is for).
pub fn approach_rng(
    seed: u64,
    target_deg: f64,
    direction: Direction,
    run: u32,
    stream: u64,
) -> ChaCha8Rng {
    let key = mix(seed
        ^ mix(TargetKey::of(target_deg).0 as u64
            ^ mix(u64::from(run) << 1 | u64::from(direction == Direction::Down))));
    let mut r = ChaCha8Rng::seed_from_u64(key);
    r.set_stream(stream);
    r
}

impl AxisModel {
    /// The default axis: a first-order error of 3″ (an eccentric scale), 1.2″ of second order,
    /// smaller higher orders, 2″ of scale error per turn, 1.5″ backlash and σ = 0.3″.
    pub fn default_with_seed(seed: u64) -> AxisModel {
        let h = |order, amplitude_arcsec, phase_rad| HarmonicArcsec {
            order,
            amplitude_arcsec,
            phase_rad,
        };
        AxisModel {
            harmonics: vec![
                h(1, 3.0, 0.7),
                h(2, 1.2, -1.9),
                h(3, 0.5, 2.4),
                h(8, 0.3, 0.1),
            ],
            scale_arcsec_per_turn: 2.0,
            backlash_arcsec: 1.5,
            repeatability_arcsec: 0.3,
            seed,
        }
    }

    /// Checks the model.
    ///
    /// # Errors
    /// [`SimError::Parameter`]: order 0, a number not finite, an amplitude, backlash or σ
    /// outside ±[`MAX_AXIS_ARCSEC`] (σ ≥ 0), more than [`MAX_AXIS_HARMONICS`] harmonics.
    pub fn validate(&self) -> Result<(), SimError> {
        let within = |v: f64| v.is_finite() && v.abs() <= MAX_AXIS_ARCSEC;
        if self.harmonics.len() > MAX_AXIS_HARMONICS {
            return Err(SimError::parameter(
                "harmonics",
                self.harmonics.len(),
                "at most 1000 harmonics",
            ));
        }
        for h in &self.harmonics {
            if h.order == 0 || !within(h.amplitude_arcsec) || !h.phase_rad.is_finite() {
                return Err(SimError::parameter(
                    "harmonic",
                    format!(
                        "order {} amplitude {} phase {}",
                        h.order, h.amplitude_arcsec, h.phase_rad
                    ),
                    "order ≥ 1, |amplitude| ≤ 3600 arcsec, a finite phase",
                ));
            }
        }
        for (name, v) in [
            ("scale_arcsec_per_turn", self.scale_arcsec_per_turn),
            ("backlash_arcsec", self.backlash_arcsec),
        ] {
            if !within(v) {
                return Err(SimError::parameter(name, v, "−3600 to 3600 arcsec"));
            }
        }
        if !(within(self.repeatability_arcsec) && self.repeatability_arcsec >= 0.0) {
            return Err(SimError::parameter(
                "repeatability_arcsec",
                self.repeatability_arcsec,
                "0 to 3600 arcsec",
            ));
        }
        Ok(())
    }

    /// The systematic error e(P) at `target_deg`, arcsec.
    pub fn systematic_arcsec(&self, target_deg: f64) -> f64 {
        let theta = target_deg.to_radians();
        self.harmonics
            .iter()
            .map(|h| h.amplitude_arcsec * (f64::from(h.order) * theta + h.phase_rad).sin())
            .sum::<f64>()
            + self.scale_arcsec_per_turn * target_deg / 360.0
    }

    /// Where the axis stops, less the target, when run `run` approaches `target_deg` from
    /// `direction`, arcsec.
    pub fn deviation_arcsec(&self, target_deg: f64, direction: Direction, run: u32) -> f64 {
        let scatter = if self.repeatability_arcsec > 0.0 {
            Normal::new(0.0, self.repeatability_arcsec)
                .expect("σ checked")
                .sample(&mut approach_rng(self.seed, target_deg, direction, run, 1))
        } else {
            0.0
        };
        self.systematic_arcsec(target_deg)
            + direction.factor() * self.backlash_arcsec / 2.0
            + scatter
    }

    /// The axis's own parameters at `targets_deg` (at least one target).
    pub fn truth(&self, targets_deg: &[f64]) -> AxisTruth {
        let (b, s) = (self.backlash_arcsec, self.repeatability_arcsec);
        let targets: Vec<TrueTarget> = targets_deg
            .iter()
            .map(|&t| {
                let e = self.systematic_arcsec(t);
                TrueTarget {
                    target_deg: t,
                    systematic_arcsec: e,
                    mean_up_arcsec: e + b / 2.0,
                    mean_down_arcsec: e - b / 2.0,
                    s_arcsec: s,
                }
            })
            .collect();
        let span = |v: &mut dyn Iterator<Item = f64>| {
            let (lo, hi) = v.fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), x| {
                (lo.min(x), hi.max(x))
            });
            hi - lo
        };
        let up = || targets.iter().map(|t| t.mean_up_arcsec);
        let down = || targets.iter().map(|t| t.mean_down_arcsec);
        let e_up = span(&mut up());
        let e_down = span(&mut down());
        let e = span(&mut up().chain(down()));
        AxisTruth {
            parameters: Parameters {
                a: Some(e + 4.0 * s),
                a_up: Some(e_up + 4.0 * s),
                a_down: Some(e_down + 4.0 * s),
                b: Some(b.abs()),
                b_mean: Some(b),
                e: Some(e),
                e_up: Some(e_up),
                e_down: Some(e_down),
                m: Some(span(&mut targets.iter().map(|t| t.systematic_arcsec))),
                r: Some(4.0 * s + b.abs()),
                r_up: Some(4.0 * s),
                r_down: Some(4.0 * s),
            },
            model: self.clone(),
            targets,
        }
    }
}

/// A simulated ISO 230-2 test: which approaches, and the reference that reads them.
#[derive(Debug, Clone, PartialEq)]
pub struct AxisTest {
    /// Targets, degrees, ascending.
    pub targets_deg: Vec<f64>,
    /// Runs n in each direction.
    pub runs: u32,
    /// Both directions, or one.
    pub directions: Vec<Direction>,
    /// The reference's noise on each reading, arcsec.
    pub reference_sigma_arcsec: f64,
    /// The reference's resolution, arcsec (readings are rounded to it).
    pub resolution_arcsec: f64,
}

/// The readings of `test` on `axis`, in the order of the standard's test cycle: run 1 through
/// every target in the positive direction, back through them in the negative, then run 2 ….
///
/// # Errors
/// [`SimError::Parameter`]: an invalid model, a reference σ outside 0…3600″, a resolution
/// outside 10⁻⁶…1″.
pub fn simulate(axis: &AxisModel, test: &AxisTest) -> Result<Vec<AxisReading>, SimError> {
    axis.validate()?;
    let sigma = test.reference_sigma_arcsec;
    if !(sigma.is_finite() && (0.0..=MAX_AXIS_ARCSEC).contains(&sigma)) {
        return Err(SimError::parameter(
            "reference sigma",
            sigma,
            "0 to 3600 arcsec",
        ));
    }
    let res = test.resolution_arcsec;
    if !(res.is_finite() && (1e-6..=1.0).contains(&res)) {
        return Err(SimError::parameter(
            "resolution",
            res,
            "0.000001 to 1 arcsec",
        ));
    }
    let mut out = Vec::new();
    for run in 1..=test.runs {
        for &d in &test.directions {
            let order: Vec<f64> = match d {
                Direction::Up => test.targets_deg.clone(),
                Direction::Down => test.targets_deg.iter().rev().copied().collect(),
            };
            for t in order {
                let noise = if sigma > 0.0 {
                    Normal::new(0.0, sigma)
                        .expect("σ checked")
                        .sample(&mut approach_rng(axis.seed, t, d, run, 2))
                } else {
                    0.0
                };
                let x = axis.deviation_arcsec(t, d, run) + noise;
                out.push(AxisReading {
                    target_deg: t,
                    direction: d,
                    run,
                    deviation_arcsec: (x / res).round() * res,
                });
            }
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use gonio_calib::axis::evaluate;

    fn test(targets: usize, runs: u32) -> AxisTest {
        AxisTest {
            targets_deg: (0..targets).map(|k| k as f64 * 15.0).collect(),
            runs,
            directions: Direction::BOTH.to_vec(),
            reference_sigma_arcsec: 0.02,
            resolution_arcsec: 0.001,
        }
    }

    #[test]
    fn the_evaluation_recovers_the_axis_backlash_and_repeatability() {
        // 25 targets × 8 runs × 2 directions. Each approach scatters with
        // σ_tot² = σ² + σ_ref² (+ the resolution's 0.001²/12, negligible).
        let (m_targets, n) = (25usize, 8u32);
        for (seed, backlash, sigma) in [(1u64, 2.0, 0.5), (2, -0.7, 0.1), (3, 0.0, 1.5)] {
            let axis = AxisModel {
                backlash_arcsec: backlash,
                repeatability_arcsec: sigma,
                ..AxisModel::default_with_seed(seed)
            };
            let t = test(m_targets, n);
            let readings = simulate(&axis, &t).unwrap();
            // The same seed gives the same readings; another seed others.
            assert_eq!(readings, simulate(&axis, &t).unwrap());
            let other = AxisModel {
                seed: seed + 100,
                ..axis.clone()
            };
            assert_ne!(readings, simulate(&other, &t).unwrap());
            let e = evaluate(&readings).unwrap();
            let sigma_tot = (sigma * sigma + 0.02f64 * 0.02).sqrt();
            // B̄ is the mean of m reversal values, each of sd σ_tot·√(2/n): 4 sd allowed.
            let sd_b = sigma_tot * (2.0 / f64::from(n)).sqrt() / (m_targets as f64).sqrt();
            let b = e.parameters.b_mean.unwrap();
            assert!(
                (b - backlash).abs() <= 4.0 * sd_b,
                "seed {seed}: B_mean {b} vs backlash {backlash}, sd {sd_b}"
            );
            // The pooled s of all 2m cells (2m(n − 1) degrees of freedom): relative sd
            // ≈ 1/√(2ν), 4 of them allowed.
            let cells: Vec<f64> = e
                .targets
                .iter()
                .flat_map(|t| [t.up.as_ref().unwrap(), t.down.as_ref().unwrap()])
                .map(|c| c.s_arcsec * c.s_arcsec)
                .collect();
            let pooled = (cells.iter().sum::<f64>() / cells.len() as f64).sqrt();
            let nu = cells.len() as f64 * f64::from(n - 1);
            assert!(
                (pooled / sigma_tot - 1.0).abs() <= 4.0 / (2.0 * nu).sqrt(),
                "seed {seed}: pooled s {pooled} vs σ {sigma_tot}"
            );
            // Every x̄↑ − x̄↓ against b: at most one in 25 beyond 3 sd (P ≈ 0.3 % each).
            let over = e
                .targets
                .iter()
                .filter(|t| {
                    (t.reversal_arcsec().unwrap() - backlash).abs()
                        > 3.0 * sigma_tot * (2.0 / f64::from(n)).sqrt()
                })
                .count();
            assert!(over <= 1, "seed {seed}: {over} reversal values beyond 3 sd");
        }
    }
}
