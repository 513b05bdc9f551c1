//! Acceptance of the mounting strategies on the default plant (issue 6, point 5): 200 parts,
//! three seeds, against the seed's results (paper strategy, on the published sequence) and the
//! issue's targets; the time model of the published and of the default sequence
//! (docs/station-timing.md).

use gonio_sim::station::{BatchConfig, BatchReport, run_batch};
use gonio_station::{PartResult, Recipe, Strategy};

const SEEDS: [u64; 3] = [1, 2, 3];

fn batch(strategy: Strategy, seed: u64) -> BatchReport {
    batch_with(strategy, seed, Recipe::default())
}

fn batch_with(strategy: Strategy, seed: u64, recipe: Recipe) -> BatchReport {
    let cfg = BatchConfig {
        parts: 200,
        strategy,
        recipe,
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
    // Yu et al., 2024, §5.2, 25 real parts: 2.1 pushes, 25.1 s, on their sequence.
    for s in SEEDS {
        let b = batch_with(Strategy::Paper, s, Recipe::published()).summary;
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
    // One push a part (11.1 s), plus a touch-up push (≈ 9.4 s with its verify turn) on the
    // parts whose random spring-back left them above the aim: 2–9 % of them on these seeds.
    for s in SEEDS {
        let b = batch(Strategy::Live, s).summary;
        assert!(b.mean_pushes <= 1.15, "{}", b.mean_pushes);
        assert!(b.mean_time_s.unwrap() <= 13.0, "{}", b.mean_time_s.unwrap());
    }
}

#[test]
fn a_part_in_12_s_at_the_same_accuracy() {
    // The station's figure of record, `gonio mount --sim --parts 200 --seed 5` with the default strategy
    // (docs/station-timing.md): a fixed seed, so these are the figures the docs give, checked.
    let r = batch(Strategy::Live, 5);
    let b = &r.summary;
    assert!(b.mean_time_s.unwrap() <= 12.0, "{}", b.mean_time_s.unwrap());
    let true_final = b.mean_true_final_e_um.unwrap();
    assert!(true_final <= 1.0, "{true_final}");
    assert!(b.mean_pushes <= 1.1, "{}", b.mean_pushes);
    assert_eq!(b.rejected, 0);
    for p in &r.parts {
        assert!(p.true_final_e_um < 3.0, "{}", p.record.serial);
    }
    // The same parts on the published sequence: 15.6 s, 1.04 pushes, 0.94 µm.
    let old = batch_with(Strategy::Live, 5, Recipe::published()).summary;
    assert!(old.mean_time_s.unwrap() > 15.0, "{:?}", old);
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
    // The published sequence: focus 2.0 s + measurement 2.8 s + 10 s per push cycle with a fast
    // contact, + 4.8 s (refocus and turn) for each turn the quality gate had re-measured. On
    // good parts that is rare: the half-turn check's false-alarm probability is 10⁻⁴ per turn
    // (≈ 0.05 expected here).
    let r = batch_with(Strategy::LeastSquares, 5, Recipe::published());
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
fn the_default_sequence_follows_the_same_time_model() {
    // The same device times in the default sequence (docs/station-timing.md), at 432°/s and
    // 240 fps, the servo at 900°/s²: the 360° turn's 258 frames from rest (1.075 s); each verify
    // turn's 224 frames over 300° (0.933 s); the last turn's stop, its 0.48 s ramp and 0.3 s
    // settling; each push cycle's align braking from the turn (0.48 s + 1.0 s), fast approach
    // 2.5 s, push 2.0 s (open loop), retract 1.7 s. The focus: a sweep of 19 moves and frames
    // and a final move (1.890 s) for the first part, a check of 3 to 7 positions (0.284 s to
    // 0.665 s) for the others.
    let r = batch(Strategy::LeastSquares, 5);
    let close = |a: f64, b: f64| (a - b).abs() < 1e-6;
    for p in &r.parts {
        let (rec, n) = (&p.record, f64::from(p.record.pushes));
        assert_eq!(rec.result, PartResult::Accepted);
        if rec.remeasured_turns > 0 {
            continue;
        }
        let t = &rec.phase_times;
        let measure = 258.0 / 240.0 + n * 224.0 / 240.0 + 0.78;
        assert!(close(t.measure_s, measure), "{}: {t:?}", rec.serial);
        assert!(close(t.push_s, n * 7.68), "{}: {t:?}", rec.serial);
        assert!(close(t.align_s.unwrap(), n * 1.48), "{}: {t:?}", rec.serial);
        assert!(
            close(t.retract_s.unwrap(), n * 1.7),
            "{}: {t:?}",
            rec.serial
        );
        let sweep = 20.0 * 0.0905 + 19.0 / 240.0;
        match (rec.focus_checks, rec.focus_sweeps) {
            (0, 1) => assert!(close(t.focus_s, sweep), "{t:?}"),
            (1, 0) => assert!((0.284..0.666).contains(&t.focus_s), "{t:?}"),
            // A check that found no peak, then the sweep.
            (1, 1) => assert!((sweep + 0.284..sweep + 0.666).contains(&t.focus_s), "{t:?}"),
            other => panic!("{}: focus {other:?}", rec.serial),
        }
        let sum = t.focus_s + t.measure_s + t.push_s;
        assert!(close(rec.time_s.unwrap(), sum), "{}", rec.serial);
    }
    assert_eq!(r.parts[0].record.focus_sweeps, 1);
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
