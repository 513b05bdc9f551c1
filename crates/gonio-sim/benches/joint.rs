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
    // 72 faces, full 72×72 matrices at S = 0°…14° (360 distinct angles, the 1° grid) and
    // SelfA's 12 heads at 36,000 positions.
    let cfg = JointSimConfig::new(72, (0..15).map(f64::from).collect(), 1);
    let sim = simulate(&enc, &cfg).unwrap();
    let set = ReadingSet::new(72, sim.polygon.readings.clone()).unwrap();
    assert_eq!(set.len(), 77_760);
    let heads = cfg.heads.heads.clone();
    g.bench_function(
        "72faces_15shifts_77760readings+selfa12_36000positions",
        |b| {
            b.iter(|| {
                calibrate(
                    black_box(&set),
                    &heads,
                    &sim.heads.turns,
                    &JointOptions::default(),
                )
                .unwrap()
            })
        },
    );
    // 24 faces at the same shifts (the seed's polygon).
    let cfg = JointSimConfig::new(24, (0..15).map(f64::from).collect(), 1);
    let sim = simulate(&enc, &cfg).unwrap();
    let set = ReadingSet::new(24, sim.polygon.readings.clone()).unwrap();
    g.bench_function(
        "24faces_15shifts_8640readings+selfa12_36000positions",
        |b| {
            b.iter(|| {
                calibrate(
                    black_box(&set),
                    &heads,
                    &sim.heads.turns,
                    &JointOptions::default(),
                )
                .unwrap()
            })
        },
    );
    // 72 faces at 15 shifts 1/3° apart (0.33°, on the 0.01° grid): 1080 distinct angles.
    let shifts: Vec<f64> = (0..15).map(|s| s as f64 * 0.33).collect();
    let cfg = JointSimConfig::new(72, shifts, 1);
    let sim = simulate(&enc, &cfg).unwrap();
    let set = ReadingSet::new(72, sim.polygon.readings.clone()).unwrap();
    g.bench_function("72faces_15shifts_1080angles+selfa12_36000positions", |b| {
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
    g.finish();
}

criterion_group!(joint, benches);
criterion_main!(joint);
