//! The twin's camera path with a caller's camera (`run_batch_with`), here a cheap geometric one
//! built on the twin's exposures: the controller must do as well through it as through the fast
//! fidelity.

use gonio_sim::station::{BatchConfig, run_batch, run_batch_with};
use gonio_station::Strategy;
mod common;
use common::Geometric;

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
