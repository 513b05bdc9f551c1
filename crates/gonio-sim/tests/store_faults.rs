//! Faults keep records: a device error, a lost ring and a focus failure in the middle of a part,
//! injected through the station's `Camera` and `PushRod` traits (wrapping the twin's devices, as
//! a real glitch would arrive), end that part with its reject reason, and the part is committed
//! to the results store whole (turns and pushes so far). The batch goes on to the next part, or
//! stops safely (stored as `stopped`, resumable) when the recipe's `on_device_error` says so.

use gonio_sim::station::{BatchConfig, PartDone, RunOptions, SimCamera, SimRod, run_batch_from};
use gonio_station::hal::{
    ApproachSpeed, Camera, CameraFrame, DeviceError, DeviceErrorKind, PushRod,
};
use gonio_station::{DeviceErrorPolicy, Recipe};
use gonio_store::{NewBatch, NewPart, PartQuery, StoredPart};
use gonio_vision::InvalidReason;
use std::cell::Cell;
use std::ops::ControlFlow;
use std::rc::Rc;

const SEED: u64 = 4;
const PARTS: usize = 4;

/// A device's error, or one injected by the test.
#[derive(Debug)]
enum Wrapped<E> {
    Device(E),
    Injected(&'static str),
}

impl<E: std::fmt::Display> std::fmt::Display for Wrapped<E> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Wrapped::Device(e) => e.fmt(f),
            Wrapped::Injected(what) => write!(f, "injected: {what}"),
        }
    }
}

impl<E: DeviceError> DeviceError for Wrapped<E> {
    fn kind(&self) -> DeviceErrorKind {
        match self {
            Wrapped::Device(e) => e.kind(),
            Wrapped::Injected(_) => DeviceErrorKind::Fault,
        }
    }
}

/// What goes wrong after the first push of a part.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Fault {
    /// The rod's drive faults on the first push stroke.
    RodOverload,
    /// The ring vanishes from the camera's view.
    RingLost,
    /// The ring vanishes and the image loses all contrast (no focus peak).
    FocusLost,
}

/// Shared between the wrappers and the test: the fault and whether it has struck in this part.
#[derive(Debug)]
struct Injector {
    fault: Fault,
    pushed: Cell<bool>,
    struck: Cell<usize>,
}

struct Rod {
    inner: SimRod,
    inj: Rc<Injector>,
}

impl PushRod for Rod {
    type Error = Wrapped<<SimRod as PushRod>::Error>;
    fn approach(&mut self, speed: ApproachSpeed) -> Result<(), Self::Error> {
        self.inner.approach(speed).map_err(Wrapped::Device)
    }
    fn push_um(&mut self, d_um: f64) -> Result<(), Self::Error> {
        if self.inj.fault == Fault::RodOverload && self.inj.struck.get() == 0 {
            self.inj.struck.set(1);
            return Err(Wrapped::Injected("push-rod drive overload"));
        }
        self.inj.pushed.set(true);
        self.inner.push_um(d_um).map_err(Wrapped::Device)
    }
    fn retract(&mut self) -> Result<(), Self::Error> {
        self.inner.retract().map_err(Wrapped::Device)
    }
}

struct Cam {
    inner: SimCamera,
    inj: Rc<Injector>,
}

impl Camera for Cam {
    type Error = Wrapped<<SimCamera as Camera>::Error>;
    fn capture(&mut self) -> Result<CameraFrame, Self::Error> {
        let mut f = self.inner.capture().map_err(Wrapped::Device)?;
        if self.inj.pushed.get() && self.inj.fault != Fault::RodOverload {
            self.inj.struck.set(self.inj.struck.get() + 1);
            f.c_px = None;
            f.invalid_reason = Some(InvalidReason::NoRing);
            if self.inj.fault == Fault::FocusLost {
                f.focus_measure = 1.0;
            }
        }
        Ok(f)
    }
}

/// Runs the batch with `fault` injected, committing every part as the station does; returns
/// the stored parts and the batch's stored status.
fn run(fault: Fault, policy: DeviceErrorPolicy) -> (Vec<StoredPart>, String, usize) {
    let dir = tempfile::tempdir().unwrap();
    let mut store = gonio_store::open(dir.path().join("r.sqlite").to_str().unwrap()).unwrap();
    let cfg = BatchConfig {
        parts: PARTS,
        recipe: Recipe {
            on_device_error: policy,
            ..Recipe::default()
        },
        ..BatchConfig::default()
    };
    let batch = store
        .begin_batch(&NewBatch {
            station: "test",
            seed: Some(SEED),
            config_json: "{}",
            parts_planned: PARTS,
            software_version: "test",
        })
        .unwrap();
    let inj = Rc::new(Injector {
        fault,
        pushed: Cell::new(false),
        struck: Cell::new(0),
    });
    let (ic, ir) = (inj.clone(), inj.clone());
    let mut faulted = 0;
    let report = run_batch_from(
        &cfg,
        SEED,
        RunOptions::default(),
        |t| {
            Ok(Cam {
                inner: SimCamera(t),
                inj: ic,
            })
        },
        |r| Rod { inner: r, inj: ir },
        &mut |d: &PartDone| {
            store
                .insert_part(&NewPart {
                    batch,
                    batch_index: d.index,
                    station: "test",
                    software_version: "test",
                    recipe: &cfg.recipe,
                    started_at: "2026-05-20T08:00:00Z",
                    ended_at: "2026-05-20T08:00:30Z",
                    record: &d.part.record,
                    learned: d.learned,
                    truth: Some((d.part.true_initial_e_um, d.part.true_final_e_um)),
                    simulated: true,
                })
                .unwrap();
            // The ring/focus faults strike once per part; the rod's once per batch.
            if inj.struck.get() > 0 {
                faulted += 1;
            }
            inj.pushed.set(false);
            if fault != Fault::RodOverload {
                inj.struck.set(0);
            }
            ControlFlow::Continue(())
        },
    )
    .unwrap();
    let status = match &report.stopped {
        Some(why) => {
            store
                .end_batch(batch, gonio_store::BatchStatus::Stopped, Some(why))
                .unwrap();
            "stopped"
        }
        None => {
            store
                .end_batch(batch, gonio_store::BatchStatus::Complete, None)
                .unwrap();
            "complete"
        }
    };
    let info = store.batch(batch).unwrap().unwrap();
    assert_eq!(info.status, status);
    let parts = store.parts(&PartQuery::default()).unwrap();
    // What is stored is what the station recorded (nothing lost on the way).
    assert_eq!(parts.len(), report.parts.len());
    for (s, r) in parts.iter().zip(&report.parts) {
        assert_eq!(s.result, r.record.result.name());
        assert_eq!(s.reject_reason, r.record.reject_reason);
        assert_eq!(s.turns.len(), r.record.turns.len());
        assert_eq!(s.push_log.len(), r.record.push_log.len());
    }
    (parts, info.status, faulted)
}

/// Parts with a push: where the fault strikes. The seed has some (asserted).
fn pushed(parts: &[StoredPart]) -> Vec<&StoredPart> {
    parts
        .iter()
        .filter(|p| p.initial_e_um.is_some_and(|e| e >= 5.0))
        .collect()
}

#[test]
fn a_device_error_mid_part_is_stored_and_the_batch_goes_on() {
    let (parts, status, _) = run(Fault::RodOverload, DeviceErrorPolicy::Continue);
    assert_eq!(parts.len(), PARTS, "the batch goes on");
    assert_eq!(status, "complete");
    let failed: Vec<_> = parts
        .iter()
        .filter(|p| p.result == "rejected_device_error")
        .collect();
    assert_eq!(failed.len(), 1);
    let p = failed[0];
    assert_eq!(p.verdict.name(), "reject");
    assert_eq!(
        p.reject_reason.as_deref(),
        Some("push rod: Fault error: injected: push-rod drive overload")
    );
    let fault = p.device_error.as_ref().expect("the device error is stored");
    assert_eq!(fault.device, "push rod");
    assert_eq!(fault.kind, DeviceErrorKind::Fault);
    // What the part did before the error is kept: its focus and its trusted initial turn.
    assert!(p.focus_um.is_some_and(f64::is_finite));
    assert_eq!(p.turns.len(), 1);
    assert!(p.turns[0].valid_frames > 0);
    assert!(p.push_log.is_empty(), "the failed push made no stroke");
    // The others are mounted as usual.
    assert!(
        parts
            .iter()
            .filter(|q| q.part != p.part)
            .all(|q| q.result == "accepted"),
        "{:?}",
        parts.iter().map(|q| &q.result).collect::<Vec<_>>()
    );
}

#[test]
fn a_device_error_stops_the_batch_safely_when_the_recipe_says_so() {
    let (parts, status, _) = run(Fault::RodOverload, DeviceErrorPolicy::Stop);
    let last = parts.last().unwrap();
    assert_eq!(last.result, "rejected_device_error");
    assert!(parts.len() < PARTS, "stopped after the failed part");
    assert_eq!(status, "stopped", "stored as stopped: resumable");
    assert!(
        parts[..parts.len() - 1]
            .iter()
            .all(|q| q.result == "accepted")
    );
}

#[test]
fn a_ring_lost_mid_part_is_stored_and_the_batch_goes_on() {
    let (parts, status, faulted) = run(Fault::RingLost, DeviceErrorPolicy::Stop);
    assert_eq!(parts.len(), PARTS, "not a device error: the batch goes on");
    assert_eq!(status, "complete");
    let hit = pushed(&parts);
    assert!(!hit.is_empty(), "the seed has parts that need a push");
    assert_eq!(hit.len(), faulted);
    for p in hit {
        assert_eq!(p.result, "rejected_ring_lost", "{:?}", p.reject_reason);
        let why = p.reject_reason.as_deref().unwrap();
        // The verify turn lost the ring, was measured again after a refocus (a full turn of
        // 258 frames), lost it again.
        assert!(
            why.starts_with("turn 3 lost the ring: 0 of 258 frames valid")
                && why.ends_with("(after 1 re-measurement(s))"),
            "{why}"
        );
        assert_eq!(p.turns.len(), 3);
        assert!(p.turns[0].quality.is_some() && p.turns[0].valid_frames == 258);
        for t in &p.turns[1..] {
            assert_eq!(t.valid_frames, 0);
            assert!(t.quality.is_none(), "a lost turn is not judged");
        }
        assert_eq!(p.push_log.len(), 1);
        assert_eq!(p.push_log[0].consistent, None, "no trusted verify turn");
        assert_eq!(p.remeasured_turns, 1);
    }
}

#[test]
fn a_focus_failure_mid_part_is_stored_and_the_batch_goes_on() {
    let (parts, status, faulted) = run(Fault::FocusLost, DeviceErrorPolicy::Stop);
    assert_eq!(parts.len(), PARTS);
    assert_eq!(status, "complete");
    let hit = pushed(&parts);
    assert!(!hit.is_empty());
    assert_eq!(hit.len(), faulted);
    for p in hit {
        assert_eq!(p.result, "rejected_focus_failure", "{:?}", p.reject_reason);
        let why = p.reject_reason.as_deref().unwrap();
        assert!(
            why.starts_with("turn 2 lost the ring")
                && why.ends_with("refocusing found no focus peak"),
            "{why}"
        );
        assert_eq!(p.turns.len(), 2, "initial and the lost verify turn");
        assert_eq!(p.push_log.len(), 1);
        assert!(p.phase_times.focus_s > 0.0);
    }
}
