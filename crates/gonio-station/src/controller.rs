//! The mounting sequence (seed 004 §2): autofocus → measure → align → approach → push → verify →
//! repeat or reject, generic over the hardware traits of [`crate::hal`].
//!
//! Strategies ([`Strategy`]):
//! - `paper`: the seed's station: extreme-point fit, angles latched from the servo log, fast
//!   contact, push by e toward θ_max.
//! - `least-squares`: the robust least-squares fit with mid-exposure stamping, push by e.
//! - `learned` (default): least squares plus a push model (expected overshoot, slip and
//!   spring-back from the recipe), a slow approach for small e, and the push gain and the angle
//!   offset between commanded and actual push direction learned from every push (carried across
//!   parts by the same [`Controller`]).
//! - `live`: as `learned`, but the push runs under feedback from the live baseline position: the
//!   rod advances in steps until the ring's column reaches the fitted centre value at that angle.
//!
//! A part ends accepted (e below the recipe's threshold) or rejected (max pushes, ring lost,
//! focus failure, timeout). A device error aborts the part with [`StationError::Device`].
//!
//! ```
//! use gonio_station::{Controller, Recipe, Strategy};
//! let c = Controller::new(Recipe::default(), Strategy::Learned);
//! assert_eq!(c.strategy.name(), "learned");
//! ```

use crate::fit::{EccentricityFit, FitMethod, FitOptions, Sample, fit};
use crate::hal::{
    ApproachSpeed, Camera, CameraFrame, Clock, DeviceError, FocusDrive, PushRod, Servo,
};
use crate::interval::{AngleLog, Stamping};
use crate::{Recipe, StationError};
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

    fn uses_model(self) -> bool {
        matches!(self, Strategy::Learned | Strategy::Live)
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

/// How a part ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum PartResult {
    /// Eccentricity below the threshold: cured.
    Accepted,
    /// The maximum number of pushes was reached.
    RejectedMaxPushes,
    /// Too few frames with a valid ring in a turn.
    RejectedRingLost,
    /// Autofocus found no peak.
    RejectedFocusFailure,
    /// The part took longer than the recipe's timeout.
    RejectedTimeout,
}

impl PartResult {
    /// Short name (`accepted`, `rejected_max_pushes`, …).
    pub fn name(self) -> &'static str {
        match self {
            PartResult::Accepted => "accepted",
            PartResult::RejectedMaxPushes => "rejected_max_pushes",
            PartResult::RejectedRingLost => "rejected_ring_lost",
            PartResult::RejectedFocusFailure => "rejected_focus_failure",
            PartResult::RejectedTimeout => "rejected_timeout",
        }
    }
}

/// One measuring turn.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TurnRecord {
    /// Start of the turn, s since the part started.
    pub t_start_s: f64,
    /// The valid frames' samples.
    pub samples: Vec<Sample>,
    /// Frames without a valid ring.
    pub invalid_frames: usize,
    /// Eccentricity, µm (NaN when the turn failed).
    pub e_um: f64,
    /// θ_max, degrees.
    pub theta_max_deg: f64,
    /// Mean column, px.
    pub c0_px: f64,
    /// Residual RMS, px.
    pub residual_rms_px: f64,
    /// Outliers rejected by the fit.
    pub outliers: usize,
}

/// One push.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PushRecord {
    /// Start, s since the part started.
    pub t_start_s: f64,
    /// Eccentricity before, µm.
    pub e_before_um: f64,
    /// Commanded push distance, µm (sum of the steps under live feedback).
    pub commanded_um: f64,
    /// Commanded push direction (servo angle facing the rod), degrees.
    pub angle_deg: f64,
    /// Approach speed.
    pub approach: ApproachSpeed,
    /// Feedback steps (live strategy; 1 otherwise).
    pub steps: u32,
}

/// Everything the station knows about one part.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PartRecord {
    /// The part's serial number.
    pub serial: String,
    /// The recipe's name.
    pub recipe: String,
    /// The strategy's name.
    pub strategy: String,
    /// First measured eccentricity, µm (NaN if never measured).
    pub initial_e_um: f64,
    /// Last measured eccentricity, µm (NaN if never measured).
    pub final_e_um: f64,
    /// Pushes made.
    pub pushes: u32,
    /// Time from start to the end of the part, s.
    pub time_s: f64,
    /// How the part ended.
    pub result: PartResult,
    /// Focus position found, µm (NaN on focus failure).
    pub focus_um: f64,
    /// Every measuring turn.
    pub turns: Vec<TurnRecord>,
    /// Every push.
    pub push_log: Vec<PushRecord>,
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

/// The five devices of a station.
#[derive(Debug)]
pub struct Devices<S, C, F, P, K> {
    /// The servo.
    pub servo: S,
    /// The camera and its detector.
    pub camera: C,
    /// The focus drive.
    pub focus: F,
    /// The push rod.
    pub rod: P,
    /// The clock.
    pub clock: K,
}

fn dev<E: DeviceError>(device: &'static str) -> impl Fn(E) -> StationError {
    move |e| StationError::Device {
        device,
        kind: e.kind(),
        message: e.to_string(),
    }
}

/// The station's controller: a recipe, a strategy and what it has learned so far.
#[derive(Debug, Clone)]
pub struct Controller {
    /// The grating type's settings.
    pub recipe: Recipe,
    /// The push strategy.
    pub strategy: Strategy,
    /// Learned gain and offset (kept across parts when `carry_learning`).
    pub learned: Learned,
    /// Keep what was learned from one part for the next.
    pub carry_learning: bool,
}

enum Turn {
    Ok(TurnRecord, EccentricityFit),
    Lost(TurnRecord),
}

impl Controller {
    /// A controller with nothing learned yet.
    pub fn new(recipe: Recipe, strategy: Strategy) -> Self {
        Controller {
            recipe,
            strategy,
            learned: Learned::default(),
            carry_learning: true,
        }
    }

    fn fit_options(&self) -> FitOptions {
        FitOptions {
            method: self.strategy.fit_method(),
            ..self.recipe.fit.clone()
        }
    }

    /// Mounts one part.
    ///
    /// # Errors
    /// [`StationError::Device`] when a device fails (the part is aborted; the caller decides
    /// whether to go on with the next one).
    pub fn mount<S, C, F, P, K>(
        &mut self,
        d: &mut Devices<S, C, F, P, K>,
        serial: &str,
    ) -> Result<PartRecord, StationError>
    where
        S: Servo,
        C: Camera,
        F: FocusDrive,
        P: PushRod,
        K: Clock,
    {
        if !self.carry_learning {
            self.learned = Learned::default();
        }
        let t0 = d.clock.now_s().map_err(dev("clock"))?;
        let mut rec = PartRecord {
            serial: serial.to_string(),
            recipe: self.recipe.name.clone(),
            strategy: self.strategy.name().to_string(),
            initial_e_um: f64::NAN,
            final_e_um: f64::NAN,
            pushes: 0,
            time_s: 0.0,
            result: PartResult::Accepted,
            focus_um: f64::NAN,
            turns: Vec::new(),
            push_log: Vec::new(),
        };
        let finish = |rec: &mut PartRecord, d: &mut Devices<S, C, F, P, K>, r: PartResult| {
            rec.result = r;
            rec.time_s = d.clock.now_s().map_err(dev("clock"))? - t0;
            Ok::<(), StationError>(())
        };
        match self.autofocus(d)? {
            Some(z) => rec.focus_um = z,
            None => {
                finish(&mut rec, d, PartResult::RejectedFocusFailure)?;
                return Ok(rec);
            }
        }
        let um = self.recipe.um_per_px;
        let mut current = match self.measure(d, t0)? {
            Turn::Ok(t, f) => {
                rec.turns.push(t);
                f
            }
            Turn::Lost(t) => {
                rec.turns.push(t);
                finish(&mut rec, d, PartResult::RejectedRingLost)?;
                return Ok(rec);
            }
        };
        rec.initial_e_um = current.e_px * um;
        rec.final_e_um = rec.initial_e_um;
        loop {
            let e_um = current.e_px * um;
            if e_um < self.recipe.threshold_um {
                finish(&mut rec, d, PartResult::Accepted)?;
                return Ok(rec);
            }
            if rec.pushes >= self.recipe.push.max_pushes {
                finish(&mut rec, d, PartResult::RejectedMaxPushes)?;
                return Ok(rec);
            }
            if d.clock.now_s().map_err(dev("clock"))? - t0 > self.recipe.timeout_s {
                finish(&mut rec, d, PartResult::RejectedTimeout)?;
                return Ok(rec);
            }
            let push = match self.push(d, &current, t0)? {
                Some(p) => p,
                None => {
                    finish(&mut rec, d, PartResult::RejectedRingLost)?;
                    return Ok(rec);
                }
            };
            rec.pushes += 1;
            let next = match self.measure(d, t0)? {
                Turn::Ok(t, f) => {
                    rec.turns.push(t);
                    f
                }
                Turn::Lost(t) => {
                    rec.turns.push(t);
                    rec.push_log.push(push);
                    finish(&mut rec, d, PartResult::RejectedRingLost)?;
                    return Ok(rec);
                }
            };
            self.learn(&current, &next, &push);
            rec.push_log.push(push);
            rec.final_e_um = next.e_px * um;
            current = next;
        }
    }

    /// Autofocus: one sweep, then a Gaussian peak fit (a parabola on the log of the focus
    /// measure) around the best position. `None` on focus failure.
    fn autofocus<S, C, F, P, K>(
        &self,
        d: &mut Devices<S, C, F, P, K>,
    ) -> Result<Option<f64>, StationError>
    where
        C: Camera,
        F: FocusDrive,
    {
        let fs = &self.recipe.focus;
        let n = fs.steps;
        let z: Vec<f64> = (0..n)
            .map(|i| fs.nominal_um - fs.range_um + 2.0 * fs.range_um * i as f64 / (n - 1) as f64)
            .collect();
        let mut m = Vec::with_capacity(n);
        for &zi in &z {
            d.focus.move_to_um(zi).map_err(dev("focus drive"))?;
            let f = d.camera.capture().map_err(dev("camera"))?;
            m.push(if f.focus_measure.is_finite() {
                f.focus_measure
            } else {
                0.0
            });
        }
        let best = (0..n).fold(0, |b, i| if m[i] > m[b] { i } else { b });
        let mut sorted = m.clone();
        sorted.sort_by(|a, b| a.total_cmp(b));
        let median = sorted[n / 2];
        if best == 0
            || best == n - 1
            || m[best] < fs.min_measure
            || m[best] < fs.min_contrast * median.max(1e-12)
        {
            return Ok(None);
        }
        // Quadratic least squares on ln m over best ± 2 (clipped), in t = (z − z_best)/step.
        let step = z[1] - z[0];
        let lo = best.saturating_sub(2);
        let hi = (best + 2).min(n - 1);
        let (mut s0, mut s1, mut s2, mut s3, mut s4) = (0.0, 0.0, 0.0, 0.0, 0.0);
        let (mut y0, mut y1, mut y2) = (0.0, 0.0, 0.0);
        for (i, mi) in m.iter().enumerate().take(hi + 1).skip(lo) {
            let t = i as f64 - best as f64;
            let y = mi.max(1e-12).ln();
            s0 += 1.0;
            s1 += t;
            s2 += t * t;
            s3 += t * t * t;
            s4 += t * t * t * t;
            y0 += y;
            y1 += t * y;
            y2 += t * t * y;
        }
        let a = nalgebra::Matrix3::new(s4, s3, s2, s3, s2, s1, s2, s1, s0);
        let rhs = nalgebra::Vector3::new(y2, y1, y0);
        let mut z_star = z[best];
        if let Some(sol) = a.lu().solve(&rhs) {
            let (qa, qb) = (sol[0], sol[1]);
            if qa < 0.0 {
                let t = (-qb / (2.0 * qa)).clamp(-1.0, 1.0);
                z_star = z[best] + t * step;
            }
        }
        d.focus.move_to_um(z_star).map_err(dev("focus drive"))?;
        Ok(Some(z_star))
    }

    /// One measuring turn and its fit.
    fn measure<S, C, F, P, K>(
        &self,
        d: &mut Devices<S, C, F, P, K>,
        t0: f64,
    ) -> Result<Turn, StationError>
    where
        S: Servo,
        C: Camera,
        K: Clock,
    {
        let ms = &self.recipe.measure;
        let t_start = d.clock.now_s().map_err(dev("clock"))?;
        d.servo
            .start_turn(ms.speed_deg_per_s)
            .map_err(dev("servo"))?;
        let n = self.recipe.frames_per_turn();
        let mut frames: Vec<CameraFrame> = Vec::with_capacity(n);
        for _ in 0..n {
            frames.push(d.camera.capture().map_err(dev("camera"))?);
        }
        d.servo.stop().map_err(dev("servo"))?;
        let log = d.servo.angle_log(t_start).map_err(dev("servo"))?;
        let mut rec = TurnRecord {
            t_start_s: t_start - t0,
            samples: Vec::with_capacity(n),
            invalid_frames: 0,
            e_um: f64::NAN,
            theta_max_deg: f64::NAN,
            c0_px: f64::NAN,
            residual_rms_px: f64::NAN,
            outliers: 0,
        };
        let log = match AngleLog::new(log) {
            Ok(l) => l,
            Err(_) => return Ok(Turn::Lost(rec)),
        };
        for f in &frames {
            match f.c_px {
                Some(c) if c.is_finite() => {
                    match log.stamp(f.start_s, f.exposure_s, self.strategy.stamping()) {
                        Ok(theta) => {
                            // Keep angles strictly increasing (a stalled servo repeats angles).
                            if rec
                                .samples
                                .last()
                                .is_none_or(|s: &Sample| theta > s.theta_deg)
                            {
                                rec.samples.push(Sample {
                                    theta_deg: theta,
                                    c_px: c,
                                });
                            } else {
                                rec.invalid_frames += 1;
                            }
                        }
                        Err(_) => rec.invalid_frames += 1,
                    }
                }
                _ => rec.invalid_frames += 1,
            }
        }
        let valid = rec.samples.len();
        if valid < 3 || (valid as f64) < ms.min_valid_fraction * n as f64 {
            return Ok(Turn::Lost(rec));
        }
        match fit(&rec.samples, &self.fit_options()) {
            Ok(f) => {
                rec.e_um = f.e_px * self.recipe.um_per_px;
                rec.theta_max_deg = f.theta_max_deg;
                rec.c0_px = f.c0_px;
                rec.residual_rms_px = f.residual_rms_px;
                rec.outliers = f.outliers.len();
                Ok(Turn::Ok(rec, f))
            }
            Err(_) => Ok(Turn::Lost(rec)),
        }
    }

    /// Align, approach, push (open loop or under live feedback), retract. `None` if the ring was
    /// lost during a live push.
    fn push<S, C, F, P, K>(
        &self,
        d: &mut Devices<S, C, F, P, K>,
        cur: &EccentricityFit,
        t0: f64,
    ) -> Result<Option<PushRecord>, StationError>
    where
        S: Servo,
        C: Camera,
        P: PushRod,
        K: Clock,
    {
        let ps = &self.recipe.push;
        let um = self.recipe.um_per_px;
        let e_um = cur.e_px * um;
        let model = self.strategy.uses_model();
        let angle = if model {
            cur.theta_max_deg - self.learned.offset_deg
        } else {
            cur.theta_max_deg
        };
        let approach = if model && e_um < ps.slow_contact_below_um {
            ApproachSpeed::Slow
        } else {
            ApproachSpeed::Fast
        };
        let overshoot = match approach {
            ApproachSpeed::Fast => ps.overshoot_fast_um,
            ApproachSpeed::Slow => ps.overshoot_slow_um,
        };
        let t_start = d.clock.now_s().map_err(dev("clock"))? - t0;
        // Align: the nearest servo angle equivalent to `angle`.
        let now = d.servo.angle_deg().map_err(dev("servo"))?;
        let target = now + (angle - now + 180.0).rem_euclid(360.0) - 180.0;
        d.servo.move_to_deg(target).map_err(dev("servo"))?;
        d.rod.approach(approach).map_err(dev("push rod"))?;
        let gain = self.learned.gain.clamp(0.5, 1.5);
        let mut commanded = 0.0;
        let mut steps = 0u32;
        let mut lost = false;
        if self.strategy == Strategy::Live {
            // Live feedback: the camera sees the grating's offset along the push direction.
            let c_target =
                cur.model_px(target) - cur.e_px * (target - cur.theta_max_deg).to_radians().cos();
            let goal_um = -ps.spring_back * e_um;
            let mut stalls = 0;
            let mut last = f64::INFINITY;
            // The gain of this push, measured from the first step under feedback.
            let mut k_live = gain;
            let mut prev: Option<(f64, f64)> = None;
            for _ in 0..60 {
                let mut sum = 0.0;
                let mut cnt = 0;
                for _ in 0..ps.live_frames {
                    let f = d.camera.capture().map_err(dev("camera"))?;
                    if let Some(c) = f.c_px.filter(|c| c.is_finite()) {
                        sum += c;
                        cnt += 1;
                    }
                }
                if cnt == 0 {
                    lost = true;
                    break;
                }
                let along_um = (sum / cnt as f64 - c_target) * um;
                if let Some((a_prev, d_prev)) = prev {
                    if d_prev * k_live > 10.0 {
                        k_live = ((a_prev - along_um) / d_prev).clamp(0.5, 1.5);
                    }
                }
                let remaining = along_um - goal_um;
                if remaining < ps.live_tolerance_um {
                    break;
                }
                if remaining > last - 0.2 {
                    stalls += 1;
                    if stalls >= 3 {
                        break;
                    }
                }
                last = remaining;
                // The first step stops short (the push's gain is not known yet); later steps
                // use the gain just measured.
                let frac = if steps == 0 && remaining > 10.0 {
                    0.85
                } else {
                    1.0
                };
                let dd = (frac * remaining / k_live)
                    .max(1.05 / k_live)
                    .min(ps.max_push_um - commanded);
                if dd <= 0.0 {
                    break;
                }
                d.rod.push_um(dd).map_err(dev("push rod"))?;
                prev = Some((along_um, dd));
                commanded += dd;
                steps += 1;
            }
        } else {
            let dd = if model {
                (e_um / (1.0 - ps.spring_back) - overshoot - ps.slip_um) / gain
            } else {
                e_um
            };
            let dd = dd.clamp(0.0, ps.max_push_um);
            d.rod.push_um(dd).map_err(dev("push rod"))?;
            commanded = dd;
            steps = 1;
        }
        d.rod.retract().map_err(dev("push rod"))?;
        if lost {
            return Ok(None);
        }
        Ok(Some(PushRecord {
            t_start_s: t_start,
            e_before_um: e_um,
            commanded_um: commanded,
            angle_deg: angle,
            approach,
            steps,
        }))
    }

    /// Learns the push gain and angle offset from the move seen between two turns.
    fn learn(&mut self, before: &EccentricityFit, after: &EccentricityFit, push: &PushRecord) {
        if !self.strategy.uses_model() {
            return;
        }
        let um = self.recipe.um_per_px;
        let vec = |f: &EccentricityFit| {
            let t = f.theta_max_deg.to_radians();
            (f.e_px * um * t.cos(), f.e_px * um * t.sin())
        };
        let (bx, by) = vec(before);
        let (ax, ay) = vec(after);
        let (mx, my) = (bx - ax, by - ay);
        let phi = push.angle_deg.to_radians();
        let along = mx * phi.cos() + my * phi.sin();
        let perp = -mx * phi.sin() + my * phi.cos();
        let moved = mx.hypot(my);
        let l = &mut self.learned;
        if moved >= 20.0 && along > 0.0 {
            let delta = perp.atan2(along).to_degrees();
            if delta.abs() < 10.0 {
                let n = l.offset_observations as f64;
                // Running mean with the prior 0° worth one observation.
                l.offset_deg = (l.offset_deg * (n + 1.0) + delta) / (n + 2.0);
                l.offset_observations += 1;
            }
        }
        if self.strategy == Strategy::Learned && push.commanded_um >= 20.0 {
            let ps = &self.recipe.push;
            let overshoot = match push.approach {
                ApproachSpeed::Fast => ps.overshoot_fast_um,
                ApproachSpeed::Slow => ps.overshoot_slow_um,
            };
            let k = (along / (1.0 - ps.spring_back) - overshoot - ps.slip_um) / push.commanded_um;
            if (0.5..1.5).contains(&k) {
                let n = l.gain_observations as f64;
                l.gain = (l.gain * (n + 1.0) + k) / (n + 2.0);
                l.gain_observations += 1;
            }
        }
    }
}
