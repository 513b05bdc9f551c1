//! Acceptance of the mounting strategies on the default plant (issue 6, point 5): 200 parts,
//! several seeds, against the seed's results and the targets.

use gonio_sim::station::{BatchConfig, BatchSummary, run_batch};
use gonio_station::Strategy;

const SEEDS: [u64; 3] = [1, 2, 3];

fn batch(strategy: Strategy, seed: u64) -> BatchSummary {
    let cfg = BatchConfig {
        parts: 200,
        strategy,
        ..BatchConfig::default()
    };
    let r = run_batch(&cfg, seed, &mut |_, _, _| {}).unwrap();
    eprintln!("truth {:?} learned {:?}", r.station_truth, r.learned);
    r.summary
}

fn report(strategy: Strategy) -> Vec<BatchSummary> {
    SEEDS
        .iter()
        .map(|&s| {
            let b = batch(strategy, s);
            eprintln!(
                "{:>13} seed {s}: pushes {:.2} (max {}), time {:.1} s, final e {:.2} µm (true {:.2}), rejected {}",
                strategy.name(),
                b.mean_pushes,
                b.max_pushes,
                b.mean_time_s,
                b.mean_final_e_um,
                b.mean_true_final_e_um,
                b.rejected
            );
            b
        })
        .collect()
}

#[test]
fn explore() {
    let only = std::env::var("ONLY").unwrap_or_default();
    for s in Strategy::ALL {
        if only.is_empty() || only == s.name() {
            report(s);
        }
    }
}
