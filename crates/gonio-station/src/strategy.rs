//! The push strategies: where and how far to push, the live-feedback loop, what the push model
//! predicts for the verify turn, and what is learned from each push.
//!
//! - `paper`: the seed's station (Yu et al., 2024): extreme-point fit, angles latched from the
//!   servo log, fast contact, push by e toward θ_max.
//! - `least-squares`: the robust least-squares fit with mid-exposure stamping, push by e.
//! - `learned` (default): least squares plus a push model (expected overshoot, slip and
//!   spring-back from the recipe's `[push]`), a slow approach for small e, and the push gain and
//!   the angle offset between commanded and actual push direction learned from every push
//!   (bounds in the recipe's `[learn]`).
//! - `live`: as `learned`, but the push runs under feedback from the live baseline position
//!   ([`LiveFeedback`]): the rod advances in steps until the ring's column reaches the fitted
//!   centre value at that angle.
//!
//! Everything here is pure (no device calls): the controller does the I/O.
//!
//! ```
//! use gonio_station::strategy::{Learned, Strategy};
//! use gonio_station::Recipe;
//! let r = Recipe::default();
//! let plan = Strategy::Learned.plan(100.0, 30.0, &Learned::default(), &r);
//! // Push model: e/(1 − spring-back) − overshoot − slip, at gain 1.
//! let d = plan.open_loop_um.unwrap();
//! assert!((d - (100.0 / 0.985 - 2.39 - 0.75)).abs() < 1e-9);
//! // Predicted: the part ends within a fraction of a micrometre of the centre.
//! assert!(plan.predict_open_loop(100.0, 30.0, &r).e_after_um < 0.1);
//! ```

use crate::fit::{EccentricityFit, FitMethod};
use crate::hal::ApproachSpeed;
use crate::interval::Stamping;
use crate::recipe::{LearnSettings, PushSettings, Recipe};
use serde::{Deserialize, Serialize};

/// A push strategy.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Strategy {
    /// The seed's station.
    Paper,
    /// Least-squares fit, push by e.
    LeastSquares,
    /// Least squares, push model, learned gain and angle offset (default).
    #[default]
    Learned,
    /// Push under live-baseline feedback.
    Live,
}

impl Strategy {
    /// The name used on the command line and in JSON.
    pub fn name(self) -> &'static str {
        match self {
            Strategy::Paper => "paper",
            Strategy::LeastSquares => "least-squares",
            Strategy::Learned => "learned",
            Strategy::Live => "live",
        }
    }

    /// All strategies.
    pub const ALL: [Strategy; 4] = [
        Strategy::Paper,
        Strategy::LeastSquares,
        Strategy::Learned,
        Strategy::Live,
    ];

    /// The eccentricity fit it uses.
    pub fn fit_method(self) -> FitMethod {
        match self {
            Strategy::Paper => FitMethod::Paper,
            _ => FitMethod::LeastSquares,
        }
    }

    /// How it stamps frame angles.
    pub fn stamping(self) -> Stamping {
        match self {
            Strategy::Paper => Stamping::Latched,
            _ => Stamping::MidExposure,
        }
    }

    /// Whether it uses the push model and learns gain and angle offset.
    pub fn uses_model(self) -> bool {
        matches!(self, Strategy::Learned | Strategy::Live)
    }

    /// The plan of a push for a part measured at `e_um` toward `theta_max_deg`.
    pub fn plan(
        self,
        e_um: f64,
        theta_max_deg: f64,
        learned: &Learned,
        recipe: &Recipe,
    ) -> PushPlan {
        let ps = &recipe.push;
        let model = self.uses_model();
        let (offset, gain) = if model {
            (
                learned.offset_deg,
                learned
                    .gain
                    .clamp(recipe.learn.gain_min, recipe.learn.gain_max),
            )
        } else {
            (0.0, 1.0)
        };
        let approach = if model && e_um < ps.slow_contact_below_um {
            ApproachSpeed::Slow
        } else {
            ApproachSpeed::Fast
        };
        let open_loop_um = match self {
            Strategy::Live => None,
            _ if model => Some(
                ((e_um / (1.0 - ps.spring_back) - overshoot_um(ps, approach) - ps.slip_um) / gain)
                    .clamp(0.0, ps.max_push_um),
            ),
            _ => Some(e_um.clamp(0.0, ps.max_push_um)),
        };
        PushPlan {
            angle_deg: theta_max_deg - offset,
            direction_deg: theta_max_deg,
            approach,
            gain,
            open_loop_um,
        }
    }
}

impl std::str::FromStr for Strategy {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        Strategy::ALL
            .into_iter()
            .find(|x| x.name() == s)
            .ok_or_else(|| {
                format!("unknown strategy {s:?}: expected paper, least-squares, learned or live")
            })
    }
}

/// The push model's expected overshoot on contact, µm.
pub fn overshoot_um(ps: &PushSettings, approach: ApproachSpeed) -> f64 {
    match approach {
        ApproachSpeed::Fast => ps.overshoot_fast_um,
        ApproachSpeed::Slow => ps.overshoot_slow_um,
    }
}

/// One push, planned.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct PushPlan {
    /// Commanded push direction (servo angle to face the rod), degrees.
    pub angle_deg: f64,
    /// The direction the part is expected to move in (commanded + learned offset), degrees.
    pub direction_deg: f64,
    /// Approach speed.
    pub approach: ApproachSpeed,
    /// Push gain assumed (learned and clamped, or 1).
    pub gain: f64,
    /// Distance to push after contact, µm (`None`: under live feedback).
    pub open_loop_um: Option<f64>,
}

/// What the push model expects the verify turn to measure.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct PushPrediction {
    /// Predicted move of the grating, µm.
    pub move_um: f64,
    /// Predicted eccentricity vector after the push (servo-angle coordinates), µm.
    pub e_after_vec_um: [f64; 2],
    /// Predicted eccentricity after the push, µm.
    pub e_after_um: f64,
    /// How far the measured eccentricity vector may lie from the prediction, µm.
    pub tolerance_um: f64,
}

impl PushPlan {
    /// The prediction for an open-loop push of [`PushPlan::open_loop_um`] on a part at `e_um`
    /// toward `theta_max_deg`: the move is `(gain·d + overshoot + slip)·(1 − spring-back)`
    /// along [`PushPlan::direction_deg`].
    pub fn predict_open_loop(
        &self,
        e_um: f64,
        theta_max_deg: f64,
        recipe: &Recipe,
    ) -> PushPrediction {
        let ps = &recipe.push;
        let d = self.open_loop_um.unwrap_or(0.0);
        let m =
            (self.gain * d + overshoot_um(ps, self.approach) + ps.slip_um) * (1.0 - ps.spring_back);
        predict(e_um, theta_max_deg, self.direction_deg, m, ps)
    }
}

/// The prediction for a move of `move_um` along `direction_deg` on a part at `e_um` toward
/// `theta_max_deg`, with the recipe's tolerance.
pub fn predict(
    e_um: f64,
    theta_max_deg: f64,
    direction_deg: f64,
    move_um: f64,
    ps: &PushSettings,
) -> PushPrediction {
    let (t, p) = (theta_max_deg.to_radians(), direction_deg.to_radians());
    let v = [
        e_um * t.cos() - move_um * p.cos(),
        e_um * t.sin() - move_um * p.sin(),
    ];
    PushPrediction {
        move_um,
        e_after_vec_um: v,
        e_after_um: v[0].hypot(v[1]),
        tolerance_um: ps.verify_tolerance_um + ps.verify_tolerance_fraction * move_um.abs(),
    }
}

/// The eccentricity vector of a fit, µm (servo-angle coordinates).
pub fn e_vec_um(f: &EccentricityFit, um_per_px: f64) -> [f64; 2] {
    let t = f.theta_max_deg.to_radians();
    [f.e_px * um_per_px * t.cos(), f.e_px * um_per_px * t.sin()]
}

/// The live-feedback loop of one push: reads of the ring's offset along the push direction in,
/// rod steps out.
#[derive(Debug, Clone)]
pub struct LiveFeedback {
    ps: PushSettings,
    gain_min: f64,
    gain_max: f64,
    goal_um: f64,
    k_live: f64,
    prev: Option<(f64, f64)>,
    last_remaining: f64,
    stalls: u32,
    readings: u32,
    /// Steps commanded so far.
    pub steps: u32,
    /// Distance commanded so far, µm.
    pub commanded_um: f64,
    /// The last reading, µm (NaN before the first).
    pub last_along_um: f64,
}

impl LiveFeedback {
    /// A loop for a part at `e_um`, starting from the gain `gain` (learned, clamped).
    pub fn new(recipe: &Recipe, gain: f64, e_um: f64) -> Self {
        let ps = recipe.push.clone();
        LiveFeedback {
            goal_um: -ps.spring_back * e_um,
            ps,
            gain_min: recipe.learn.gain_min,
            gain_max: recipe.learn.gain_max,
            k_live: gain,
            prev: None,
            last_remaining: f64::INFINITY,
            stalls: 0,
            readings: 0,
            steps: 0,
            commanded_um: 0.0,
            last_along_um: f64::NAN,
        }
    }

    /// Whether the loop wants another reading.
    pub fn wants_reading(&self) -> bool {
        self.readings < self.ps.live_max_steps
    }

    /// After a reading of the grating's offset along the push direction (µm): the next step
    /// to push, µm, or `None` to stop (goal reached, stalled, or out of travel).
    pub fn next(&mut self, along_um: f64) -> Option<f64> {
        let ps = &self.ps;
        self.readings += 1;
        self.last_along_um = along_um;
        // The gain of this push, measured from the previous step under feedback.
        if let Some((a_prev, d_prev)) = self.prev
            && d_prev * self.k_live > ps.live_gain_min_move_um
        {
            self.k_live = ((a_prev - along_um) / d_prev).clamp(self.gain_min, self.gain_max);
        }
        let remaining = along_um - self.goal_um;
        if remaining < ps.live_tolerance_um {
            return None;
        }
        if remaining > self.last_remaining - ps.live_stall_um {
            self.stalls += 1;
            if self.stalls >= ps.live_max_stalls {
                return None;
            }
        }
        self.last_remaining = remaining;
        // The first step stops short (the push's gain is not known yet); later steps use the
        // gain just measured.
        let frac = if self.steps == 0 && remaining > ps.live_first_step_above_um {
            ps.live_first_step_fraction
        } else {
            1.0
        };
        let dd = (frac * remaining / self.k_live)
            .max(ps.live_min_step_um / self.k_live)
            .min(ps.max_push_um - self.commanded_um);
        if dd <= 0.0 {
            return None;
        }
        self.prev = Some((along_um, dd));
        self.commanded_um += dd;
        self.steps += 1;
        Some(dd)
    }

    /// The prediction after the push: the feedback brings the part to its goal along the push
    /// direction (which anticipates the spring-back), whatever the rod's gain. A push that
    /// stalled or ran out of travel short of the goal disagrees with it.
    pub fn predict(&self, e_um: f64, theta_max_deg: f64, plan: &PushPlan) -> PushPrediction {
        let along_before = e_um * (plan.angle_deg - theta_max_deg).to_radians().cos();
        let m = (along_before - self.goal_um) * (1.0 - self.ps.spring_back);
        predict(e_um, theta_max_deg, plan.direction_deg, m, &self.ps)
    }
}

/// The learned push gain and angle offset.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Learned {
    /// Estimated push gain (actual move per commanded µm).
    pub gain: f64,
    /// Estimated offset of the actual push direction from the commanded one, degrees.
    pub offset_deg: f64,
    /// Observations behind the gain.
    pub gain_observations: u32,
    /// Observations behind the offset.
    pub offset_observations: u32,
}

impl Default for Learned {
    fn default() -> Self {
        Learned {
            gain: 1.0,
            offset_deg: 0.0,
            gain_observations: 0,
            offset_observations: 0,
        }
    }
}

/// What one push did, as the learning needs it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PushOutcome {
    /// Commanded direction, degrees.
    pub angle_deg: f64,
    /// Commanded distance, µm.
    pub commanded_um: f64,
    /// Approach speed.
    pub approach: ApproachSpeed,
}

impl Learned {
    /// Learns the push gain and angle offset from the move seen between two trusted turns.
    pub fn learn(
        &mut self,
        strategy: Strategy,
        recipe: &Recipe,
        before: &EccentricityFit,
        after: &EccentricityFit,
        push: &PushOutcome,
    ) {
        if !strategy.uses_model() {
            return;
        }
        let ls: &LearnSettings = &recipe.learn;
        let ps = &recipe.push;
        let (b, a) = (
            e_vec_um(before, recipe.um_per_px),
            e_vec_um(after, recipe.um_per_px),
        );
        let (mx, my) = (b[0] - a[0], b[1] - a[1]);
        let phi = push.angle_deg.to_radians();
        let along = mx * phi.cos() + my * phi.sin();
        let perp = -mx * phi.sin() + my * phi.cos();
        let moved = mx.hypot(my);
        let w = ls.prior_weight;
        if moved >= ls.offset_min_move_um && along > 0.0 {
            let delta = perp.atan2(along).to_degrees();
            if delta.abs() < ls.max_offset_deg {
                let n = self.offset_observations as f64;
                // Running mean with the prior 0° worth `prior_weight` observations.
                self.offset_deg = (self.offset_deg * (n + w) + delta) / (n + w + 1.0);
                self.offset_observations += 1;
            }
        }
        if strategy == Strategy::Learned && push.commanded_um >= ls.gain_min_push_um {
            let k = (along / (1.0 - ps.spring_back) - overshoot_um(ps, push.approach) - ps.slip_um)
                / push.commanded_um;
            if (ls.gain_min..ls.gain_max).contains(&k) {
                let n = self.gain_observations as f64;
                self.gain = (self.gain * (n + w) + k) / (n + w + 1.0);
                self.gain_observations += 1;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn live_feedback_converges_on_a_weak_rod() {
        // A rod at gain 0.3 under feedback: the loop measures the gain (clamped to the recipe's
        // 0.5) and still reaches the goal in a few steps.
        let r = Recipe::default();
        let mut fb = LiveFeedback::new(&r, 1.0, 100.0);
        let mut along = 100.0;
        while fb.wants_reading() {
            match fb.next(along) {
                Some(dd) => along -= 0.3 * dd,
                None => break,
            }
        }
        assert!(
            (along - fb.goal_um).abs() < r.push.live_tolerance_um,
            "{along}"
        );
        assert!(fb.steps < 20, "{}", fb.steps);
    }

    #[test]
    fn prediction_points_back_to_the_centre() {
        let r = Recipe::default();
        let plan = Strategy::Paper.plan(50.0, 200.0, &Learned::default(), &r);
        assert_eq!(plan.open_loop_um, Some(50.0));
        let p = plan.predict_open_loop(50.0, 200.0, &r);
        // Push by e at gain 1, plus the expected overshoot and slip, minus spring-back:
        // (50 + 2.39 + 0.75)·0.985 = 52.34 µm, i.e. 2.34 µm past the centre.
        assert!((p.move_um - 53.14 * 0.985).abs() < 1e-9);
        assert!((p.e_after_um - (53.14 * 0.985 - 50.0)).abs() < 1e-9);
        let ps = &r.push;
        let tol = ps.verify_tolerance_um + ps.verify_tolerance_fraction * p.move_um;
        assert!((p.tolerance_um - tol).abs() < 1e-9);
    }
}
