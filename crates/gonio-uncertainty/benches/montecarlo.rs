//! Monte Carlo speed: 10⁶ trials of a 10-input linear model on one core (target
//! ≤ 0.15 s), through a closure and through the budget's `LinearModel` (what `gonio budget
//! --monte-carlo` runs), plus the Student-t coverage factor and a nested budget evaluation.

#[path = "../../../bench/criterion_on_cpu.rs"]
mod on_cpu;

use criterion::Criterion;
use criterion::measurement::{Measurement, WallTime};
use gonio_uncertainty::student::coverage_factor;
use gonio_uncertainty::{
    InputDistribution, LinearModel, McConfig, McTrials, monte_carlo, parse_budget_file,
};
use std::hint::black_box;

fn ten_inputs() -> Vec<InputDistribution> {
    (0..10)
        .map(|i| {
            let a = 1.0 + 0.1 * i as f64;
            match i % 5 {
                0 => InputDistribution::Normal { mean: 0.0, sd: a },
                1 => InputDistribution::Rectangular {
                    mean: 0.0,
                    half_width: a,
                },
                2 => InputDistribution::Triangular {
                    mean: 0.0,
                    half_width: a,
                },
                3 => InputDistribution::Arcsine {
                    mean: 0.0,
                    half_width: a,
                },
                _ => InputDistribution::StudentT {
                    mean: 0.0,
                    scale: a,
                    nu: 5.0,
                },
            }
        })
        .collect()
}

fn bench<M: Measurement + 'static>(c: &mut Criterion<M>) {
    let inputs = ten_inputs();
    let coef: Vec<f64> = (0..10).map(|i| 1.0 - 0.05 * i as f64).collect();
    let mut g = c.benchmark_group("monte_carlo");
    g.sample_size(10);
    g.bench_function("linear_10_inputs_1e6_trials", |b| {
        let cfg = McConfig {
            trials: McTrials::Fixed(1_000_000),
            ..McConfig::default()
        };
        b.iter(|| {
            monte_carlo(
                black_box(&inputs),
                &[],
                |x: &[f64]| x.iter().zip(&coef).map(|(x, c)| x * c).sum(),
                &cfg,
            )
            .unwrap()
        })
    });
    g.bench_function("linear_model_10_inputs_1e6_trials", |b| {
        let model = LinearModel {
            names: (0..10).map(|i| format!("b/x{i}")).collect(),
            inputs: inputs.clone(),
            coefficients: coef.clone(),
            correlations: Vec::new(),
        };
        let cfg = McConfig {
            trials: McTrials::Fixed(1_000_000),
            ..McConfig::default()
        };
        b.iter(|| black_box(&model).monte_carlo(&cfg).unwrap())
    });
    g.bench_function("linear_10_normal_inputs_1e6_trials", |b| {
        let normals = vec![InputDistribution::Normal { mean: 0.0, sd: 1.0 }; 10];
        let cfg = McConfig {
            trials: McTrials::Fixed(1_000_000),
            ..McConfig::default()
        };
        b.iter(|| {
            monte_carlo(
                black_box(&normals),
                &[],
                |x: &[f64]| x.iter().zip(&coef).map(|(x, c)| x * c).sum(),
                &cfg,
            )
            .unwrap()
        })
    });
    g.finish();

    c.bench_function("coverage_factor_nu_1_to_1000_p95", |b| {
        b.iter(|| {
            let mut s = 0.0;
            for nu in 1..=1000 {
                s += coverage_factor(black_box(0.95), f64::from(nu));
            }
            s
        })
    });

    let text = std::fs::read_to_string(
        std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../../examples/budgets/hsieh2022-shift-angle.toml"),
    )
    .unwrap();
    c.bench_function("hsieh2022_table3_parse_and_evaluate", |b| {
        b.iter(|| {
            parse_budget_file(black_box(&text))
                .unwrap()
                .evaluate(None, None)
                .unwrap()
        })
    });
}

fn main() {
    // GONIO_BENCH_ON_CPU=1: the thread's on-CPU time (for a machine shared with other work).
    on_cpu::run(bench::<on_cpu::OnCpu>, bench::<WallTime>);
}
