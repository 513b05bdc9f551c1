//! Full fidelity: every frame rendered by the grating renderer ([`crate::frames`]) and run
//! through the real streaming detector (`gonio_vision::Detector`).

use super::twin::FrameDetector;
use crate::SimError;
use crate::frames::{GratingRenderer, GratingScene};
use gonio_vision::{Detector, Optics};

/// Render → detect, one frame at a time, reusing one frame buffer.
pub struct RenderedDetector {
    renderer: GratingRenderer,
    detector: Detector,
    buf: Vec<u8>,
}

impl std::fmt::Debug for RenderedDetector {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("RenderedDetector").finish_non_exhaustive()
    }
}

impl RenderedDetector {
    /// The seed's optics and the renderer's default scene.
    ///
    /// # Errors
    /// [`SimError::Parameter`] when the optics or scene are invalid.
    pub fn new(optics: &Optics, scene: GratingScene) -> Result<Self, SimError> {
        let renderer = GratingRenderer::new(optics, scene)?;
        let detector = Detector::new(optics)
            .map_err(|e| SimError::parameter("optics", e, "valid optics for the detector"))?;
        let buf = vec![0u8; renderer.frame_len()];
        Ok(RenderedDetector {
            renderer,
            detector,
            buf,
        })
    }

    /// The seed's station: default optics and scene.
    ///
    /// # Errors
    /// As [`RenderedDetector::new`].
    pub fn seed_station() -> Result<Self, SimError> {
        Self::new(&Optics::default(), GratingScene::default())
    }
}

impl FrameDetector for RenderedDetector {
    fn detect(
        &mut self,
        theta_deg: f64,
        offset_um: [f64; 2],
        dz_um: f64,
        frame_seed: u64,
    ) -> (Option<f64>, String, f64) {
        // The renderer's grating centre at table angle θ is e·(cos(θ+ψ), sin(θ+ψ)) with X toward
        // the camera (columns increase with X); the twin's camera sees offset·(cos θ, sin θ),
        // i.e. e·cos(θ − θ_e): ψ = −θ_e.
        let e = offset_um[0].hypot(offset_um[1]);
        let psi = -offset_um[1].atan2(offset_um[0]).to_degrees();
        match self
            .renderer
            .render(theta_deg, e, psi, dz_um, frame_seed, &mut self.buf)
        {
            Err(err) => (None, format!("render failed: {err}"), 0.0),
            Ok(_) => match self.detector.detect(&self.buf) {
                Err(err) => (None, format!("detector failed: {err}"), 0.0),
                Ok(r) => (
                    r.c_px.filter(|_| r.valid),
                    r.reason.map_or(String::new(), |x| format!("{x:?}")),
                    r.focus,
                ),
            },
        }
    }
}
