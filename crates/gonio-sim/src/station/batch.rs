//! A batch of parts mounted on the simulated station, with the station's records and the
//! simulation's ground truth side by side.

use super::frames::{FrameTap, TappedCamera, frame_camera};
use super::pace::Pace;
use super::plant::{PartTruth, PlantConfig, StationTruth};
use super::twin::{Faults, Shared, SimCamera, SimClock, SimFocus, SimRod, SimServo, Twin};
use crate::frames::GratingScene;
use gonio_station::hal::{Camera, PushRod};
use gonio_station::observe::{NoObserver, Observer};
use gonio_station::strategy::Learned;
pub use gonio_station::summary::{BatchSummary, SummaryBuilder};
use gonio_station::{
    Controller, DeviceErrorPolicy, Devices, PartRecord, Recipe, StationError, Strategy,
};
use serde::{Deserialize, Serialize};
use std::cell::RefCell;
use std::ops::ControlFlow;
use std::rc::Rc;

/// How frames are simulated.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Fidelity {
    /// Ring column from the geometry plus the detector's noise.
    #[default]
    Fast,
    /// Frames rendered and run through the real detector.
    Frames,
}

/// What to simulate.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct BatchConfig {
    /// Number of parts.
    pub parts: usize,
    /// The push strategy.
    pub strategy: Strategy,
    /// Frame fidelity.
    pub fidelity: Fidelity,
    /// The scene the frames fidelity renders (`None`: the `realistic` scene).
    pub scene: Option<GratingScene>,
    /// The recipe.
    pub recipe: Recipe,
    /// The plant.
    pub plant: PlantConfig,
    /// Injected faults.
    pub faults: Faults,
}

impl Default for BatchConfig {
    fn default() -> Self {
        BatchConfig {
            parts: 25,
            strategy: Strategy::default(),
            fidelity: Fidelity::Fast,
            scene: None,
            recipe: Recipe::default(),
            plant: PlantConfig::default(),
            faults: Faults::default(),
        }
    }
}

/// One part: the station's record and the simulation's truth.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SimPartRecord {
    /// What the station recorded.
    #[serde(flatten)]
    pub record: PartRecord,
    /// True initial eccentricity, µm.
    pub true_initial_e_um: f64,
    /// True final eccentricity, µm.
    pub true_final_e_um: f64,
}

/// The batch's result.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct BatchReport {
    /// The seed.
    pub seed: u64,
    /// Strategy name.
    pub strategy: String,
    /// Fidelity.
    pub fidelity: Fidelity,
    /// Recipe name.
    pub recipe: String,
    /// The simulated station's true constants.
    pub station_truth: StationTruth,
    /// What the controller learned by the end.
    pub learned: Learned,
    /// Every part (empty when the run discarded them: [`RunOptions::discard_parts`]).
    pub parts: Vec<SimPartRecord>,
    /// Why the batch stopped before its last part (a device error under the recipe's
    /// `on_device_error = "stop"`); `None` when every part was mounted.
    pub stopped: Option<String>,
    /// Summary.
    pub summary: BatchSummary,
}

/// Summarises part records (their truth with them).
pub fn summarise(parts: &[SimPartRecord]) -> BatchSummary {
    let mut s = SummaryBuilder::default();
    for p in parts {
        s.add(&p.record, Some(p.true_final_e_um));
    }
    s.finish()
}

/// Mounts `cfg.parts` simulated parts with one controller (learning carries across parts).
/// `progress(done, total, part)` is called after every part. The same seed gives the same
/// report; part `i` is the same part for every strategy.
///
/// A device error (injected through [`Faults`], or a frame that cannot be rendered or detected)
/// ends its part `rejected_device_error`; the batch then stops or goes on as the recipe's
/// `on_device_error` says ([`BatchReport::stopped`]).
///
/// The `frames` fidelity renders every frame of `cfg.scene` (default: the `realistic` scene) and
/// runs it through the station's own camera path (`gonio_station::DetectorCamera` over
/// [`TwinFrames`](super::TwinFrames)); the fast one computes each frame's column from the
/// geometry ([`SimCamera`]). Both report the detector's reasons for the frames they cannot use.
///
/// # Errors
/// [`StationError::RecipeValue`] for an invalid recipe; [`StationError::Device`] when the
/// renderer and detector of the `frames` fidelity cannot be set up.
pub fn run_batch(
    cfg: &BatchConfig,
    seed: u64,
    progress: &mut dyn FnMut(usize, usize, &SimPartRecord),
) -> Result<BatchReport, StationError> {
    run_batch_observed(cfg, seed, RunOptions::default(), &mut |d: &PartDone| {
        progress(d.index + 1, d.total, d.part);
        ControlFlow::Continue(())
    })
}

/// As [`run_batch_from`] with the twin's own camera for `cfg.fidelity` (as [`run_batch`]): a
/// batch from any part, observed, paced, each part handed to `on_part` as it finishes.
///
/// # Errors
/// As [`run_batch`].
pub fn run_batch_observed(
    cfg: &BatchConfig,
    seed: u64,
    mut opts: RunOptions<'_>,
    on_part: &mut dyn FnMut(&PartDone) -> ControlFlow<()>,
) -> Result<BatchReport, StationError> {
    let setup = |e: crate::SimError| StationError::Device {
        device: "camera",
        kind: gonio_station::hal::DeviceErrorKind::Other,
        message: format!("cannot set up the renderer and detector: {e}"),
    };
    match (cfg.fidelity, opts.frame_tap.take()) {
        (Fidelity::Fast, _) => {
            run_batch_from(cfg, seed, opts, |t| Ok(SimCamera(t)), |r| r, on_part)
        }
        (Fidelity::Frames, None) => run_batch_from(
            cfg,
            seed,
            opts,
            |t| frame_camera(t, &cfg.recipe.optics(), cfg.scene.clone()).map_err(setup),
            |r| r,
            on_part,
        ),
        (Fidelity::Frames, Some(tap)) => run_batch_from(
            cfg,
            seed,
            opts,
            |t| TappedCamera::new(t, &cfg.recipe.optics(), cfg.scene.clone(), tap).map_err(setup),
            |r| r,
            on_part,
        ),
    }
}

/// As [`run_batch`], with the camera `camera(twin)` makes for the simulated station (a test's
/// own camera, built on [`Twin::expose`] or on [`TwinFrames`](super::TwinFrames)).
///
/// # Errors
/// As [`run_batch`], and whatever `camera` returns.
pub fn run_batch_with<C: Camera>(
    cfg: &BatchConfig,
    seed: u64,
    camera: impl FnOnce(Shared) -> Result<C, StationError>,
    progress: &mut dyn FnMut(usize, usize, &SimPartRecord),
) -> Result<BatchReport, StationError> {
    run_batch_on(cfg, seed, camera, |r| r, progress)
}

/// As [`run_batch_with`], with the twin's push rod wrapped by the caller too (to inject faults
/// through the `Camera` and `PushRod` traits, as a real glitch would arrive).
///
/// # Errors
/// As [`run_batch_with`].
pub fn run_batch_on<C: Camera, P: PushRod>(
    cfg: &BatchConfig,
    seed: u64,
    camera: impl FnOnce(Shared) -> Result<C, StationError>,
    rod: impl FnOnce(SimRod) -> P,
    progress: &mut dyn FnMut(usize, usize, &SimPartRecord),
) -> Result<BatchReport, StationError> {
    run_batch_from(
        cfg,
        seed,
        RunOptions::default(),
        camera,
        rod,
        &mut |d: &PartDone| {
            progress(d.index + 1, d.total, d.part);
            ControlFlow::Continue(())
        },
    )
}

/// Where a batch starts and how it runs (see [`run_batch_from`]).
#[derive(Default)]
pub struct RunOptions<'a> {
    /// 0-based index of the first part to mount: a resumed batch starts after its last stored
    /// part.
    pub first_part: usize,
    /// What the controller had learned before that part (a resumed batch: from the last stored
    /// part; a new batch: nothing).
    pub learned: Learned,
    /// The focus the part before found (a resumed batch: the last stored part's `focus_um`; a
    /// new batch: none), where the first part's focus check starts.
    pub carried_focus_um: Option<f64>,
    /// Told everything the controller does, as it happens (a live view).
    pub observer: Option<&'a mut dyn Observer>,
    /// Run in step with the wall clock (a live view); `None`: as fast as possible.
    pub pace: Option<Pace>,
    /// Told every rendered frame with the detector's result (full fidelity only; see
    /// [`run_batch_observed`]): a recorder, the live view's thumbnail.
    pub frame_tap: Option<FrameTap<'a>>,
    /// Keep no part in the report ([`BatchReport::parts`] empty; the summary still counts
    /// every part, and `on_part` still sees each): a long batch in bounded memory.
    pub discard_parts: bool,
}

impl std::fmt::Debug for RunOptions<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("RunOptions")
            .field("first_part", &self.first_part)
            .field("learned", &self.learned)
            .field("carried_focus_um", &self.carried_focus_um)
            .field("observed", &self.observer.is_some())
            .field("pace", &self.pace)
            .field("tapped", &self.frame_tap.is_some())
            .field("discard_parts", &self.discard_parts)
            .finish()
    }
}

/// A part just finished, as [`run_batch_from`] reports it.
#[derive(Debug, Clone, Copy)]
pub struct PartDone<'a> {
    /// 0-based index of the part in the batch.
    pub index: usize,
    /// Parts in the batch.
    pub total: usize,
    /// The part's record and truth.
    pub part: &'a SimPartRecord,
    /// What the controller has learned after this part (the state a resumed batch restores).
    pub learned: &'a Learned,
}

/// Mounts parts `opts.first_part..cfg.parts` of the batch `seed`, calling `on_part` as each one
/// finishes (to commit it to a results store); `on_part` returning [`ControlFlow::Break`] ends
/// the batch there (the report then holds the parts so far).
///
/// Part `i` depends only on the seed, `i` and the controller's state before it (what it
/// learned and the focus it carries; each part has its own random stream and clock; the
/// station's constants come from the seed), so a batch resumed at part `i` with the learned
/// state and the focus stored with part `i − 1` gives the same records as an uninterrupted one.
///
/// # Errors
/// As [`run_batch`].
pub fn run_batch_from<C: Camera, P: PushRod>(
    cfg: &BatchConfig,
    seed: u64,
    opts: RunOptions<'_>,
    camera: impl FnOnce(Shared) -> Result<C, StationError>,
    rod: impl FnOnce(SimRod) -> P,
    on_part: &mut dyn FnMut(&PartDone) -> ControlFlow<()>,
) -> Result<BatchReport, StationError> {
    cfg.recipe.validate()?;
    let r = &cfg.recipe;
    let mut twin = Twin::new(
        cfg.plant.clone(),
        r.um_per_px,
        r.measure.fps,
        r.measure.exposure_s,
        seed,
    );
    twin.faults = cfg.faults.clone();
    // A resumed batch: the focus drive where the last stored part's focus left it (a part ends
    // with its drive at its focus, unless a refocus failed after it).
    if let Some(z) = opts.carried_focus_um {
        twin.place_focus(z);
    }
    if let Some(p) = opts.pace {
        twin.set_pace(p);
    }
    let station_truth = twin.station;
    let shared = Rc::new(RefCell::new(twin));
    let mut devices = Devices {
        servo: SimServo(shared.clone()),
        camera: camera(shared.clone())?,
        focus: SimFocus(shared.clone()),
        rod: rod(SimRod(shared.clone())),
        clock: SimClock(shared.clone()),
    };
    let mut ctl = Controller::new(cfg.recipe.clone(), cfg.strategy);
    ctl.learned = opts.learned;
    ctl.carried_focus_um = opts.carried_focus_um;
    let mut none = NoObserver;
    let obs: &mut dyn Observer = match opts.observer {
        Some(o) => o,
        None => &mut none,
    };
    let mut parts = if opts.discard_parts {
        Vec::new()
    } else {
        Vec::with_capacity(cfg.parts.saturating_sub(opts.first_part))
    };
    let mut summary = SummaryBuilder::default();
    let mut stopped = None;
    for i in opts.first_part..cfg.parts {
        let truth = PartTruth::draw(&cfg.plant, seed, i as u64 + 1);
        let true_initial = truth.e_um();
        shared.borrow_mut().load_part(truth);
        let serial = format!("SIM-{seed}-{:04}", i + 1);
        let record = ctl.mount_observed(&mut devices, &serial, obs)?;
        let true_final = shared.borrow().true_e_um();
        let p = SimPartRecord {
            record,
            true_initial_e_um: true_initial,
            true_final_e_um: true_final,
        };
        let flow = on_part(&PartDone {
            index: i,
            total: cfg.parts,
            part: &p,
            learned: &ctl.learned,
        });
        let failed = p.record.device_error.is_some();
        if failed && cfg.recipe.on_device_error == DeviceErrorPolicy::Stop && i + 1 < cfg.parts {
            stopped = Some(format!(
                "stopped after part {} of {} ({}): {}",
                i + 1,
                cfg.parts,
                p.record.serial,
                p.record.reject_reason.as_deref().unwrap_or("device error")
            ));
        }
        summary.add(&p.record, Some(p.true_final_e_um));
        if !opts.discard_parts {
            parts.push(p);
        }
        if stopped.is_some() || flow.is_break() {
            break;
        }
    }
    let summary = summary.finish();
    Ok(BatchReport {
        seed,
        strategy: cfg.strategy.name().to_string(),
        fidelity: cfg.fidelity,
        recipe: cfg.recipe.name.clone(),
        station_truth,
        learned: ctl.learned,
        parts,
        stopped,
        summary,
    })
}

/// The plant's parameters, for reports.
pub fn default_plant() -> PlantConfig {
    PlantConfig::default()
}
