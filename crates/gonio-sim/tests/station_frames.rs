//! Full fidelity: 5 parts mounted end to end with every frame rendered and run through the real
//! detector (render → detect → fit → push).

use gonio_sim::station::{BatchConfig, Fidelity, run_batch};
use gonio_station::PartResult;

#[test]
fn five_parts_at_full_fidelity() {
    let cfg = BatchConfig {
        parts: 5,
        fidelity: Fidelity::Frames,
        ..BatchConfig::default()
    };
    let r = run_batch(&cfg, 1, &mut |i, n, p| {
        eprintln!(
            "part {i}/{n}: {} e {:.1} → {:.2} µm (true {:.2}), {} pushes, {:.1} s, {}",
            p.record.serial,
            p.record.initial_e_um,
            p.record.final_e_um,
            p.true_final_e_um,
            p.record.pushes,
            p.record.time_s,
            p.record.result.name()
        )
    })
    .unwrap();
    for p in &r.parts {
        assert_eq!(p.record.result, PartResult::Accepted, "{}", p.record.serial);
        // The detector's c is within ~0.1 px of the rendered truth, so the measured initial e
        // matches the true one to well under a micrometre.
        assert!(
            (p.record.initial_e_um - p.true_initial_e_um).abs() < 0.5,
            "{} vs {}",
            p.record.initial_e_um,
            p.true_initial_e_um
        );
        assert!((p.record.final_e_um - p.true_final_e_um).abs() < 0.5);
        assert!(p.true_final_e_um < 5.0);
        // Every turn had (nearly) all frames valid.
        for t in &p.record.turns {
            assert!(t.invalid_frames <= 10, "{}", t.invalid_frames);
        }
    }
}
