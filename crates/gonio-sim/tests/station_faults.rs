//! The controller's paths with faults injected through the simulated devices' traits: ring
//! lost, focus failure, max pushes → reject, timeout, device error.

use gonio_sim::station::{BatchConfig, DeviceId, Faults, run_batch};
use gonio_station::{PartResult, Recipe, StationError, Strategy};

fn cfg(faults: Faults) -> BatchConfig {
    BatchConfig {
        parts: 3,
        faults,
        ..BatchConfig::default()
    }
}

#[test]
fn ring_lost_before_the_first_turn_rejects() {
    let r = run_batch(
        &cfg(Faults {
            ring_lost_after_pushes: Some(0),
            ..Faults::default()
        }),
        1,
        &mut |_, _, _| {},
    )
    .unwrap();
    for p in &r.parts {
        assert_eq!(p.record.result, PartResult::RejectedRingLost);
        assert_eq!(p.record.pushes, 0);
        assert!(p.record.initial_e_um.is_nan());
    }
}

#[test]
fn ring_lost_after_a_push_rejects() {
    let r = run_batch(
        &cfg(Faults {
            ring_lost_after_pushes: Some(1),
            ..Faults::default()
        }),
        1,
        &mut |_, _, _| {},
    )
    .unwrap();
    for p in &r.parts {
        // Parts already within the threshold are accepted without a push; the others lose the
        // ring on the verification turn.
        if p.record.initial_e_um >= 5.0 {
            assert_eq!(p.record.result, PartResult::RejectedRingLost);
            assert_eq!(p.record.pushes, 1);
            assert_eq!(p.record.turns.len(), 2);
        }
    }
}

#[test]
fn flat_focus_measure_is_a_focus_failure() {
    let r = run_batch(
        &cfg(Faults {
            focus_dead: true,
            ..Faults::default()
        }),
        1,
        &mut |_, _, _| {},
    )
    .unwrap();
    for p in &r.parts {
        assert_eq!(p.record.result, PartResult::RejectedFocusFailure);
        assert!(p.record.turns.is_empty());
    }
}

#[test]
fn autofocus_finds_the_best_focus() {
    let r = run_batch(&cfg(Faults::default()), 2, &mut |_, _, _| {}).unwrap();
    for i in 0..3 {
        let truth = gonio_sim::station::PartTruth::draw(
            &gonio_sim::station::PlantConfig::default(),
            2,
            i + 1,
        );
        let got = r.parts[i as usize].record.focus_um;
        // Sweep step 16.7 µm, depth of focus 25 µm, 1 % noise on the measure.
        assert!(
            (got - truth.best_focus_um).abs() < 3.0,
            "{got} vs {}",
            truth.best_focus_um
        );
    }
}

#[test]
fn max_pushes_rejects() {
    let recipe = Recipe::from_toml("threshold_um = 0.05\n[push]\nmax_pushes = 2\n").unwrap();
    let c = BatchConfig {
        recipe,
        ..cfg(Faults::default())
    };
    let r = run_batch(&c, 3, &mut |_, _, _| {}).unwrap();
    for p in &r.parts {
        assert_eq!(p.record.result, PartResult::RejectedMaxPushes);
        assert_eq!(p.record.pushes, 2);
        assert_eq!(p.record.push_log.len(), 2);
    }
    assert_eq!(r.summary.rejected, 3);
}

#[test]
fn timeout_rejects() {
    let recipe = Recipe::from_toml("threshold_um = 0.05\ntimeout_s = 12.0\n").unwrap();
    let c = BatchConfig {
        recipe,
        strategy: Strategy::LeastSquares,
        ..cfg(Faults::default())
    };
    let r = run_batch(&c, 3, &mut |_, _, _| {}).unwrap();
    for p in &r.parts {
        assert_eq!(p.record.result, PartResult::RejectedTimeout);
        // Focus + measurement + one push cycle (14.8 s) passes the 12 s timeout.
        assert_eq!(p.record.pushes, 1);
    }
}

#[test]
fn device_error_aborts_with_the_device_named() {
    for (id, name) in [
        (DeviceId::Rod, "push rod"),
        (DeviceId::Camera, "camera"),
        (DeviceId::Servo, "servo"),
        (DeviceId::Focus, "focus drive"),
        (DeviceId::Clock, "clock"),
    ] {
        let e = run_batch(
            &cfg(Faults {
                device_error: Some((id, 1)),
                ..Faults::default()
            }),
            1,
            &mut |_, _, _| {},
        )
        .unwrap_err();
        match e {
            StationError::Device { device, .. } => assert_eq!(device, name),
            other => panic!("{other:?}"),
        }
    }
}
