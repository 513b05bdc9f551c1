//! Budget evaluation against hostile sizes (issue 13): a 1,000-row budget with 999 neighbour
//! correlations (> 120 s before, growing as n⁴), a diamond of 60 nested budgets each referring
//! twice to the next (> 12 GB before, in Monte Carlo), and the flattening of that diamond.

use criterion::{Criterion, criterion_group, criterion_main};
use gonio_uncertainty::parse_budget_file;
use std::hint::black_box;

fn chain(n: usize) -> String {
    let mut s = String::from("[[budget]]\nname = \"chain\"\n");
    for i in 0..n {
        s += &format!("[[budget.contribution]]\nname = \"r{i}\"\nu = 0.1\n");
    }
    for i in 0..n - 1 {
        s += &format!(
            "[[budget.correlation]]\nbetween = [\"r{i}\", \"r{}\"]\nr = 0.3\n",
            i + 1
        );
    }
    s
}

fn diamond(depth: usize) -> String {
    let mut s = String::from(
        "[[budget]]\nname = \"b0\"\n[[budget.contribution]]\nname = \"leaf\"\nu = 0.1\n",
    );
    for k in 1..=depth {
        s += &format!(
            "[[budget]]\nname = \"b{k}\"\n[[budget.contribution]]\nname = \"x\"\nfrom = \"b{}\"\n\
             [[budget.contribution]]\nname = \"y\"\nfrom = \"b{}\"\nsensitivity = 0.5\n",
            k - 1,
            k - 1
        );
    }
    s
}

fn bench(c: &mut Criterion) {
    let mut g = c.benchmark_group("budget");
    g.sample_size(20);
    let text = chain(1000);
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
