//! Accuracy on rendered frames against the renderer's ground truth, and the invalid cases.

use gonio_sim::frames::{GratingRenderer, GratingScene};
use gonio_vision::{Detector, InvalidReason, Optics};

fn run(
    scene: GratingScene,
    cases: &[(f64, f64, f64, f64)],
    seed0: u64,
) -> Vec<(
    f64,
    gonio_vision::FrameResult,
    gonio_sim::frames::FrameTruth,
)> {
    let optics = Optics::default();
    let r = GratingRenderer::new(&optics, scene).unwrap();
    let mut det = Detector::new(&optics).unwrap();
    let mut frame = vec![0u8; r.frame_len()];
    cases
        .iter()
        .enumerate()
        .map(|(i, &(th, e, psi, z))| {
            let t = r
                .render(th, e, psi, z, seed0 + i as u64, &mut frame)
                .unwrap();
            let res = det.detect(&frame).unwrap();
            let err = res.c_px.map_or(f64::NAN, |c| c - t.c_true_px);
            (err, res, t)
        })
        .collect()
}

#[test]
fn c_within_a_tenth_of_a_pixel_over_theta_and_eccentricity() {
    let mut cases = Vec::new();
    for e in [0.0, 5.0, 60.0, 200.0, 420.0] {
        for k in 0..24 {
            cases.push((k as f64 * 15.0 + 3.7, e, 30.0, 0.0));
        }
    }
    let out = run(GratingScene::default(), &cases, 100);
    let mut worst: f64 = 0.0;
    let mut ss = 0.0;
    for ((err, res, t), c) in out.iter().zip(&cases) {
        assert!(
            res.valid,
            "case {c:?}: invalid ({:?}), truth {t:?}",
            res.reason
        );
        worst = worst.max(err.abs());
        ss += err * err;
    }
    let f: Vec<f64> = out.iter().map(|o| o.1.focus).collect();
    eprintln!(
        "focus {:.1} … {:.1}",
        f.iter().cloned().fold(f64::MAX, f64::min),
        f.iter().cloned().fold(0.0, f64::max)
    );
    let rms = (ss / out.len() as f64).sqrt();
    eprintln!("frames {} worst {worst:.4} px rms {rms:.4} px", out.len());
    assert!(worst <= 0.1, "worst |c − c_true| = {worst:.4} px");
}

#[test]
fn mild_blur_keeps_accuracy() {
    // ±40 µm of defocus: σ grows from 0.55 to ≈ 2 µm (2.7 px).
    let cases: Vec<_> = (0..12)
        .map(|k| (k as f64 * 30.0, 150.0, 80.0, -40.0 + k as f64 * 8.0))
        .collect();
    let out = run(GratingScene::default(), &cases, 500);
    for ((err, res, t), c) in out.iter().zip(&cases) {
        assert!(
            res.valid,
            "case {c:?}: {:?} blur {:.2} px",
            res.reason, t.blur_sigma_px
        );
        assert!(
            err.abs() <= 0.1,
            "case {c:?}: error {err:.4} px, blur {:.2} px",
            t.blur_sigma_px
        );
    }
}

#[test]
fn frames_without_a_usable_ring_say_why() {
    let no_ring = GratingScene {
        ring_present: false,
        ..GratingScene::default()
    };
    let out = run(
        no_ring,
        &[(10.0, 50.0, 0.0, 0.0), (200.0, 300.0, 0.0, 0.0)],
        900,
    );
    for (_, res, _) in &out {
        assert_eq!(res.reason, Some(InvalidReason::NoRing), "{res:?}");
    }
    // Eccentricity so large that the ring straddles the window's side (window ±540 µm).
    let out = run(
        GratingScene::default(),
        &[
            (0.0, 536.0, 0.0, 0.0),
            (180.0, 536.0, 0.0, 0.0),
            (180.0, 541.0, 0.0, 0.0),
        ],
        910,
    );
    for (_, res, t) in &out {
        assert!(!t.ring_in_window);
        assert_eq!(
            res.reason,
            Some(InvalidReason::RingOutsideWindow),
            "{res:?} {t:?}"
        );
    }
    let over = GratingScene {
        exposure: 1.6,
        ..GratingScene::default()
    };
    let out = run(over, &[(40.0, 80.0, 0.0, 0.0)], 920);
    assert_eq!(out[0].1.reason, Some(InvalidReason::Saturated));
    // Heavy defocus: 400 µm off → σ ≈ 20 µm.
    let out = run(
        GratingScene::default(),
        &[(40.0, 80.0, 0.0, 400.0), (90.0, 10.0, 0.0, -500.0)],
        930,
    );
    for (_, res, _) in &out {
        assert_eq!(res.reason, Some(InvalidReason::OutOfFocus), "{res:?}");
    }
    eprintln!(
        "heavy defocus focus: {:.1} {:.1}",
        out[0].1.focus, out[1].1.focus
    );
}
