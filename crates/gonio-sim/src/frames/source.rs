//! Rendered frames as a [`FrameSource`]: one turn of the table at constant speed (or, for the
//! `random` family, a fresh scene and pose per frame), each frame stamped with its time and
//! angle and its ground truth kept for the caller.
//!
//! ```
//! use gonio_sim::frames::{RenderedFrames, SceneChoice, ScenePreset, Turn};
//! use gonio_vision::{Optics, SourceDetector};
//! let optics = Optics::default();
//! let src = RenderedFrames::new(&optics, SceneChoice::Preset(ScenePreset::Realistic),
//!                               Turn::default(), 2, 5).unwrap();
//! let mut det = SourceDetector::new(src, &optics).unwrap();
//! while let Some(d) = det.detect_next().unwrap() {
//!     let truth = det.source().last_truth().unwrap();
//!     assert!((d.result.c_px.unwrap() - truth.c_true_px).abs() < 0.1);
//! }
//! ```

use super::{FrameTruth, GratingRenderer, GratingScene, SceneDraw, SceneFamily, ScenePreset};
use crate::SimError;
use gonio_vision::{FrameHeader, FrameSource, FrameStamp, Optics};

/// Which scene every frame shows.
#[derive(Debug, Clone, PartialEq)]
pub enum SceneChoice {
    /// One of the named scenes.
    Preset(ScenePreset),
    /// A scene given in full (e.g. from a scene TOML file).
    Scene(Box<GratingScene>),
    /// A new scene from the family for every frame (the `random` scene).
    Random(Box<SceneFamily>),
}

/// The table's motion over the frames: θ_k = start + speed·k/fps at mid-exposure.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Turn {
    /// θ of frame 0 at mid-exposure, degrees.
    pub start_deg: f64,
    /// Table speed, degrees per second.
    pub speed_deg_s: f64,
    /// Frame rate, frames per second.
    pub fps: f64,
    /// Exposure time, s.
    pub exposure_s: f64,
    /// Eccentricity of the grating, µm.
    pub eccentricity_um: f64,
    /// Eccentricity angle in the grating's frame, degrees.
    pub ecc_angle_deg: f64,
    /// Focus position (best focus at the scene's), µm.
    pub focus_um: f64,
    /// With a `random` scene: take θ, e and ψ from each drawn scene instead of this turn.
    pub drawn_pose: bool,
}

impl Default for Turn {
    /// The seed's measuring turn: 180°/s, 100 fps, 0.5 ms exposure; e = 100 µm at ψ = 30°.
    fn default() -> Self {
        Turn {
            start_deg: 0.0,
            speed_deg_s: 180.0,
            fps: 100.0,
            exposure_s: 0.5e-3,
            eccentricity_um: 100.0,
            ecc_angle_deg: 30.0,
            focus_um: 0.0,
            drawn_pose: false,
        }
    }
}

/// Seed of frame `k` of a run seeded with `seed` (noise, dust, and the drawn scene).
pub fn frame_seed(seed: u64, k: u64) -> u64 {
    seed.wrapping_mul(0x9E37_79B9_7F4A_7C15).wrapping_add(k)
}

/// Rendered frames, one after another (see the module documentation).
#[derive(Debug, Clone)]
pub struct RenderedFrames {
    renderer: GratingRenderer,
    family: Option<SceneFamily>,
    turn: Turn,
    count: u64,
    seed: u64,
    index: u64,
    last: Option<(FrameTruth, Option<SceneDraw>)>,
}

impl RenderedFrames {
    /// `count` frames of `scene` over `turn`, seeded with `seed`.
    ///
    /// # Errors
    /// [`SimError::Parameter`] for invalid optics, scene or turn values.
    pub fn new(
        optics: &Optics,
        scene: SceneChoice,
        turn: Turn,
        count: u64,
        seed: u64,
    ) -> Result<Self, SimError> {
        if !(turn.fps.is_finite() && turn.fps > 0.0) {
            return Err(SimError::parameter("fps", turn.fps, "a finite number > 0"));
        }
        for (name, v) in [
            ("start_deg", turn.start_deg),
            ("speed_deg_s", turn.speed_deg_s),
            ("exposure_s", turn.exposure_s),
        ] {
            if !v.is_finite() {
                return Err(SimError::parameter(name, v, "a finite number"));
            }
        }
        let (base, family) = match scene {
            SceneChoice::Preset(p) => (GratingScene::preset(p), None),
            SceneChoice::Scene(s) => (*s, None),
            SceneChoice::Random(f) => (GratingScene::default(), Some(*f)),
        };
        Ok(RenderedFrames {
            renderer: GratingRenderer::new(optics, base)?,
            family,
            turn,
            count,
            seed,
            index: 0,
            last: None,
        })
    }

    /// Only frames `first .. end` of the run (the same frames as in the whole run: each frame's
    /// scene, pose and noise depend on the run's seed and the frame's index only).
    pub fn frames(mut self, first: u64, end: u64) -> Self {
        self.index = first;
        self.count = end;
        self
    }

    /// The truth of the frame delivered last.
    pub fn last_truth(&self) -> Option<&FrameTruth> {
        self.last.as_ref().map(|l| &l.0)
    }

    /// The drawn scene and pose of the frame delivered last (`random` scenes only).
    pub fn last_draw(&self) -> Option<&SceneDraw> {
        self.last.as_ref().and_then(|l| l.1.as_ref())
    }

    /// The renderer of the fixed scene (for a `random` scene: the renderer's basic scene, unused).
    pub fn renderer(&self) -> &GratingRenderer {
        &self.renderer
    }
}

impl FrameSource for RenderedFrames {
    type Error = SimError;
    fn next_frame(&mut self, pixels: &mut Vec<u8>) -> Result<Option<FrameHeader>, SimError> {
        if self.index >= self.count {
            return Ok(None);
        }
        let k = self.index;
        let t = &self.turn;
        let (w, h) = self.renderer.size();
        pixels.resize(w * h, 0);
        let fs = frame_seed(self.seed, k);
        let mid_s = k as f64 / t.fps;
        let mut theta = t.start_deg + t.speed_deg_s * mid_s;
        let (truth, draw) = match &self.family {
            None => (
                self.renderer.render(
                    theta,
                    t.eccentricity_um,
                    t.ecc_angle_deg,
                    t.focus_um,
                    fs,
                    pixels,
                )?,
                None,
            ),
            Some(f) => {
                let um = self
                    .renderer
                    .optics()
                    .params()
                    .map_or(0.75, |p| p.um_per_px);
                let d = f.draw(fs, um, w, h);
                let r = self.renderer.with_scene(d.scene.clone())?;
                let (e, psi, z) = if t.drawn_pose {
                    theta = d.theta_deg;
                    (d.eccentricity_um, d.ecc_angle_deg, d.focus_um)
                } else {
                    (t.eccentricity_um, t.ecc_angle_deg, t.focus_um)
                };
                (r.render(theta, e, psi, z, fs, pixels)?, Some(d))
            }
        };
        self.last = Some((truth, draw));
        self.index += 1;
        Ok(Some(FrameHeader {
            width: w,
            height: h,
            stamp: FrameStamp {
                index: k,
                start_s: Some(mid_s - 0.5 * t.exposure_s),
                exposure_s: Some(t.exposure_s),
                theta_deg: Some(theta),
            },
        }))
    }
}
