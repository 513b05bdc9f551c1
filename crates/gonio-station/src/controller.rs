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
//! The sequence saves time where the measurement allows it (`docs/station-timing.md`): the
//! focus carried from the last part is checked with a few frames instead of swept
//! (`focus.carry_from_last_part`, a full sweep when the check finds no peak); a turn's frames
//! start with the servo's ramp (`measure.frames_from_rest`) and end when they span the turn's
//! arc (a camera that misses triggers gives fewer frames, not a longer turn); a verify turn covers
//! `measure.verify_turn_deg` with the ring's roundness carried from the part's full turn
//! ([`crate::ring`]); and the servo goes from a turn straight to the push angle
//! (`push.align_during_stop`).
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
use crate::ring::RoundnessPrior;
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
    /// The focus position the last part found (`None`: none yet, or its focus failed): the
    /// next part's focus check starts there (`focus.carry_from_last_part`).
    pub carried_focus_um: Option<f64>,
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
            carried_focus_um: None,
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
        self.carried_focus_um = rec.focus_um;
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
        let carried = if self.recipe.focus.carry_from_last_part {
            self.carried_focus_um
        } else {
            None
        };
        let focus = self.focus(d, rec, carried)?;
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
        // Whether the servo still turns after a measuring turn (its stop joined to the align).
        let mut turning = false;
        let mut current =
            match self.gated_turn(d, rec, t0, TurnKind::Initial, None, &mut turning, obs)? {
                Gated::Trusted(f) => *f,
                Gated::Rejected(r, why) => return Ok((r, Some(why))),
            };
        // The ring's roundness from the part's full turn, carried into its shorter verify turns
        // (with the eccentricity it was fitted at: its chord).
        let shorter = self.recipe.measure.verify_turn_deg < self.recipe.measure.turn_deg;
        let mut ring = own_ring(&current).filter(|_| shorter);
        rec.initial_e_um = Some(current.0.e_px * um);
        rec.final_e_um = rec.initial_e_um;
        loop {
            let (e_um, theta_max) = (current.0.e_px * um, current.0.theta_max_deg);
            if e_um < aim {
                self.stop_turn(d, rec, &mut turning)?;
                return Ok((PartResult::Accepted, None));
            }
            // Between the aim and the threshold (live only), a part is accepted once the
            // pushes or the time are used up.
            if rec.pushes >= self.recipe.push.max_pushes {
                self.stop_turn(d, rec, &mut turning)?;
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
                self.stop_turn(d, rec, &mut turning)?;
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
            let pushed = self.push(d, &current, &plan, t - t0, &mut turning, rec)?;
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
            // The carried roundness with the chord of the eccentricity the push model expects.
            let carried = ring.as_ref().map(|(r, e_px, theta)| {
                let v = prediction.e_after_vec_um;
                let to = (v[0].hypot(v[1]) / um, v[1].atan2(v[0]).to_degrees());
                r.rechorded((*e_px, *theta), to, self.recipe.ring_radius_px())
            });
            let next = match self.gated_turn(
                d,
                rec,
                t0,
                TurnKind::Verify,
                carried.as_ref(),
                &mut turning,
                obs,
            )? {
                Gated::Trusted(f) => *f,
                Gated::Rejected(r, why) => return Ok((r, Some(why))),
            };
            if let Some(r) = own_ring(&next).filter(|_| shorter) {
                ring = Some(r);
            }
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
                self.stop_turn(d, rec, &mut turning)?;
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

    /// Stops the servo if a measuring turn left it turning (the stop counts to the turn).
    fn stop_turn<S, C, F, P, K>(
        &self,
        d: &mut Devices<S, C, F, P, K>,
        rec: &mut PartRecord,
        turning: &mut bool,
    ) -> Result<(), StationError>
    where
        S: Servo,
        K: Clock,
    {
        if *turning {
            let t = now(d)?;
            d.servo.stop().map_err(dev("servo"))?;
            *turning = false;
            rec.phase_times.measure_s += now(d)? - t;
        }
        Ok(())
    }

    /// Measures a turn and judges it; a turn that fails the gate or loses the ring is measured
    /// again (after a refocus) up to `quality.remeasure_turns` times. The first attempt carries
    /// `ring` (a verify turn over `measure.verify_turn_deg`); a re-measurement covers
    /// `measure.turn_deg` and fits its own roundness. A trusted turn may leave the servo turning
    /// (`turning`: `push.align_during_stop`); a rejected one leaves it stopped.
    #[allow(clippy::too_many_arguments)]
    fn gated_turn<S, C, F, P, K>(
        &self,
        d: &mut Devices<S, C, F, P, K>,
        rec: &mut PartRecord,
        t0: f64,
        kind: TurnKind,
        ring: Option<&RoundnessPrior>,
        turning: &mut bool,
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
            let (k, carried) = if attempt == 0 {
                (kind, ring)
            } else {
                (TurnKind::Remeasure, None)
            };
            let t = now(d)?;
            obs.phase(Phase::Measure(k));
            let turn = self.measure(d, t0, k, rec.turns.len(), rec.focus_um, carried, obs)?;
            *turning = self.recipe.push.align_during_stop;
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
            self.stop_turn(d, rec, turning)?;
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
                rec.focus_sweeps += 1;
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

    /// The part's focus: a check around `start` (the last part's focus) when there is one, a
    /// full sweep when there is none or the check finds no peak. `None` on focus failure.
    fn focus<S, C, F, P, K>(
        &self,
        d: &mut Devices<S, C, F, P, K>,
        rec: &mut PartRecord,
        start: Option<f64>,
    ) -> Result<Option<f64>, StationError>
    where
        C: Camera,
        F: FocusDrive,
    {
        if let Some(z0) = start {
            rec.focus_checks += 1;
            if let Some(z) = self.focus_check(d, z0)? {
                return Ok(Some(z));
            }
        }
        rec.focus_sweeps += 1;
        self.autofocus(d)
    }

    /// Focus check around `z0`: the focus measure at `z0` and `z0 ± focus.check_step_um`,
    /// walking on toward the best while it is at an end (at most `focus.check_max_points`
    /// positions), then the peak of the parabola through the log of the measure at the best and
    /// its two neighbours (exact for the Gaussian focus curve the sweep assumes too). `None` (a
    /// sweep follows) when the best stays at an end, or the best is below `focus.min_measure` or
    /// below `focus.min_contrast` × the worst position's: the same tests of a peak as the sweep's.
    fn focus_check<S, C, F, P, K>(
        &self,
        d: &mut Devices<S, C, F, P, K>,
        z0: f64,
    ) -> Result<Option<f64>, StationError>
    where
        C: Camera,
        F: FocusDrive,
    {
        let fs = &self.recipe.focus;
        let h = fs.check_step_um;
        // (step index, focus measure), in index order.
        let mut pts: std::collections::VecDeque<(i64, f64)> = std::collections::VecDeque::new();
        let look = |d: &mut Devices<S, C, F, P, K>, k: i64| -> Result<f64, StationError> {
            let z = z0 + k as f64 * h;
            // The drive stays where the last part left it: no move to the start.
            let there = k == 0
                && (d.focus.position_um().map_err(dev("focus drive"))? - z).abs() < FOCUS_AT_UM;
            if !there {
                d.focus.move_to_um(z).map_err(dev("focus drive"))?;
            }
            let f = d.camera.capture().map_err(dev("camera"))?;
            Ok(if f.focus_measure.is_finite() {
                f.focus_measure
            } else {
                0.0
            })
        };
        pts.push_back((0, look(d, 0)?));
        pts.push_front((-1, look(d, -1)?));
        pts.push_back((1, look(d, 1)?));
        let best = |pts: &std::collections::VecDeque<(i64, f64)>| {
            (0..pts.len()).fold(0, |b, i| if pts[i].1 > pts[b].1 { i } else { b })
        };
        while pts.len() < fs.check_max_points {
            let b = best(&pts);
            if b == 0 {
                let k = pts[0].0 - 1;
                pts.push_front((k, look(d, k)?));
            } else if b == pts.len() - 1 {
                let k = pts[b].0 + 1;
                pts.push_back((k, look(d, k)?));
            } else {
                break;
            }
        }
        let b = best(&pts);
        let worst = pts.iter().map(|p| p.1).fold(f64::INFINITY, f64::min);
        let m = pts[b].1;
        if b == 0
            || b == pts.len() - 1
            || m < fs.min_measure
            || m < fs.min_contrast * worst.max(1e-12)
        {
            return Ok(None);
        }
        let ln = |i: usize| pts[i].1.max(1e-12).ln();
        let (ym, y0, yp) = (ln(b - 1), ln(b), ln(b + 1));
        let curvature = ym - 2.0 * y0 + yp;
        if !curvature.is_finite() || curvature >= 0.0 {
            return Ok(None);
        }
        let t = (0.5 * (ym - yp) / curvature).clamp(-1.0, 1.0);
        let z = z0 + (pts[b].0 as f64 + t) * h;
        d.focus.move_to_um(z).map_err(dev("focus drive"))?;
        Ok(Some(z))
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

    /// One measuring turn over `measure.turn_deg`, or `measure.verify_turn_deg` with the ring's
    /// roundness `carried`; its fit and the quality gate's verdict. The servo keeps turning
    /// after the turn when `push.align_during_stop` (the caller stops it or aligns from it).
    #[allow(clippy::too_many_arguments)]
    fn measure<S, C, F, P, K>(
        &self,
        d: &mut Devices<S, C, F, P, K>,
        t0: f64,
        kind: TurnKind,
        turn_index: usize,
        focus_um: Option<f64>,
        carried: Option<&RoundnessPrior>,
        obs: &mut dyn Observer,
    ) -> Result<Turn, StationError>
    where
        S: Servo,
        C: Camera,
        K: Clock,
    {
        let ms = &self.recipe.measure;
        let arc = if carried.is_some() {
            ms.verify_turn_deg
        } else {
            ms.turn_deg
        };
        let t_start = now(d)?;
        if ms.frames_from_rest {
            d.servo.begin_turn(ms.speed_deg_per_s)
        } else {
            d.servo.start_turn(ms.speed_deg_per_s)
        }
        .map_err(dev("servo"))?;
        let n = self.recipe.frames_for_arc(arc);
        // The turn ends when its frames span the arc: after `n` frames from a camera that
        // delivers every trigger, or at the n-th frame's time (to half a frame) from one that
        // misses some. The quality gate judges the coverage and gaps of what it delivered.
        let span_s = (n as f64 - 1.5) / ms.fps;
        let mut first_s = None;
        let mut frames: Vec<CameraFrame> = Vec::with_capacity(n);
        for index in 0..n {
            let f = d.camera.capture().map_err(dev("camera"))?;
            let t_s = f.start_s + 0.5 * f.exposure_s - t_start;
            let spanned = t_s - *first_s.get_or_insert(t_s) >= span_s;
            obs.frame(&LiveFrame {
                turn: turn_index,
                index,
                frames: n,
                t_s,
                turn_deg: self.recipe.nominal_turn_deg(t_s),
                c_px: f.c_px.filter(|c| c.is_finite()),
            });
            frames.push(f);
            if spanned {
                break;
            }
        }
        if !self.recipe.push.align_during_stop {
            d.servo.stop().map_err(dev("servo"))?;
        }
        // From rest, the first frame is taken as the servo starts: the log reaches back before
        // it (the servo at rest), so that every frame's angle is interpolated, none cut off.
        let since = if ms.frames_from_rest {
            t_start - LOG_LEAD_S
        } else {
            t_start
        };
        let log = d.servo.angle_log(since).map_err(dev("servo"))?;
        obs.turn_inputs(&frames, &log);
        let (rec, fit) = evaluate_turn(
            &self.recipe,
            self.strategy,
            &frames,
            log,
            t_start - t0,
            kind,
            focus_um,
            carried,
        );
        obs.turn(&rec, fit.as_ref());
        Ok(match fit {
            Some(f) => Turn::Ok(rec, Box::new(f)),
            None => Turn::Lost(rec),
        })
    }

    /// Align, approach, push (open loop or under live feedback), retract; the push model's
    /// prediction for the verify turn. `None` if the ring was lost during a live push. A servo
    /// still `turning` from the measuring turn brakes into the align move. Each step's time
    /// goes into `rec`'s phase times.
    fn push<S, C, F, P, K>(
        &self,
        d: &mut Devices<S, C, F, P, K>,
        cur: &Trusted,
        plan: &PushPlan,
        t_start_s: f64,
        turning: &mut bool,
        rec: &mut PartRecord,
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
        let times = &mut rec.phase_times;
        // Align: the servo angle equivalent to the commanded direction nearest to where the
        // servo comes to rest (a turning servo brakes over v²/2a).
        let t = now(d)?;
        let now_deg = d.servo.angle_deg().map_err(dev("servo"))?;
        let rest_deg = if *turning {
            let m = &self.recipe.measure;
            now_deg + 0.5 * m.speed_deg_per_s * m.speed_deg_per_s / m.servo_accel_deg_per_s2
        } else {
            now_deg
        };
        let target = rest_deg + (plan.angle_deg - rest_deg + 180.0).rem_euclid(360.0) - 180.0;
        d.servo.move_to_deg(target).map_err(dev("servo"))?;
        *turning = false;
        let t = lap(d, t, &mut times.align_s)?;
        d.rod.approach(plan.approach).map_err(dev("push rod"))?;
        let t = lap(d, t, &mut times.approach_s)?;
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
        let t = lap(d, t, &mut times.stroke_s)?;
        d.rod.retract().map_err(dev("push rod"))?;
        lap(d, t, &mut times.retract_s)?;
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

/// The roundness a trusted turn fitted for itself (not carried from an earlier one), with the
/// eccentricity (px) and θ_max (degrees) it was fitted at: the prior of the part's later verify
/// turns.
fn own_ring(t: &Trusted) -> Option<(RoundnessPrior, f64, f64)> {
    if t.0.carried_roundness {
        None
    } else {
        t.0.ring.clone().map(|r| (r, t.0.e_px, t.0.theta_max_deg))
    }
}

/// How far back before a turn from rest its angle log is read, s.
const LOG_LEAD_S: f64 = 0.05;
/// The focus drive counts as at a position within this, µm (well inside the depth of focus).
const FOCUS_AT_UM: f64 = 1.0;

/// Adds the time since `t` to `part` and returns the time now.
fn lap<S, C, F, P, K: Clock>(
    d: &mut Devices<S, C, F, P, K>,
    t: f64,
    part: &mut Option<f64>,
) -> Result<f64, StationError> {
    let n = now(d)?;
    PhaseTimes::add(part, n - t);
    Ok(n)
}

fn now<S, C, F, P, K: Clock>(d: &mut Devices<S, C, F, P, K>) -> Result<f64, StationError> {
    d.clock.now_s().map_err(dev("clock"))
}
