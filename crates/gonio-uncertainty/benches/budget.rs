//! Budget evaluation against hostile sizes: a 1,000-row budget with 999 neighbour
//! correlations (> 120 s before, growing as n⁴), a diamond of 60 nested budgets each referring
//! twice to the next (> 12 GB before, in Monte Carlo), and the flattening of that diamond.

#[path = "../tests/support/hostile_inputs.rs"]
mod hostile_inputs;

use criterion::{Criterion, criterion_group, criterion_main};
use gonio_uncertainty::parse_budget_file;
use hostile_inputs::{chain, diamond};
use std::hint::black_box;

fn bench(c: &mut Criterion) {
    let mut g = c.benchmark_group("budget");
    g.sample_size(20);
    let text = chain(1000, 0.3);
    g.bench_function("chain_1000_rows_999_correlations_parse_and_evaluate", |b| {
        b.iter(|| {
            parse_budget_file(black_box(&text))
                .unwrap()
                .evaluate(None, None)
                .unwrap()
        })
    });
    let set = parse_budget_file(&text).unwrap();
    g.bench_function("chain_1000_rows_999_correlations_evaluate", |b| {
        b.iter(|| black_box(&set).evaluate(None, None).unwrap())
    });
    let text = diamond(60);
    g.bench_function("diamond_60_parse_evaluate_all_and_flatten", |b| {
        b.iter(|| {
            let set = parse_budget_file(black_box(&text)).unwrap();
            (
                set.evaluate_all(None).unwrap(),
                set.linear_model(None).unwrap(),
            )
        })
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
