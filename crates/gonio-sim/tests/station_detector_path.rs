//! The twin's camera path with a caller's camera (`run_batch_with`), here a cheap geometric one
//! built on the twin's exposures: the controller must do as well through it as through the fast
//! fidelity.

use gonio_sim::station::{
    BatchConfig, DeviceId, Shared, SimDeviceError, run_batch, run_batch_with,
};
use gonio_station::Strategy;
use gonio_station::hal::{Camera, CameraFrame};

/// The ring column from the geometry (no roundness, no noise) and a Gaussian focus curve.
struct Geometric(Shared);

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

#[test]
fn camera_path_matches_the_fast_fidelity_statistics() {
    let cfg = BatchConfig {
        parts: 200,
        strategy: Strategy::Learned,
        ..BatchConfig::default()
    };
    for seed in [1, 2] {
        let fast = run_batch(&cfg, seed, &mut |_, _, _| {}).unwrap().summary;
        let geo = run_batch_with(&cfg, seed, |t| Ok(Geometric(t)), &mut |_, _, _| {})
            .unwrap()
            .summary;
        eprintln!("seed {seed}: fast {fast:?}\n        geometric {geo:?}");
        // Different random streams, same plant: pushes per part have a standard deviation of
        // ≈ 0.6, so 200-part means agree to ≈ 0.06 (1σ); allow 4σ.
        assert!((fast.mean_pushes - geo.mean_pushes).abs() < 0.25);
        assert_eq!(geo.rejected, 0);
    }
}
