//! Speed of self-calibration (issue: 12 heads × 36,000 positions through the Fourier method in
//! under 30 ms on one core).

#[path = "../../../bench/criterion_on_cpu.rs"]
mod on_cpu;

use criterion::Criterion;
use criterion::measurement::{Measurement, WallTime};
use gonio_calib::selfcal::{Heads, Method, SelfcalOptions, calibrate};
use gonio_sim::EncoderModel;
use gonio_sim::selfcal::{SelfcalSimConfig, simulate};
use std::hint::black_box;

fn benches<M: Measurement + 'static>(c: &mut Criterion<M>) {
    let heads = Heads::selfa12();
    let cfg = SelfcalSimConfig::new(heads.clone(), 1);
    let sim = simulate(&EncoderModel::default_with_seed(1), &cfg).unwrap();
    assert_eq!(sim.turns[0].positions_deg.len(), 36_000);
    let mut g = c.benchmark_group("selfcal");
    g.sample_size(30);
    g.bench_function("selfa12_36000positions/fourier", |b| {
        b.iter(|| calibrate(&heads, black_box(&sim.turns), &SelfcalOptions::default()).unwrap())
    });
    let eda = SelfcalOptions {
        method: Method::Eda,
        ..SelfcalOptions::default()
    };
    g.bench_function("selfa12_36000positions/selfa", |b| {
        b.iter(|| calibrate(&heads, black_box(&sim.turns), &eda).unwrap())
    });
    g.finish();
}

fn main() {
    // GONIO_BENCH_ON_CPU=1: the thread's on-CPU time (for a machine shared with other work).
    on_cpu::run(benches::<on_cpu::OnCpu>, benches::<WallTime>);
}
