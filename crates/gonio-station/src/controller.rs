//! The mounting sequence (Yu et al., 2024, §2): autofocus → measure → align → approach →
//! push → verify → repeat or reject, generic over the hardware traits of [`crate::hal`], with the
//! push strategies of [`crate::strategy`] and the quality gate of [`crate::quality`] on every turn.
//!
//! The station pushes only on a measurement it can trust:
//! - every turn is judged by the quality gate; a turn that fails it (or loses the ring) is
//!   measured again after a refocus, as often as the recipe's `quality.remeasure_turns` says;
//!   if the last attempt fails too, the part ends `measurement_untrusted` (or
//!   `rejected_ring_lost`) with every turn kept;
//! - a push takes a [`Trusted`] fit, which only a turn that passed the gate gives;
//! - after each push the verify turn must agree with the push model's prediction (within
//!   `push.verify_tolerance_um` + `push.verify_tolerance_fraction` × the predicted move);
//!   otherwise pushing stops and the part ends `push_inconsistent` (unless the trusted verify
//!   turn already finds it within the threshold: then it is accepted, the push flagged).
//!
//! A part also ends accepted (e below the recipe's threshold; the live strategy pushes again
//! while e is above `push.live_aim_fraction` of it and pushes and time remain) or rejected (max
//! pushes, ring lost, focus failure, timeout). A device error ends the part `rejected_device_error` with its record
//! kept (the device, its message, every turn and push so far); the controller then tries to
//! leave the station safe (rod retracted, servo stopped). A device that reports the run
//! interrupted ([`DeviceErrorKind::Interrupted`]: a signal) ends the part `interrupted`, with
//! what was measured and the same safe stop.
//!
//! ```
//! use gonio_station::{Controller, Recipe, Strategy};
//! let c = Controller::new(Recipe::default(), Strategy::Learned);
//! assert_eq!(c.strategy.name(), "learned");
//! ```

use crate::fit::EccentricityFit;
use crate::hal::{
    Camera, CameraFrame, Clock, DeviceError, DeviceErrorKind, FocusDrive, PushRod, Servo,
};
use crate::observe::{LiveFrame, NoObserver, Observer, Phase};
pub use crate::record::{
    DeviceFault, PartRecord, PartResult, PhaseTimes, PushRecord, TurnKind, TurnRecord,
};
pub use crate::strategy::{Learned, Strategy};
use crate::strategy::{LiveFeedback, PushOutcome, PushPlan, PushPrediction, e_vec_um};
use crate::turn::evaluate_turn;
use crate::{Recipe, StationError};

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

/// A fit whose turn passed the quality gate: the only kind the station pushes on.
#[derive(Debug, Clone, PartialEq)]
pub struct Trusted(EccentricityFit);

impl Trusted {
    /// The fit.
    pub fn fit(&self) -> &EccentricityFit {
        &self.0
    }
}

enum Turn {
    Ok(TurnRecord, Box<EccentricityFit>),
    Lost(TurnRecord),
}

/// How a gated measurement ended.
enum Gated {
    Trusted(Box<Trusted>),
    Rejected(PartResult, String),
}

/// The end of a part, with the reason when rejected.
type Ending = (PartResult, Option<String>);

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

    /// Mounts one part and returns its record, whatever happened to it.
    ///
    /// A device error ends the part `rejected_device_error` with the device and its message in
    /// [`PartRecord::device_error`] (and [`PartRecord::device_error()`] as a
    /// [`StationError::Device`] for callers that want the error); the caller decides whether to
    /// go on with the next part ([`crate::recipe::DeviceErrorPolicy`]). A device that reports
    /// the run interrupted ([`DeviceErrorKind::Interrupted`]) ends the part `interrupted`, with
    /// what was measured until then and no device error.
    ///
    /// # Errors
    /// [`StationError::RecipeValue`] when the recipe is invalid (nothing is moved).
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
        self.mount_observed(d, serial, &mut NoObserver)
    }

    /// As [`Controller::mount`], telling `obs` what happens as it happens (frames, turns,
    /// pushes, the finished record). The observer cannot change what the station does.
    ///
    /// # Errors
    /// As [`Controller::mount`].
    pub fn mount_observed<S, C, F, P, K>(
        &mut self,
        d: &mut Devices<S, C, F, P, K>,
        serial: &str,
        obs: &mut dyn Observer,
    ) -> Result<PartRecord, StationError>
    where
        S: Servo,
        C: Camera,
        F: FocusDrive,
        P: PushRod,
        K: Clock,
    {
        self.recipe.validate()?;
        obs.part_started(serial);
        if !self.carry_learning {
            self.learned = Learned::default();
        }
        let mut rec = PartRecord::new(serial, &self.recipe.name, self.strategy.name());
        let t0 = d.clock.now_s().map_err(dev("clock"));
        let ending = match &t0 {
            Ok(t0) => self.run(d, &mut rec, *t0, obs).map(|e| (*t0, e)),
            Err(e) => Err(e.clone()),
        };
        match ending {
            Ok((t0, (result, reason))) => {
                rec.result = result;
                rec.reject_reason = reason;
                rec.time_s = d.clock.now_s().ok().map(|t| t - t0);
            }
            Err(StationError::Device {
                device,
                kind: DeviceErrorKind::Interrupted,
                message,
            }) => {
                // Not a failure: the run was asked to stop. What was measured stays.
                rec.result = PartResult::Interrupted;
                rec.reject_reason = Some(format!("{device}: {message}"));
                let _ = d.rod.retract();
                let _ = d.servo.stop();
                if let Ok(t0) = t0 {
                    rec.time_s = d.clock.now_s().ok().map(|t| t - t0);
                }
            }
            Err(StationError::Device {
                device,
                kind,
                message,
            }) => {
                rec.result = PartResult::RejectedDeviceError;
                rec.reject_reason = Some(format!("{device}: {kind:?} error: {message}"));
                rec.device_error = Some(DeviceFault {
                    device: device.to_string(),
                    kind,
                    message,
                });
                // Best effort: leave the station safe; a second failure is already covered.
                let _ = d.rod.retract();
                let _ = d.servo.stop();
                if let Ok(t0) = t0 {
                    rec.time_s = d.clock.now_s().ok().map(|t| t - t0);
                }
            }
            Err(other) => return Err(other),
        }
        obs.part_finished(&rec);
        Ok(rec)
    }

    /// The sequence of one part; device errors propagate.
    fn run<S, C, F, P, K>(
        &mut self,
        d: &mut Devices<S, C, F, P, K>,
        rec: &mut PartRecord,
        t0: f64,
        obs: &mut dyn Observer,
    ) -> Result<Ending, StationError>
    where
        S: Servo,
        C: Camera,
        F: FocusDrive,
        P: PushRod,
        K: Clock,
    {
        let t = now(d)?;
        obs.phase(Phase::Focus);
        let focus = self.autofocus(d)?;
        rec.phase_times.focus_s += now(d)? - t;
        match focus {
            Some(z) => rec.focus_um = Some(z),
            None => {
                return Ok((
                    PartResult::RejectedFocusFailure,
                    Some("autofocus: the focus measure has no peak in the sweep".into()),
                ));
            }
        }
        let um = self.recipe.um_per_px;
        let threshold = self.recipe.threshold_um;
        // The live strategy aims below the threshold (a touch-up push when one push ended
        // between the aim and the threshold); the others push until under the threshold.
        let aim = match self.strategy {
            Strategy::Live => threshold * self.recipe.push.live_aim_fraction,
            _ => threshold,
        };
        let mut current = match self.gated_turn(d, rec, t0, TurnKind::Initial, obs)? {
            Gated::Trusted(f) => *f,
            Gated::Rejected(r, why) => return Ok((r, Some(why))),
        };
        rec.initial_e_um = Some(current.0.e_px * um);
        rec.final_e_um = rec.initial_e_um;
        loop {
            let (e_um, theta_max) = (current.0.e_px * um, current.0.theta_max_deg);
            if e_um < aim {
                return Ok((PartResult::Accepted, None));
            }
            // Between the aim and the threshold (live only), a part is accepted once the
            // pushes or the time are used up.
            if rec.pushes >= self.recipe.push.max_pushes {
                if e_um < threshold {
                    return Ok((PartResult::Accepted, None));
                }
                return Ok((
                    PartResult::RejectedMaxPushes,
                    Some(format!(
                        "e = {e_um:.2} µm ≥ {threshold} µm after {} pushes",
                        rec.pushes
                    )),
                ));
            }
            let elapsed = now(d)? - t0;
            if elapsed > self.recipe.timeout_s {
                if e_um < threshold {
                    return Ok((PartResult::Accepted, None));
                }
                return Ok((
                    PartResult::RejectedTimeout,
                    Some(format!(
                        "{elapsed:.1} s > timeout {} s with e = {e_um:.2} µm",
                        self.recipe.timeout_s
                    )),
                ));
            }
            let plan = self
                .strategy
                .plan(e_um, theta_max, &self.learned, &self.recipe);
            let t = now(d)?;
            obs.phase(Phase::Push);
            let pushed = self.push(d, &current, &plan, t - t0)?;
            let push_duration = now(d)? - t;
            rec.phase_times.push_s += push_duration;
            let (mut push, prediction) = match pushed {
                Some(p) => p,
                None => {
                    return Ok((
                        PartResult::RejectedRingLost,
                        Some(format!(
                            "push {}: the ring was lost in the live view",
                            rec.pushes + 1
                        )),
                    ));
                }
            };
            push.duration_s = Some(push_duration);
            obs.push(&push);
            rec.pushes += 1;
            rec.push_log.push(push);
            let next = match self.gated_turn(d, rec, t0, TurnKind::Verify, obs)? {
                Gated::Trusted(f) => *f,
                Gated::Rejected(r, why) => return Ok((r, Some(why))),
            };
            let after = e_vec_um(&next.0, um);
            let deviation = (after[0] - prediction.e_after_vec_um[0])
                .hypot(after[1] - prediction.e_after_vec_um[1]);
            let consistent = deviation <= prediction.tolerance_um;
            let e_after = next.0.e_px * um;
            rec.final_e_um = Some(e_after);
            let last = rec.push_log.last_mut().expect("the push was just logged");
            last.e_after_um = Some(e_after);
            last.deviation_um = Some(deviation);
            last.consistent = Some(consistent);
            if !consistent {
                if e_after < threshold {
                    // The trusted verify turn finds the part centred: nothing left to push.
                    return Ok((PartResult::Accepted, None));
                }
                return Ok((
                    PartResult::PushInconsistent,
                    Some(format!(
                        "push {}: verify turn e = {e_after:.2} µm at {:.1}°, the push model predicted {:.2} µm; {deviation:.2} µm apart > tolerance {:.2} µm",
                        rec.pushes,
                        next.0.theta_max_deg,
                        prediction.e_after_um,
                        prediction.tolerance_um
                    )),
                ));
            }
            let outcome = PushOutcome {
                angle_deg: last.angle_deg,
                commanded_um: last.commanded_um,
                approach: last.approach,
            };
            self.learned
                .learn(self.strategy, &self.recipe, &current.0, &next.0, &outcome);
            current = next;
        }
    }

    /// Measures a turn and judges it; a turn that fails the gate or loses the ring is measured
    /// again (after a refocus) up to `quality.remeasure_turns` times.
    fn gated_turn<S, C, F, P, K>(
        &self,
        d: &mut Devices<S, C, F, P, K>,
        rec: &mut PartRecord,
        t0: f64,
        kind: TurnKind,
        obs: &mut dyn Observer,
    ) -> Result<Gated, StationError>
    where
        S: Servo,
        C: Camera,
        F: FocusDrive,
        K: Clock,
    {
        let q = &self.recipe.quality;
        let mut attempt = 0;
        loop {
            let k = if attempt == 0 {
                kind
            } else {
                TurnKind::Remeasure
            };
            let t = now(d)?;
            obs.phase(Phase::Measure(k));
            let turn = self.measure(d, t0, k, rec.turns.len(), rec.focus_um, obs)?;
            rec.phase_times.measure_s += now(d)? - t;
            let n = rec.turns.len() + 1;
            let (failure, result) = match turn {
                Turn::Ok(t, f) => {
                    rec.turns.push(t);
                    if f.quality.ok {
                        return Ok(Gated::Trusted(Box::new(Trusted(*f))));
                    }
                    (
                        format!(
                            "turn {n} failed the quality gate: {}",
                            f.quality.reasons().join("; ")
                        ),
                        PartResult::MeasurementUntrusted,
                    )
                }
                Turn::Lost(t) => {
                    let why = format!(
                        "turn {n} lost the ring: {} of {} frames valid, {:.0} % needed",
                        t.samples.len(),
                        t.frames_taken,
                        100.0 * self.recipe.measure.min_valid_fraction
                    );
                    rec.turns.push(t);
                    (why, PartResult::RejectedRingLost)
                }
            };
            if attempt >= q.remeasure_turns {
                let why = if attempt > 0 {
                    format!("{failure} (after {attempt} re-measurement(s))")
                } else {
                    failure
                };
                return Ok(Gated::Rejected(result, why));
            }
            attempt += 1;
            rec.remeasured_turns += 1;
            if q.refocus_before_remeasure {
                let t = now(d)?;
                obs.phase(Phase::Focus);
                let z = self.autofocus(d)?;
                rec.phase_times.focus_s += now(d)? - t;
                match z {
                    Some(z) => rec.focus_um = Some(z),
                    None => {
                        return Ok(Gated::Rejected(
                            PartResult::RejectedFocusFailure,
                            format!("{failure}; refocusing found no focus peak"),
                        ));
                    }
                }
            }
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

    /// One measuring turn, its fit and the quality gate's verdict.
    #[allow(clippy::too_many_arguments)]
    fn measure<S, C, F, P, K>(
        &self,
        d: &mut Devices<S, C, F, P, K>,
        t0: f64,
        kind: TurnKind,
        turn_index: usize,
        focus_um: Option<f64>,
        obs: &mut dyn Observer,
    ) -> Result<Turn, StationError>
    where
        S: Servo,
        C: Camera,
        K: Clock,
    {
        let ms = &self.recipe.measure;
        let t_start = now(d)?;
        d.servo
            .start_turn(ms.speed_deg_per_s)
            .map_err(dev("servo"))?;
        let n = self.recipe.frames_per_turn();
        let mut frames: Vec<CameraFrame> = Vec::with_capacity(n);
        for index in 0..n {
            let f = d.camera.capture().map_err(dev("camera"))?;
            let t_s = f.start_s + 0.5 * f.exposure_s - t_start;
            obs.frame(&LiveFrame {
                turn: turn_index,
                index,
                frames: n,
                t_s,
                turn_deg: ms.speed_deg_per_s * t_s,
                c_px: f.c_px.filter(|c| c.is_finite()),
            });
            frames.push(f);
        }
        d.servo.stop().map_err(dev("servo"))?;
        let log = d.servo.angle_log(t_start).map_err(dev("servo"))?;
        obs.turn_inputs(&frames, &log);
        let (rec, fit) = evaluate_turn(
            &self.recipe,
            self.strategy,
            &frames,
            log,
            t_start - t0,
            kind,
            focus_um,
        );
        obs.turn(&rec, fit.as_ref());
        Ok(match fit {
            Some(f) => Turn::Ok(rec, Box::new(f)),
            None => Turn::Lost(rec),
        })
    }

    /// Align, approach, push (open loop or under live feedback), retract; the push model's
    /// prediction for the verify turn. `None` if the ring was lost during a live push.
    fn push<S, C, F, P, K>(
        &self,
        d: &mut Devices<S, C, F, P, K>,
        cur: &Trusted,
        plan: &PushPlan,
        t_start_s: f64,
    ) -> Result<Option<(PushRecord, PushPrediction)>, StationError>
    where
        S: Servo,
        C: Camera,
        P: PushRod,
        K: Clock,
    {
        let cur = &cur.0;
        let um = self.recipe.um_per_px;
        let e_um = cur.e_px * um;
        // Align: the nearest servo angle equivalent to the commanded direction.
        let now_deg = d.servo.angle_deg().map_err(dev("servo"))?;
        let target = now_deg + (plan.angle_deg - now_deg + 180.0).rem_euclid(360.0) - 180.0;
        d.servo.move_to_deg(target).map_err(dev("servo"))?;
        d.rod.approach(plan.approach).map_err(dev("push rod"))?;
        let (commanded, steps, prediction, lost) = match plan.open_loop_um {
            Some(dd) => {
                d.rod.push_um(dd).map_err(dev("push rod"))?;
                (
                    dd,
                    1,
                    plan.predict_open_loop(e_um, cur.theta_max_deg, &self.recipe),
                    false,
                )
            }
            None => {
                // Live feedback: the camera sees the grating's offset along the push direction.
                let c_target = cur.model_px(target)
                    - cur.e_px * (target - cur.theta_max_deg).to_radians().cos();
                let mut fb = LiveFeedback::new(&self.recipe, plan.gain, e_um);
                let mut lost = false;
                while fb.wants_reading() {
                    let mut sum = 0.0;
                    let mut cnt = 0;
                    for _ in 0..self.recipe.push.live_frames {
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
                    match fb.next((sum / cnt as f64 - c_target) * um) {
                        Some(dd) => d.rod.push_um(dd).map_err(dev("push rod"))?,
                        None => break,
                    }
                }
                let p = fb.predict(e_um, cur.theta_max_deg, plan);
                (fb.commanded_um, fb.steps, p, lost)
            }
        };
        d.rod.retract().map_err(dev("push rod"))?;
        if lost {
            return Ok(None);
        }
        Ok(Some((
            PushRecord {
                t_start_s,
                e_before_um: e_um,
                commanded_um: commanded,
                angle_deg: plan.angle_deg,
                approach: plan.approach,
                steps,
                gain: plan.gain,
                predicted_move_um: prediction.move_um,
                predicted_e_after_um: prediction.e_after_um,
                tolerance_um: prediction.tolerance_um,
                e_after_um: None,
                deviation_um: None,
                consistent: None,
                duration_s: None,
            },
            prediction,
        )))
    }
}

fn now<S, C, F, P, K: Clock>(d: &mut Devices<S, C, F, P, K>) -> Result<f64, StationError> {
    d.clock.now_s().map_err(dev("clock"))
}
