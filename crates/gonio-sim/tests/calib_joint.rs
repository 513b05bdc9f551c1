//! The joint calibration (polygon + SelfA heads in one least squares) against the simulator's
//! ground truth.

use gonio_calib::joint::{
    HeadAngles, Interpolation, Invisible, JointCalibration, JointOptions, SeenBy, calibrate,
};
use gonio_calib::selfcal::{self, Heads, SelfcalOptions};
use gonio_calib::shift_angle::{self, Options, ReadingSet};
use gonio_sim::encoder::HarmonicArcsec;
use gonio_sim::joint::{JointSim, JointSimConfig, simulate, true_coefficients, truth_without};
use gonio_sim::{EncoderModel, Graduation};

/// The planted orders: 24 and 48 (invisible to a 24-face polygon), 84 (invisible to SelfA) and
/// 168 (invisible to both), 0.05″ each, on top of the seed's 2nd harmonic and the default
/// random graduation error (0.01″ per line, 36,000 lines).
fn planted(seed: u64) -> EncoderModel {
    let h = |order, amplitude_arcsec, phase_rad| HarmonicArcsec {
        order,
        amplitude_arcsec,
        phase_rad,
    };
    EncoderModel::new(
        vec![
            h(2, 1.0314, -2.4233),
            h(24, 0.05, 0.7),
            h(48, 0.05, -1.1),
            h(84, 0.05, 2.0),
            h(168, 0.05, -0.3),
        ],
        Graduation {
            lines: 36_000,
            sigma_arcsec: 0.01,
            seed: seed + 500,
        },
    )
    .unwrap()
}

/// 24 faces, full matrices at S = 0°…14° (σ 0.05″); SelfA at 36,000 positions (σ 0.01″).
fn lab(seed: u64) -> (JointSim, ReadingSet, Heads) {
    let cfg = JointSimConfig::new(24, (0..15).map(f64::from).collect(), seed);
    let sim = simulate(&planted(seed), &cfg).unwrap();
    let set = ReadingSet::new(24, sim.polygon.readings.clone()).unwrap();
    (sim, set, cfg.heads.heads)
}

fn joint(sim: &JointSim, set: &ReadingSet, heads: &Heads) -> JointCalibration {
    calibrate(set, heads, &sim.heads.turns, &JointOptions::default()).unwrap()
}

/// Every order up to NS/2 the joint estimate does not contain: those the heads cannot see
/// (every `e^{ikφ}` equal to 1, or the Nyquist order) and the polygon does not resolve.
fn invisible_orders(cal: &JointCalibration, heads: &Heads, ns: usize) -> Vec<u32> {
    (1..=(ns / 2) as u32)
        .filter(|&k| {
            (selfcal::noise_gain(heads, k).is_none() || k as usize * 2 == ns)
                && !cal.blind.from_polygon.contains(&k)
        })
        .collect()
}

/// The polygon-alone estimate's harmonic of order k, fitted to its merged α (closed per shift).
fn polygon_alone_amplitude(cal: &shift_angle::Calibration, order: u32) -> f64 {
    let merged = cal.merged();
    let theta: Vec<f64> = merged.iter().map(|m| m.angle_deg.to_radians()).collect();
    let y: Vec<f64> = merged.iter().map(|m| m.value_arcsec).collect();
    gonio_core::HarmonicFitSpec::new(&[order])
        .fit(&theta, &y, None)
        .unwrap()
        .harmonic(order)
        .unwrap()
        .amplitude
}

#[test]
fn joint_sees_what_either_method_sees_and_reports_what_neither_does() {
    let (sim, set, heads) = lab(1);
    let cal = joint(&sim, &set, &heads);
    // Within 3 u of the encoder's true coefficients (its exact DFT on the heads' grid, which
    // includes the graduation error's share of each order), cos and sin separately.
    for (k, seen) in [
        (24u32, SeenBy::Heads),
        (48, SeenBy::Heads),
        (84, SeenBy::Polygon),
    ] {
        let h = &cal.harmonics[k as usize - 1];
        let (c, s) = true_coefficients(&sim.heads.truth, k);
        assert!(h.estimated && h.seen_by == seen, "{h:?}");
        let (zc, zs) = (
            (h.cos_arcsec - c) / h.u_cos_arcsec,
            (h.sin_arcsec - s) / h.u_sin_arcsec,
        );
        eprintln!(
            "order {k}: amplitude {:.5}″ (true {:.5}″), u {:.2e}″, z = {zc:+.2}, {zs:+.2}",
            h.amplitude_arcsec,
            c.hypot(s),
            h.u_cos_arcsec
        );
        assert!(
            zc.abs() <= 3.0 && zs.abs() <= 3.0,
            "order {k}: z = {zc}, {zs}"
        );
    }
    // 84 comes from the polygon alone, 24 and 48 from the heads alone.
    assert_eq!(cal.harmonics[83].heads_share, 0.0);
    assert!(cal.harmonics[23].heads_share > 0.99);
    // 168 is invisible to both: reported, not estimated.
    let h168 = &cal.harmonics[167];
    assert!(!h168.estimated && h168.seen_by == SeenBy::Neither);
    assert_eq!(h168.invisible, Some(Invisible::BothBlind));
    assert!(cal.blind.joint.contains(&168) && !cal.blind.joint.contains(&84));
    assert_eq!(cal.blind.from_polygon, vec![84]);
    // Neither method alone recovers 168 (nor the other's blind orders).
    let sa = shift_angle::calibrate(&set, &Options::default()).unwrap();
    for k in [24u32, 48, 168] {
        assert!(sa.undetectable_harmonics.contains(&k));
        // Each shift's closure removes the order: what is left is noise, far below 0.05″.
        let a = polygon_alone_amplitude(&sa, k);
        assert!(a < 0.005, "polygon alone, order {k}: {a}");
    }
    let sc = selfcal::calibrate(&heads, &sim.heads.turns, &SelfcalOptions::default()).unwrap();
    for k in [84u32, 168] {
        assert!(sc.undetectable_orders.contains(&k));
        assert_eq!(sc.harmonics[k as usize - 1].amplitude_arcsec, 0.0);
    }
}

/// Twenty labs: |α_joint − α_true| ≤ U at ≥ 95 % of the common angles, and the joint u is never
/// larger than either method's own u (`gonio shift-angle`'s least squares, `gonio selfcal`'s
/// Fourier least squares) at any angle.
///
/// The truth is the encoder's error at each angle less the orders the joint estimate reports as
/// invisible (its content at those orders: 168, and heads-blind orders above the polygon's
/// Nyquist order); U = k·u with k = t₉₅(ν_eff). With a correct u the expected fraction is 95 %;
/// the heads' model (linear between positions, measured head angles) describes the simulator's
/// scale exactly, so nothing but the readings' noise is left.
#[test]
fn joint_u_covers_the_truth_over_20_labs() {
    let (mut inside, mut total) = (0usize, 0usize);
    let mut worst_z: f64 = 0.0;
    let mut worst_ratio: f64 = 0.0;
    let mut worst_ratio_gls: f64 = 0.0;
    for seed in 0..20u64 {
        let (sim, set, heads) = lab(seed);
        let cal = joint(&sim, &set, &heads);
        let angles: Vec<f64> = cal.alpha.iter().map(|a| a.angle_deg).collect();
        let truth = truth_without(
            &sim.heads.truth,
            &invisible_orders(&cal, &heads, 36_000),
            &angles,
        );
        for (a, t) in cal.alpha.iter().zip(&truth) {
            total += 1;
            if (a.value_arcsec - t).abs() <= a.expanded_arcsec {
                inside += 1;
            }
        }
        let sa = shift_angle::calibrate(&set, &Options::default()).unwrap();
        let sc = selfcal::calibrate(&heads, &sim.heads.turns, &SelfcalOptions::default()).unwrap();
        for m in sa.merged() {
            let q = angles
                .iter()
                .position(|&x| (x - m.angle_deg).abs() < 1e-9)
                .unwrap();
            let p = sc
                .errors
                .iter()
                .find(|e| (e.position_deg - m.angle_deg).abs() < 1e-9)
                .unwrap();
            let better = m.u_arcsec.min(p.u_arcsec);
            worst_ratio = worst_ratio.max(cal.alpha[q].u_arcsec / better);
            worst_ratio_gls = worst_ratio_gls
                .max(cal.alpha[q].u_arcsec / m.u_arcsec.min(cal.alpha[q].u_heads_alone_arcsec));
        }
        for k in [24u32, 48, 84] {
            let h = &cal.harmonics[k as usize - 1];
            let (c, s) = true_coefficients(&sim.heads.truth, k);
            worst_z = worst_z
                .max(((h.cos_arcsec - c) / h.u_cos_arcsec).abs())
                .max(((h.sin_arcsec - s) / h.u_sin_arcsec).abs());
        }
    }
    let fraction = inside as f64 / total as f64;
    eprintln!(
        "coverage {inside}/{total} = {fraction:.4}; largest u_joint/min(u_alone) {worst_ratio:.3} (vs the heads' GLS alone {worst_ratio_gls:.3}); largest |z| of orders 24, 48, 84: {worst_z:.2}"
    );
    assert!(fraction >= 0.95, "{fraction}");
    assert!(worst_ratio <= 1.0, "{worst_ratio}");
}

/// Heads mounted a few arcseconds off their nominal angles read a high order with a phase error
/// k·δ; the joint's heads model takes each head's mean difference as its displacement. Encoder:
/// harmonics only (no graduation error), one of them at order 3000 (0.05″), so the heads read a
/// band-limited error and the trigonometric model between positions is the exact one (the linear
/// one would attenuate order 3000 by up to 3 %); heads displaced by N(0, 5″) as in the default
/// simulator.
#[test]
fn measured_head_angles_remove_the_phase_error_of_displaced_heads() {
    let h = |order, amplitude_arcsec, phase_rad| HarmonicArcsec {
        order,
        amplitude_arcsec,
        phase_rad,
    };
    let enc =
        EncoderModel::harmonics_only(vec![h(2, 1.0314, -2.4233), h(3000, 0.05, 0.4)]).unwrap();
    let cfg = JointSimConfig::new(24, (0..15).map(f64::from).collect(), 3);
    let sim = simulate(&enc, &cfg).unwrap();
    let set = ReadingSet::new(24, sim.polygon.readings.clone()).unwrap();
    let heads = cfg.heads.heads.clone();
    let (c, s) = true_coefficients(&sim.heads.truth, 3000);
    let z = |angles| {
        let opts = JointOptions {
            head_angles: angles,
            interpolation: Interpolation::Trigonometric,
            max_order: 3000,
            ..JointOptions::default()
        };
        let cal = calibrate(&set, &heads, &sim.heads.turns, &opts).unwrap();
        let h = &cal.harmonics[2999];
        ((h.cos_arcsec - c) / h.u_cos_arcsec)
            .abs()
            .max(((h.sin_arcsec - s) / h.u_sin_arcsec).abs())
    };
    let (measured, nominal) = (z(HeadAngles::Measured), z(HeadAngles::Nominal));
    eprintln!(
        "order 3000: |z| = {measured:.2} with measured head angles, {nominal:.1} with nominal ones"
    );
    assert!(measured <= 3.0, "{measured}");
    // A 5″ displacement at order 3000 is a phase error of ~0.07 rad: 0.004″ on 0.05″, ~100 u.
    assert!(nominal > 10.0, "{nominal}");
}

/// The χ² agreement check: consistent for two instruments reading one encoder, not when the
/// polygon reads a different one (an extra 0.02″ order-5 term, which the heads would see).
#[test]
fn consistency_check_flags_instruments_that_disagree() {
    let (sim, set, heads) = lab(4);
    let c = joint(&sim, &set, &heads).consistency.unwrap();
    assert_eq!(c.dof, 15 * 23 - 2);
    assert!(c.consistent, "{c:?}");
    let other = EncoderModel::new(
        [
            planted(4).harmonics(),
            &[HarmonicArcsec {
                order: 5,
                amplitude_arcsec: 0.02,
                phase_rad: 0.3,
            }],
        ]
        .concat(),
        planted(4).graduation(),
    )
    .unwrap();
    let cfg = JointSimConfig::new(24, (0..15).map(f64::from).collect(), 4);
    let polygon = gonio_sim::shift_angle::simulate(&other, &cfg.polygon).unwrap();
    let bad = ReadingSet::new(24, polygon.readings).unwrap();
    let c = joint(&sim, &bad, &heads).consistency.unwrap();
    eprintln!(
        "disagreeing instruments: χ² = {:.0} for {} dof, p = {:.2e}",
        c.chi2, c.dof, c.p_upper
    );
    assert!(!c.consistent && c.p_upper < 1e-6, "{c:?}");
}
