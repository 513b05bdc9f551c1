//! Acceptance of the mounting strategies on the default plant (issue 6, point 5): 200 parts,
//! three seeds, against the seed's results (paper strategy) and the targets.

use gonio_sim::station::{BatchConfig, BatchReport, run_batch};
use gonio_station::{PartResult, Strategy};

const SEEDS: [u64; 3] = [1, 2, 3];

fn batch(strategy: Strategy, seed: u64) -> BatchReport {
    let cfg = BatchConfig {
        parts: 200,
        strategy,
        ..BatchConfig::default()
    };
    let r = run_batch(&cfg, seed, &mut |_, _, _| {}).unwrap();
    let b = &r.summary;
    eprintln!(
        "{:>13} seed {seed}: pushes {:.2} (max {}), time {:.1} s, final e {:.2} µm (true {:.2}), rejected {}",
        strategy.name(),
        b.mean_pushes,
        b.max_pushes,
        b.mean_time_s.unwrap(),
        b.mean_final_e_um.unwrap(),
        b.mean_true_final_e_um.expect("the twin's truth"),
        b.rejected
    );
    r
}

#[test]
fn paper_strategy_reproduces_the_seed_within_20_percent() {
    // Yu et al., 2024, §5.2, 25 real parts: 2.1 pushes, 25.1 s.
    for s in SEEDS {
        let b = batch(Strategy::Paper, s).summary;
        assert!(
            (b.mean_pushes / 2.1 - 1.0).abs() <= 0.2,
            "{}",
            b.mean_pushes
        );
        assert!(
            (b.mean_time_s.unwrap() / 25.1 - 1.0).abs() <= 0.2,
            "{}",
            b.mean_time_s.unwrap()
        );
    }
}

#[test]
fn default_strategy_meets_its_targets() {
    assert_eq!(Strategy::default(), Strategy::Learned);
    for s in SEEDS {
        let b = batch(Strategy::default(), s).summary;
        assert!(
            b.mean_final_e_um.unwrap() <= 2.0,
            "{}",
            b.mean_final_e_um.unwrap()
        );
        assert!(
            b.mean_true_final_e_um.expect("the twin's truth") <= 2.0,
            "{}",
            b.mean_true_final_e_um.expect("the twin's truth")
        );
        assert!(b.mean_pushes <= 1.7, "{}", b.mean_pushes);
        assert!(b.mean_time_s.unwrap() <= 22.0, "{}", b.mean_time_s.unwrap());
        assert_eq!(b.rejected, 0);
    }
}

#[test]
fn live_strategy_needs_about_one_push() {
    // One push a part (15.0 s), plus a touch-up push (≈ 10 s with its verify turn) on the
    // parts whose random spring-back left them above the aim: 6–9 % of them on these seeds.
    for s in SEEDS {
        let b = batch(Strategy::Live, s).summary;
        assert!(b.mean_pushes <= 1.15, "{}", b.mean_pushes);
        assert!(b.mean_time_s.unwrap() <= 17.0, "{}", b.mean_time_s.unwrap());
    }
}

#[test]
fn least_squares_fit_needs_fewer_pushes_than_the_paper_fit() {
    // Same parts, same plant: only the fit (and the angle stamping) differ.
    let (mut p, mut l) = (0.0, 0.0);
    for s in SEEDS {
        p += batch(Strategy::Paper, s).summary.mean_pushes;
        l += batch(Strategy::LeastSquares, s).summary.mean_pushes;
    }
    assert!(
        l < p - 0.2,
        "least squares {l} vs paper {p} (sums over seeds)"
    );
}

#[test]
fn station_measurement_agrees_with_the_ground_truth() {
    // Least squares at 0.3 px noise over 200 frames: u(e) ≈ 0.022 µm; with roundness fitted and
    // mid-exposure stamps the station's final e must match the simulated truth to a few u(e).
    let r = batch(Strategy::Learned, 4);
    let mut ss = 0.0;
    for p in &r.parts {
        let d = p.record.final_e_um.unwrap() - p.true_final_e_um;
        assert!(d.abs() < 0.15, "{}: {d}", p.record.serial);
        ss += d * d;
    }
    let rms = (ss / r.parts.len() as f64).sqrt();
    assert!(rms < 0.05, "{rms}");
    // The learned push-direction offset converges to the station's true one (per-push scatter
    // 0.2°, ~300 observations: standard error ≈ 0.012°).
    assert!(
        (r.learned.offset_deg - r.station_truth.offset_deg).abs() < 0.1,
        "{:?} vs {:?}",
        r.learned,
        r.station_truth
    );
}

#[test]
fn time_model_matches_the_spec() {
    // focus 2.0 s + measurement 2.8 s + 10 s per push cycle with a fast contact, + 4.8 s (refocus
    // and turn) for each turn the quality gate had re-measured. On good parts that is rare: the
    // half-turn check's false-alarm probability is 10⁻⁴ per turn (≈ 0.05 expected here).
    let r = batch(Strategy::LeastSquares, 5);
    assert!(r.summary.remeasured_turns <= 2, "{:?}", r.summary);
    for p in &r.parts {
        assert_eq!(p.record.result, PartResult::Accepted);
        let want = 4.8 + 10.0 * p.record.pushes as f64 + 4.8 * p.record.remeasured_turns as f64;
        assert!(
            (p.record.time_s.unwrap() - want).abs() < 0.02,
            "{} vs {want}",
            p.record.time_s.unwrap()
        );
    }
}

#[test]
fn same_seed_same_bytes() {
    let cfg = BatchConfig {
        parts: 10,
        strategy: Strategy::Live,
        ..BatchConfig::default()
    };
    let a = serde_json::to_string(&run_batch(&cfg, 11, &mut |_, _, _| {}).unwrap()).unwrap();
    let b = serde_json::to_string(&run_batch(&cfg, 11, &mut |_, _, _| {}).unwrap()).unwrap();
    assert_eq!(a, b);
    let c = serde_json::to_string(&run_batch(&cfg, 12, &mut |_, _, _| {}).unwrap()).unwrap();
    assert_ne!(a, c);
}

#[test]
fn a_batch_that_discards_its_parts_has_the_same_summary() {
    use gonio_sim::station::{PartDone, RunOptions, run_batch_observed};
    use std::ops::ControlFlow;
    let cfg = BatchConfig {
        parts: 40,
        strategy: Strategy::Live,
        ..BatchConfig::default()
    };
    let kept = run_batch(&cfg, 7, &mut |_, _, _| {}).unwrap();
    let mut seen = Vec::new();
    let opts = RunOptions {
        discard_parts: true,
        ..RunOptions::default()
    };
    let lean = run_batch_observed(&cfg, 7, opts, &mut |d: &PartDone| {
        seen.push(d.part.record.serial.clone());
        ControlFlow::Continue(())
    })
    .unwrap();
    assert!(lean.parts.is_empty());
    assert_eq!(seen.len(), 40);
    // The same sums in the same order: the same bits, not merely close.
    assert_eq!(
        serde_json::to_string(&lean.summary).unwrap(),
        serde_json::to_string(&kept.summary).unwrap()
    );
}

#[test]
fn the_live_strategy_pushes_again_above_its_aim() {
    // Spring-back is random (up to 3 % of the move): one push from 150 µm can end near 3 µm.
    // The live strategy pushes again while e ≥ 55 % of the threshold (2.75 µm), so no accepted
    // part is measured above that, nor truly above it plus the quality gate's largest u(e)
    // (0.25 µm): 3 µm.
    let r = gonio_station::Recipe::default();
    let aim = r.threshold_um * r.push.live_aim_fraction;
    let max_u = r.quality.max_u_e_fraction * r.threshold_um;
    for s in SEEDS {
        let b = batch(Strategy::Live, s);
        for p in &b.parts {
            if p.record.result == PartResult::Accepted && p.record.pushes < r.push.max_pushes {
                let (e, t) = (p.record.final_e_um.unwrap(), p.true_final_e_um);
                assert!(e < aim, "{}: {e} µm", p.record.serial);
                assert!(t < aim + max_u, "{}: {t} µm", p.record.serial);
            }
        }
    }
}
