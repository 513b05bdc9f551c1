//! Full fidelity: every frame rendered by the grating renderer ([`crate::frames`]) at the twin's
//! current exposure ([`TwinFrames`], a `FrameSource`) and run through the real streaming detector
//! by the station's own camera (`gonio_station::DetectorCamera`): the same typed path as a real
//! camera's.

use super::twin::{DeviceId, Exposure, Shared, SimDeviceError};
use crate::SimError;
use crate::frames::{FrameTruth, GratingRenderer, GratingScene, ScenePreset};
use gonio_station::hal::{Camera, CameraFrame, DeviceErrorKind};
use gonio_station::{DetectorCamera, DetectorCameraError};
use gonio_vision::{FrameHeader, FrameSource, FrameStamp, Optics};

/// The twin's camera sensor at full fidelity: renders the grating as the twin has it at each
/// exposure (servo angle at mid-exposure, the part's offset, defocus), a ring-less grating once
/// the ring is lost (fault injection). Counts as the camera for injected device faults.
#[derive(Debug)]
pub struct TwinFrames {
    twin: Shared,
    renderer: GratingRenderer,
    no_ring: GratingRenderer,
    index: u64,
}

impl TwinFrames {
    /// Frames of `scene` through `optics` for the twin behind `twin`.
    ///
    /// # Errors
    /// [`SimError::Parameter`] when the optics or scene are invalid.
    pub fn new(twin: Shared, optics: &Optics, scene: GratingScene) -> Result<Self, SimError> {
        let renderer = GratingRenderer::new(optics, scene)?;
        let no_ring = renderer.with_scene(GratingScene {
            ring_present: false,
            ..renderer.scene().clone()
        })?;
        Ok(TwinFrames {
            twin,
            renderer,
            no_ring,
            index: 0,
        })
    }
}

impl FrameSource for TwinFrames {
    type Error = SimDeviceError;
    fn next_frame(&mut self, pixels: &mut Vec<u8>) -> Result<Option<FrameHeader>, SimDeviceError> {
        let x = {
            let mut t = self.twin.borrow_mut();
            t.call(DeviceId::Camera)?;
            t.expose()
        };
        let r = if x.ring_lost {
            &self.no_ring
        } else {
            &self.renderer
        };
        let (w, h) = r.size();
        pixels.resize(w * h, 0);
        x.render(r, pixels).map_err(|err| SimDeviceError {
            device: DeviceId::Camera,
            kind: DeviceErrorKind::Fault,
            message: format!("cannot render the frame: {err}"),
        })?;
        let stamp = FrameStamp {
            index: self.index,
            start_s: Some(x.start_s),
            exposure_s: Some(x.exposure_s),
            theta_deg: Some(x.theta_deg),
        };
        self.index += 1;
        Ok(Some(FrameHeader {
            width: w,
            height: h,
            stamp,
        }))
    }
}

/// The twin's camera at full fidelity: rendered frames through the station's detector camera.
pub type FrameCamera = DetectorCamera<TwinFrames>;

/// The full-fidelity camera for the twin behind `twin`: `scene` (default: the `realistic` scene)
/// through `optics` (a recipe's: `Recipe::optics`).
///
/// # Errors
/// [`SimError::Parameter`] when the scene or the optics are invalid.
pub fn frame_camera(
    twin: Shared,
    optics: &Optics,
    scene: Option<GratingScene>,
) -> Result<FrameCamera, SimError> {
    let optics = optics.clone();
    let scene = scene.unwrap_or_else(|| GratingScene::preset(ScenePreset::Realistic));
    let frames = TwinFrames::new(twin, &optics, scene)?;
    DetectorCamera::new(frames, &optics)
        .map_err(|e| SimError::parameter("optics", e, "valid optics for the detector"))
}

// The full-fidelity camera tells its frames through the station's one frame tap.
pub use gonio_station::tap::{FrameTap, SeenFrame};

impl Exposure {
    /// Renders the grating as this exposure shows it (the servo angle at mid-exposure, the
    /// part's offset, defocus, the frame's noise seed) into `pixels`, `r`'s size.
    ///
    /// The renderer's grating centre at table angle θ is e·(cos(θ+ψ), sin(θ+ψ)) with X toward
    /// the camera (columns increase with X); the twin's camera sees offset·(cos θ, sin θ), i.e.
    /// e·cos(θ − θ_e): ψ = −θ_e.
    ///
    /// # Errors
    /// As [`GratingRenderer::render`], whose ground truth of the frame this returns.
    pub fn render(&self, r: &GratingRenderer, pixels: &mut [u8]) -> Result<FrameTruth, SimError> {
        let e = self.offset_um[0].hypot(self.offset_um[1]);
        let psi = -self.offset_um[1].atan2(self.offset_um[0]).to_degrees();
        r.render(self.theta_deg, e, psi, self.dz_um, self.seed, pixels)
    }
}

/// The full-fidelity camera with a tap: every frame is handed to the tap with the detector's
/// result after it is detected. What the station gets is exactly what [`FrameCamera`] gives.
pub struct TappedCamera<'a> {
    cam: FrameCamera,
    tap: FrameTap<'a>,
}

impl std::fmt::Debug for TappedCamera<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("TappedCamera")
            .field("cam", &self.cam)
            .finish_non_exhaustive()
    }
}

impl<'a> TappedCamera<'a> {
    /// As [`frame_camera`], telling `tap` every frame.
    ///
    /// # Errors
    /// As [`frame_camera`].
    pub fn new(
        twin: Shared,
        optics: &Optics,
        scene: Option<GratingScene>,
        tap: FrameTap<'a>,
    ) -> Result<Self, SimError> {
        Ok(TappedCamera {
            cam: frame_camera(twin, optics, scene)?,
            tap,
        })
    }
}

impl Camera for TappedCamera<'_> {
    type Error = DetectorCameraError<SimDeviceError>;
    fn capture(&mut self) -> Result<CameraFrame, Self::Error> {
        let f = self.cam.capture()?;
        if let Some(seen) = self.cam.seen() {
            (self.tap)(&seen);
        }
        Ok(f)
    }
}
