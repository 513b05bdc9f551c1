//! Issue 15: the station pushes only on a measurement it can trust. Faults are injected through
//! the `Camera` and `PushRod` traits (wrappers around the twin's devices, as a real glitch would
//! arrive); for each, no push is made on an untrusted turn and the part ends in the stated
//! verdict with a record of why. On good parts the gate costs nothing.

use gonio_sim::station::{
    BatchConfig, BatchReport, PlantConfig, SimCamera, run_batch, run_batch_on,
};
use gonio_station::hal::{ApproachSpeed, Camera, CameraFrame, PushRod};
use gonio_station::quality::QualityCheck;
use gonio_station::{PartRecord, PartResult, Recipe, Strategy};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// Frames of one measuring turn and the angle between them (the default recipe: 200 frames,
/// 1.8°).
const TURN_FRAMES: u64 = 200;
const DEG_PER_FRAME: f64 = 1.8;

/// Where a frame lies in its run of back-to-back frames (a measuring turn, or one autofocus or
/// live-view reading): a frame more than 1.5 frame periods after the previous one starts a run.
#[derive(Debug, Default)]
struct Runs {
    last_start_s: Option<f64>,
    /// Index of the frame in its run.
    index: u64,
    /// Measuring turns seen before the current run.
    turns_before: u64,
}

impl Runs {
    fn see(&mut self, f: &CameraFrame) {
        let period = 0.01;
        match self.last_start_s {
            Some(t) if f.start_s - t < 1.5 * period => self.index += 1,
            _ => {
                if self.index + 1 >= TURN_FRAMES / 2 {
                    self.turns_before += 1;
                }
                self.index = 0;
            }
        }
        self.last_start_s = Some(f.start_s);
    }
    /// Angle turned since the run started, degrees.
    fn turned_deg(&self) -> f64 {
        self.index as f64 * DEG_PER_FRAME
    }
}

/// The camera faults of the issue.
#[derive(Debug, Clone, Copy)]
enum Fault {
    /// On this share of frames the detector returns a line at a fixed offset from the ring, px.
    Line { share: f64, offset_px: f64 },
    /// The ring's column jumps by this much halfway through every turn, px.
    Jump { px: f64 },
    /// A contiguous sector of every turn is dropped (no valid ring), degrees from the turn's
    /// start.
    Drop { from_deg: f64, to_deg: f64 },
}

struct FaultyCamera<C> {
    inner: C,
    fault: Fault,
    /// Turns affected (counted from the first); `None`: all.
    turns: Option<u64>,
    runs: Runs,
    rng: ChaCha8Rng,
}

impl<C> FaultyCamera<C> {
    fn new(inner: C, fault: Fault, turns: Option<u64>) -> Self {
        FaultyCamera {
            inner,
            fault,
            turns,
            runs: Runs::default(),
            rng: ChaCha8Rng::seed_from_u64(15),
        }
    }
}

impl<C: Camera> Camera for FaultyCamera<C> {
    type Error = C::Error;
    fn capture(&mut self) -> Result<CameraFrame, C::Error> {
        let mut f = self.inner.capture()?;
        self.runs.see(&f);
        if self.turns.is_some_and(|n| self.runs.turns_before >= n) {
            return Ok(f);
        }
        let turned = self.runs.turned_deg();
        match self.fault {
            Fault::Line { share, offset_px } => {
                if self.rng.random::<f64>() < share {
                    f.c_px = f.c_px.map(|c| c + offset_px);
                }
            }
            Fault::Jump { px } => {
                if turned >= 180.0 {
                    f.c_px = f.c_px.map(|c| c + px);
                }
            }
            Fault::Drop { from_deg, to_deg } => {
                if (from_deg..to_deg).contains(&turned) {
                    f.c_px = None;
                    f.invalid_reason = Some(gonio_vision::InvalidReason::NoRing);
                }
            }
        }
        Ok(f)
    }
}

/// A push rod whose gain silently falls to `gain` after `after` push cycles.
struct WeakRod<P> {
    inner: P,
    gain: f64,
    after: u32,
    cycles: u32,
}

impl<P: PushRod> PushRod for WeakRod<P> {
    type Error = P::Error;
    fn approach(&mut self, speed: ApproachSpeed) -> Result<(), P::Error> {
        self.inner.approach(speed)
    }
    fn push_um(&mut self, d_um: f64) -> Result<(), P::Error> {
        let k = if self.cycles >= self.after {
            self.gain
        } else {
            1.0
        };
        self.inner.push_um(k * d_um)
    }
    fn retract(&mut self) -> Result<(), P::Error> {
        self.cycles += 1;
        self.inner.retract()
    }
}

fn config(parts: usize, strategy: Strategy) -> BatchConfig {
    BatchConfig {
        parts,
        strategy,
        ..BatchConfig::default()
    }
}

fn with_camera(cfg: &BatchConfig, fault: Fault, turns: Option<u64>) -> BatchReport {
    run_batch_on(
        cfg,
        15,
        |t| Ok(FaultyCamera::new(SimCamera(t), fault, turns)),
        |r| r,
        &mut |_, _, _| {},
    )
    .unwrap()
}

/// Every push follows a turn that passed the gate, and every failed turn has its reasons.
fn assert_pushes_follow_trusted_turns(r: &PartRecord) {
    for p in &r.push_log {
        let before = r
            .turns
            .iter()
            .rev()
            .find(|t| t.t_start_s < p.t_start_s)
            .expect("a turn before every push");
        let q = before
            .quality
            .as_ref()
            .expect("a judged turn before a push");
        assert!(q.ok, "{}: pushed on an untrusted turn {q:?}", r.serial);
    }
    for t in &r.turns {
        if let Some(q) = &t.quality {
            assert_eq!(q.ok, q.failures.is_empty());
        }
    }
}

/// The camera fault's part: untrusted, no push, every turn kept, the reason recorded; each turn
/// failed at least one of `checks`.
fn assert_untrusted(r: &PartRecord, checks: &[QualityCheck]) {
    assert_eq!(
        r.result,
        PartResult::MeasurementUntrusted,
        "{}: {:?}",
        r.serial,
        r.reject_reason
    );
    assert_eq!(r.pushes, 0);
    assert!(r.push_log.is_empty());
    // The initial turn and its re-measurement after a refocus (the recipe's default: once).
    assert_eq!(r.turns.len(), 2);
    assert_eq!(r.remeasured_turns, 1);
    for t in &r.turns {
        let q = t.quality.as_ref().unwrap();
        assert!(!q.ok);
        assert!(
            q.failures.iter().any(|f| checks.contains(&f.check)),
            "{}: {:?}",
            r.serial,
            q.reasons()
        );
    }
    let why = r.reject_reason.as_deref().unwrap();
    assert!(checks.iter().any(|c| why.contains(c.name())), "{why}");
    // Never measured trustworthily: no e is reported.
    assert!(r.initial_e_um.is_none() && r.final_e_um.is_none());
}

/// What catches a line on 40 % of frames (see the test below).
const LINE_CHECKS: &[QualityCheck] = &[QualityCheck::Outliers, QualityCheck::ResidualRms];

#[test]
fn a_line_on_40_percent_of_frames_is_never_pushed_on() {
    // The detector follows a track-border line 25 px from the ring on 40 % of frames. Either the
    // robust fit follows the majority (the ring) and drops the line's frames as outliers (≈ 40 %
    // against the limit 5 %), or it settles between the two and its residual RMS is
    // ≈ 25·√(0.4·0.6) ≈ 12 px against 0.95 px. (When the line is on every valid frame, as in the
    // issue's turn, the residual catches it: see gonio-station's quality_gate tests.)
    let r = with_camera(
        &config(10, Strategy::Learned),
        Fault::Line {
            share: 0.4,
            offset_px: 25.0,
        },
        None,
    );
    for p in &r.parts {
        assert_pushes_follow_trusted_turns(&p.record);
        assert_untrusted(&p.record, LINE_CHECKS);
        assert_eq!(p.true_final_e_um, p.true_initial_e_um);
        eprintln!(
            "{}: {}",
            p.record.serial,
            p.record.reject_reason.as_deref().unwrap()
        );
    }
    assert_eq!(r.summary.untrusted, 10);
}

#[test]
fn a_5_px_jump_halfway_through_the_turn_is_never_pushed_on() {
    // The jump biases e by up to 5·2/π ≈ 3.2 px (2.4 µm) while the residual RMS stays near
    // 0.8 px, under its limit: the half-turn comparison catches it (c₀ differs by 5 px against
    // a standard error of ≈ 0.45·0.3 = 0.14 px in the half-turn model).
    let r = with_camera(
        &config(10, Strategy::Learned),
        Fault::Jump { px: 5.0 },
        None,
    );
    for p in &r.parts {
        assert_pushes_follow_trusted_turns(&p.record);
        assert_untrusted(&p.record, &[QualityCheck::HalfTurns]);
        assert_eq!(p.true_final_e_um, p.true_initial_e_um);
    }
}

#[test]
fn a_dropped_120_degrees_is_never_pushed_on() {
    let r = with_camera(
        &config(10, Strategy::Learned),
        Fault::Drop {
            from_deg: 120.0,
            to_deg: 240.0,
        },
        None,
    );
    for p in &r.parts {
        assert_pushes_follow_trusted_turns(&p.record);
        assert_untrusted(&p.record, &[QualityCheck::LargestGap]);
        let q = p.record.turns[0].quality.as_ref().unwrap();
        for c in [QualityCheck::Coverage, QualityCheck::FramesUsed] {
            assert!(q.failures.iter().any(|f| f.check == c), "{:?}", q.reasons());
        }
    }
}

#[test]
fn every_strategy_refuses_an_untrusted_turn() {
    for s in Strategy::ALL {
        let r = with_camera(
            &config(3, s),
            Fault::Line {
                share: 0.4,
                offset_px: 25.0,
            },
            None,
        );
        for p in &r.parts {
            assert_untrusted(&p.record, LINE_CHECKS);
        }
    }
}

#[test]
fn a_glitch_on_one_turn_costs_one_remeasurement() {
    // The fault on the first turn only: the re-measurement passes and the part goes on. On the
    // published sequence, whose turns and sweeps take the same time every time.
    let cfg = BatchConfig {
        recipe: Recipe::published(),
        ..config(1, Strategy::Learned)
    };
    let r = with_camera(&cfg, Fault::Jump { px: 5.0 }, Some(1));
    let p = &r.parts[0].record;
    assert_pushes_follow_trusted_turns(p);
    assert_eq!(p.result, PartResult::Accepted, "{:?}", p.reject_reason);
    assert_eq!(p.remeasured_turns, 1);
    assert!(!p.turns[0].quality.as_ref().unwrap().ok);
    assert!(p.turns[1].quality.as_ref().unwrap().ok);
    // The cost: one more autofocus (2.0 s each) and one more turn (2.8 s each).
    assert!(
        (p.phase_times.focus_s - 2.0 * 2.0).abs() < 0.01,
        "{:?}",
        p.phase_times
    );
    let turns = p.turns.len() as f64;
    assert!(
        (p.phase_times.measure_s - 2.8 * turns).abs() < 0.01,
        "{:?}",
        p.phase_times
    );
    assert!(p.reject_reason.is_none());
}

#[test]
fn a_rod_at_30_percent_gain_stops_after_one_push() {
    // The rod works for the first 20 push cycles (the controller learns gain ≈ 1), then silently
    // pushes at 30 %. A part whose verify turn finds it farther than the tolerance from where the
    // push model put it is rejected after that one push. Nominally that is every part whose
    // predicted move M leaves a shortfall 0.7·M above the tolerance 8 µm + 0.45·M (M > 32 µm);
    // but the fast approach's overshoot |N(0, 3 µm)|, the stick-slip U(0, 1.5 µm) and the 8 %
    // gain scatter also move the part, so near the boundary a part may still land within the
    // tolerance (SIM-15-0023: M = 54 µm, moved 23 µm instead of 16). With three standard
    // deviations of each, the shortfall exceeds the tolerance for every M > 60 µm.
    let cfg = config(40, Strategy::Learned);
    let r = run_batch_on(
        &cfg,
        15,
        |t| Ok(SimCamera(t)),
        |rod| WeakRod {
            inner: rod,
            gain: 0.3,
            after: 20,
            cycles: 0,
        },
        &mut |_, _, _| {},
    )
    .unwrap();
    let mut cycles = 0;
    let mut caught = 0;
    for p in &r.parts {
        let rec = &p.record;
        assert_pushes_follow_trusted_turns(rec);
        let weak = cycles >= 20;
        cycles += rec.pushes;
        if !weak {
            assert_eq!(rec.result, PartResult::Accepted, "{}", rec.serial);
            continue;
        }
        let first = match rec.push_log.first() {
            Some(f) => f,
            None => continue, // within the threshold from the start
        };
        if first.consistent == Some(false) && first.e_after_um.unwrap() >= cfg.recipe.threshold_um {
            assert_eq!(
                rec.result,
                PartResult::PushInconsistent,
                "{}: {:?}",
                rec.serial,
                rec.reject_reason
            );
            assert_eq!(rec.pushes, 1);
            assert_eq!(first.consistent, Some(false));
            assert!(first.deviation_um.unwrap() > first.tolerance_um);
            let why = rec.reject_reason.as_deref().unwrap();
            assert!(why.starts_with("push 1: verify turn"), "{why}");
            // The part moved only ≈ 30 % of the way: the record keeps its measured e.
            assert!(rec.final_e_um.unwrap() > 0.5 * rec.initial_e_um.unwrap());
            caught += 1;
        } else {
            // A smaller part still moves the right way (30 % per push) and ends within the
            // threshold or at the push limit.
            assert!(
                first.predicted_move_um <= 60.0,
                "{}: M = {} µm not caught",
                rec.serial,
                first.predicted_move_um
            );
            assert!(matches!(
                rec.result,
                PartResult::Accepted | PartResult::PushInconsistent | PartResult::RejectedMaxPushes
            ));
        }
    }
    eprintln!(
        "weak rod: {caught} parts stopped after one push; {:?}",
        r.summary
    );
    assert!(caught >= 15, "{caught}");
}

#[test]
fn a_part_that_does_not_move_is_not_shoved_again() {
    // A rod with no effect at all (gain 0) on parts of at least 20 µm: the shortfall M exceeds
    // 8 µm + 0.45·M for any M > 14.5 µm.
    let cfg = BatchConfig {
        plant: PlantConfig {
            e_min_um: 20.0,
            ..PlantConfig::default()
        },
        ..config(10, Strategy::Learned)
    };
    for s in Strategy::ALL {
        let cfg = BatchConfig {
            strategy: s,
            ..cfg.clone()
        };
        let r = run_batch_on(
            &cfg,
            16,
            |t| Ok(SimCamera(t)),
            |rod| WeakRod {
                inner: rod,
                gain: 0.0,
                after: 0,
                cycles: 0,
            },
            &mut |_, _, _| {},
        )
        .unwrap();
        for p in &r.parts {
            // Live feedback sees the ring not move and stops on stalls; open loop pushes once.
            assert_eq!(
                p.record.result,
                PartResult::PushInconsistent,
                "{s:?} {}: {:?}",
                p.record.serial,
                p.record.reject_reason
            );
            assert_eq!(p.record.pushes, 1);
        }
    }
}

#[test]
fn no_cost_on_good_parts_false_reject_rate() {
    // Issue 15, point 4: over 1 000 good parts on the default plant the gate rejects ≤ 0.5 %
    // (≤ 5 parts). Expected: none. A part is rejected only when a turn and its re-measurement
    // both fail; the likeliest false alarm, the half-turn check (χ₃-distributed on good turns,
    // limit at its 10⁻⁴ tail), makes that ≈ 10⁻⁸ per part; the residual stays below 0.35 px
    // against 0.95 px, the push deviation below 0.8 of its tolerance.
    for s in Strategy::ALL {
        // The paper's strategy stamps a frame with the servo's last 1 ms sample before
        // mid-exposure: its angle lags by up to speed × 1 ms, 0.43° at the default sequence's
        // 432°/s (SD 0.12°: 1.3 px of column at e = 450 µm), which fails large parts' turns.
        // It is the published station's method, judged on the published sequence (180°/s).
        let cfg = match s {
            Strategy::Paper => BatchConfig {
                recipe: Recipe::published(),
                ..config(1000, s)
            },
            _ => config(1000, s),
        };
        let r = run_batch(&cfg, 2024, &mut |_, _, _| {}).unwrap();
        let b = &r.summary;
        eprintln!(
            "{:>13}: 1000 good parts: {} measurement_untrusted, {} push_inconsistent, {} turns re-measured; pushes {:.2}, time {:.1} s, final e {:.2} µm",
            s.name(),
            b.untrusted,
            b.push_inconsistent,
            b.remeasured_turns,
            b.mean_pushes,
            b.mean_time_s.unwrap(),
            b.mean_final_e_um.unwrap()
        );
        assert!(b.untrusted + b.push_inconsistent <= 5, "{b:?}");
        assert_eq!(b.device_errors, 0);
        for p in &r.parts {
            assert_pushes_follow_trusted_turns(&p.record);
        }
    }
}
