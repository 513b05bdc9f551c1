//! Speed of the eccentricity fits on one 200-frame turn (the seed's station budget for the
//! whole measurement, fit included, is 2.8 s).

use criterion::{Criterion, criterion_group, criterion_main};
use gonio_station::fit::{FitMethod, FitOptions, Sample, fit};
use std::hint::black_box;

fn turn() -> Vec<Sample> {
    // Deterministic pseudo-noise (no RNG dependency needed for a speed test).
    (0..200)
        .map(|i| {
            let t = 12.0 + 1.8 * i as f64;
            let noise = 0.3 * ((i as f64 * 12.9898).sin() * 43758.5453).fract();
            Sample {
                theta_deg: t,
                c_px: 720.0
                    + 133.0 * (t - 71.0f64).to_radians().cos()
                    + 0.5 * (2.0 * t - 10.0f64).to_radians().cos()
                    + noise,
            }
        })
        .collect()
}

fn bench(c: &mut Criterion) {
    let s = turn();
    for m in [FitMethod::LeastSquares, FitMethod::Paper] {
        let o = FitOptions::with_method(m);
        c.bench_function(&format!("fit {} 200 frames", m.name()), |b| {
            b.iter(|| fit(black_box(&s), &o).unwrap())
        });
    }
}

criterion_group!(benches, bench);
criterion_main!(benches);
