//! The twin's camera path with a caller's camera (`run_batch_with`), here a cheap geometric one
//! built on the twin's exposures: the controller must do as well through it as through the fast
//! fidelity; and one that misses triggers: a turn still ends at its arc.

use gonio_sim::station::{BatchConfig, SimCamera, SimDeviceError, run_batch, run_batch_with};
use gonio_station::hal::{Camera, CameraFrame};
use gonio_station::{PartResult, Strategy};
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

/// A camera that misses one trigger in three: the twin's camera, with every third exposure
/// taken and thrown away (the twin's clock moves on by a frame interval for it).
struct MissesTriggers {
    inner: SimCamera,
    calls: u64,
}

impl Camera for MissesTriggers {
    type Error = SimDeviceError;
    fn capture(&mut self) -> Result<CameraFrame, SimDeviceError> {
        self.calls += 1;
        if self.calls.is_multiple_of(2) {
            self.inner.capture()?;
        }
        self.inner.capture()
    }
}

#[test]
fn a_turn_ends_at_its_arc_when_the_camera_misses_triggers() {
    let cfg = BatchConfig {
        parts: 25,
        ..BatchConfig::default()
    };
    let recipe = &cfg.recipe;
    let r = run_batch_with(
        &cfg,
        3,
        |t| {
            Ok(MissesTriggers {
                inner: SimCamera(t),
                calls: 0,
            })
        },
        &mut |_, _, _| {},
    )
    .unwrap();
    let mut turns = 0;
    for p in &r.parts {
        assert_eq!(p.record.result, PartResult::Accepted, "{:?}", p.record);
        for t in &p.record.turns {
            let arc = if t.carried_roundness.is_some() {
                recipe.measure.verify_turn_deg
            } else {
                recipe.measure.turn_deg
            };
            // Two frames of every three triggers: the turn's frames stop at the arc's time,
            // not after the number of frames planned for the arc.
            let n = recipe.frames_for_arc(arc) as f64;
            let expect = 2.0 * n / 3.0;
            assert!(
                (t.frames_taken as f64 - expect).abs() <= 1.5,
                "{} frames for {arc}° ({n} planned at the full rate)",
                t.frames_taken
            );
            turns += 1;
        }
        // Fewer frames, the same arc: the fit keeps its accuracy (u(e) ≈ 0.03 µm at the full
        // rate, × √1.5 here; 0.1 µm is > 3σ).
        let measured = p.record.final_e_um.unwrap();
        assert!(
            (measured - p.true_final_e_um).abs() < 0.1,
            "measured {measured} µm, true {} µm",
            p.true_final_e_um
        );
    }
    assert!(turns >= 50);
}
