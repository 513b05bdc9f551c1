//! The twin's frame-detector path (used by the full fidelity) with a cheap geometric detector:
//! the controller must do as well through it as through the fast fidelity.

use gonio_sim::station::{BatchConfig, FrameDetector, run_batch, run_batch_with};
use gonio_station::Strategy;

/// The ring column from the geometry (no roundness, no noise) and a Gaussian focus curve.
struct Geometric;

impl FrameDetector for Geometric {
    fn detect(
        &mut self,
        theta_deg: f64,
        offset_um: [f64; 2],
        dz_um: f64,
        _frame_seed: u64,
    ) -> (Option<f64>, String, f64) {
        let t = theta_deg.to_radians();
        let c = 720.0 + (offset_um[0] * t.cos() + offset_um[1] * t.sin()) / 0.75;
        (
            Some(c),
            String::new(),
            40.0 * (-0.5 * (dz_um / 25.0).powi(2)).exp() + 2.0,
        )
    }
}

#[test]
fn detector_path_matches_the_fast_fidelity_statistics() {
    let cfg = BatchConfig {
        parts: 200,
        strategy: Strategy::Learned,
        ..BatchConfig::default()
    };
    for seed in [1, 2] {
        let fast = run_batch(&cfg, seed, &mut |_, _, _| {}).unwrap().summary;
        let geo = run_batch_with(&cfg, seed, Some(Box::new(Geometric)), &mut |_, _, _| {})
            .unwrap()
            .summary;
        eprintln!("seed {seed}: fast {fast:?}\n        geometric {geo:?}");
        // Different random streams, same plant: pushes per part have a standard deviation of
        // ≈ 0.6, so 200-part means agree to ≈ 0.06 (1σ); allow 4σ.
        assert!((fast.mean_pushes - geo.mean_pushes).abs() < 0.25);
        assert_eq!(geo.rejected, 0);
    }
}
