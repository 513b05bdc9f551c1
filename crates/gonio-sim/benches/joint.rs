//! Speed of the joint calibration (issue: 72 faces × 15 shifts plus 12 heads × 36,000 positions
//! in ≤ 1 s end to end).

use criterion::{Criterion, criterion_group, criterion_main};
use gonio_calib::joint::{JointOptions, calibrate};
use gonio_calib::shift_angle::ReadingSet;
use gonio_sim::EncoderModel;
use gonio_sim::joint::{JointSimConfig, simulate};
use std::hint::black_box;

fn benches(c: &mut Criterion) {
    let enc = EncoderModel::default_with_seed(1);
    let mut g = c.benchmark_group("joint");
    g.sample_size(10);
    // SelfA's 12 heads at 36,000 positions with full polygon matrices at 15 shifts:
    // 72 faces at S = 0°…14° (360 distinct angles, the 1° grid; the case), 24 faces at the
    // same shifts, and 72 faces at S = 0°, 0.33°, …, 4.62° (1080 distinct angles).
    let one_degree: Vec<f64> = (0..15).map(f64::from).collect();
    let third: Vec<f64> = (0..15).map(|s| s as f64 * 0.33).collect();
    for (faces, shifts, name) in [
        (
            72,
            &one_degree,
            "72faces_15shifts_77760readings+selfa12_36000positions",
        ),
        (
            24,
            &one_degree,
            "24faces_15shifts_8640readings+selfa12_36000positions",
        ),
        (
            72,
            &third,
            "72faces_15shifts_1080angles+selfa12_36000positions",
        ),
    ] {
        let cfg = JointSimConfig::new(faces, shifts.clone(), 1);
        let sim = simulate(&enc, &cfg).unwrap();
        let set = ReadingSet::new(faces, sim.polygon.readings.clone()).unwrap();
        assert_eq!(set.len(), 15 * faces * faces);
        let heads = cfg.heads.heads.clone();
        g.bench_function(name, |b| {
            b.iter(|| {
                calibrate(
                    black_box(&set),
                    &heads,
                    &sim.heads.turns,
                    &JointOptions::default(),
                )
                .unwrap()
            })
        });
    }
    g.finish();
}

criterion_group!(joint, benches);
criterion_main!(joint);
