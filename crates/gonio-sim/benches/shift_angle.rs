//! Speed of the shift-angle estimators (issue: the seed case < 5 ms; 72 faces × 15 shifts of
//! full matrices with the full covariance of α and β < 200 ms, one core).

use criterion::{Criterion, criterion_group, criterion_main};
use gonio_calib::shift_angle::{CovarianceLevel, Method, Options, ReadingSet, calibrate};
use gonio_sim::EncoderModel;
use gonio_sim::shift_angle::{Rows, ShiftAngleConfig, simulate};
use std::hint::black_box;

fn set(faces: usize, shifts: usize, rows: Rows) -> ReadingSet {
    let sim = simulate(
        &EncoderModel::default_with_seed(1),
        &ShiftAngleConfig {
            faces,
            // Spread over one pitch: shifts a whole pitch apart calibrate the same angles, and
            // a reading set refuses them.
            shifts_deg: (0..shifts)
                .map(|s| s as f64 * 360.0 / (faces * shifts) as f64)
                .collect(),
            rows,
            seed: 1,
            ..ShiftAngleConfig::default()
        },
    )
    .unwrap();
    ReadingSet::new(faces, sim.readings).unwrap()
}

fn benches(c: &mut Criterion) {
    let seed_case = set(24, 15, Rows::Seed);
    assert_eq!(seed_case.len(), 576 + 14 * 24);
    c.bench_function("shift_angle/seed_24faces_912readings/least_squares", |b| {
        b.iter(|| calibrate(black_box(&seed_case), &Options::default()).unwrap())
    });
    c.bench_function("shift_angle/seed_24faces_912readings/paper", |b| {
        let o = Options {
            method: Method::Paper,
            sigma_arcsec: Some(0.05),
            ..Options::default()
        };
        b.iter(|| calibrate(black_box(&seed_case), &o).unwrap())
    });
    let big = set(72, 15, Rows::Full);
    assert_eq!(big.len(), 77_760);
    let mut g = c.benchmark_group("shift_angle/72faces_15shifts_77760readings");
    g.sample_size(20);
    g.bench_function("least_squares_full_covariance", |b| {
        let o = Options {
            covariance: CovarianceLevel::Full,
            ..Options::default()
        };
        b.iter(|| calibrate(black_box(&big), &o).unwrap())
    });
    g.bench_function("least_squares_diagonal", |b| {
        b.iter(|| calibrate(black_box(&big), &Options::default()).unwrap())
    });
    g.finish();
}

criterion_group!(shift_angle, benches);
criterion_main!(shift_angle);
