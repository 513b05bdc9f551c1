//! Helpers shared by the station tests.

use gonio_sim::station::{DeviceId, Shared, SimDeviceError};
use gonio_station::hal::{Camera, CameraFrame};

/// A perfect camera: the ring's column straight from the geometry (no roundness, no noise) and a
/// Gaussian focus curve. It draws each frame's exposure from the twin like the frames fidelity,
/// so the plant's random draws match those of a run with the real detector.
pub struct Geometric(pub Shared);

impl Camera for Geometric {
    type Error = SimDeviceError;
    fn capture(&mut self) -> Result<CameraFrame, SimDeviceError> {
        let mut t = self.0.borrow_mut();
        t.call(DeviceId::Camera)?;
        let x = t.expose();
        let th = x.theta_deg.to_radians();
        let c = 720.0 + (x.offset_um[0] * th.cos() + x.offset_um[1] * th.sin()) / 0.75;
        Ok(CameraFrame {
            start_s: x.start_s,
            exposure_s: x.exposure_s,
            c_px: Some(c),
            invalid_reason: None,
            focus_measure: 40.0 * (-0.5 * (x.dz_um / 25.0).powi(2)).exp() + 2.0,
        })
    }
}
