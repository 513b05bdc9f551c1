//! The certificate: U attached once from the random part and the instrument terms, the same
//! fields for both methods, and a JSON form that reads back to the same certificate.

use gonio_calib::certificate::{Certificate, Instrument, Procedure};
use gonio_calib::selfcal::{self, Heads, SelfcalOptions, Turn};
use gonio_calib::shift_angle::{Options, Reading, ReadingSet, calibrate};
use gonio_uncertainty::instrument::InstrumentFile;
use gonio_uncertainty::student::coverage_factor;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};

/// A 24-face polygon, full matrices at S = 0° and 5°, α = 0.8·sin 2θ + 0.3·cos 24θ, readings with
/// white noise σ = 0.02″.
fn shift_angle_set(seed: u64) -> ReadingSet {
    let n = 24usize;
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let noise = Normal::new(0.0, 0.02).unwrap();
    let beta: Vec<f64> = (0..n).map(|k| 0.3 * (k as f64 * 0.7).sin()).collect();
    let mean_beta = beta.iter().sum::<f64>() / n as f64;
    let beta: Vec<f64> = beta.iter().map(|b| b - mean_beta).collect();
    let mut readings = Vec::new();
    for shift in [0.0, 5.0] {
        for j in 1..=n {
            for i in 1..=n {
                let theta = ((i - 1) as f64 * 15.0 + shift).to_radians();
                let alpha = 0.8 * (2.0 * theta).sin() + 0.3 * (24.0 * theta).cos();
                let c: f64 = (0..i).map(|t| beta[(j - 1 + t) % n]).sum();
                readings.push(Reading::new(
                    shift,
                    j,
                    i,
                    alpha + c + noise.sample(&mut rng),
                ));
            }
        }
    }
    ReadingSet::new(n, readings).unwrap()
}

fn instrument() -> Instrument {
    let terms = InstrumentFile::parse(
        "coverage = 0.95\n[autocollimator_linearity]\ndistribution = \"rectangular\"\nhalf_width = 0.05\n[encoder_resolution]\ndistribution = \"resolution\"\nstep = 0.04\nrelative_uncertainty = 0.1\n",
    )
    .unwrap();
    Instrument::new(terms, Some("inst.toml".into()))
}

#[test]
fn shift_angle_certificate_attaches_the_budget_to_every_angle() {
    let set = shift_angle_set(1);
    let cal = calibrate(&set, &Options::default()).unwrap();
    let inst = instrument();
    let cert = Certificate::from_shift_angle(&cal, &set, false, 2, &inst).unwrap();
    assert_eq!(cert.procedure, Procedure::ShiftAngle);
    assert_eq!(cert.points.len(), 48);
    let dof = cal.residuals.dof as f64;
    // The instrument terms' variance: (0.05/√3)² + (0.04/√12)².
    let ui2 = 0.05f64.powi(2) / 3.0 + 0.04f64.powi(2) / 12.0;
    for (p, m) in cert.points.iter().zip(cal.merged()) {
        assert_eq!(p.angle_deg, m.angle_deg);
        assert_eq!(p.u_random_arcsec, m.u_arcsec);
        assert!((p.u_arcsec.powi(2) - (m.u_arcsec.powi(2) + ui2)).abs() < 1e-15);
        let c = inst.terms.combine(m.u_arcsec, dof).unwrap();
        assert_eq!(p.k, Some(c.k));
        assert_eq!(p.nu_eff, Some(c.nu_eff));
        assert!((p.expanded_arcsec.unwrap() - c.k * p.u_arcsec).abs() < 1e-15);
        assert_eq!(p.p, Some(0.95));
        assert_eq!(p.shift_deg, Some(m.shift_deg));
    }
    // The budget table is the angle with the largest U, with the random part first.
    let b = cert.budget.as_ref().unwrap();
    assert_eq!(b.contributions[0].name, "random part (estimator)");
    assert!((b.expanded - cert.max_expanded_arcsec().unwrap()).abs() < 1e-15);
    let shares: f64 = b.contributions.iter().map(|r| r.share).sum();
    assert!((shares - 1.0).abs() < 1e-12);
    // The spectrum sees order 2 (0.8″) and marks the polygon's blind order 24.
    let l2 = cert.spectrum.lines.iter().find(|l| l.order == 2).unwrap();
    // u(α) ≈ 0.004″ per angle: the fitted amplitude is within 5·u of 0.8″.
    assert!((l2.amplitude_arcsec - 0.8).abs() < 5.0 * l2.u_amplitude_arcsec + 1e-3);
    let l24 = cert.spectrum.lines.iter().find(|l| l.order == 24);
    assert!(l24.is_none_or(|l| !l.visible));
    assert_eq!(cert.spectrum.invisible[0].by, "24-face polygon");
    assert!(cert.undetectable_orders.contains(&24));
    // Residuals: one per reading, their RMS is the reported one.
    let sa = cert.shift_angle.as_ref().unwrap();
    assert_eq!(sa.reading_residuals_arcsec.len(), set.len());
    let rms = (sa
        .reading_residuals_arcsec
        .iter()
        .map(|r| r * r)
        .sum::<f64>()
        / set.len() as f64)
        .sqrt();
    assert!((rms - cert.residuals.rms_arcsec).abs() < 1e-12);
    // β with U from the random part's ν.
    let k_beta = coverage_factor(0.95, dof);
    let b1 = sa.pitch_deviations[0];
    assert!((b1.expanded_arcsec.unwrap() - k_beta * b1.u_arcsec).abs() < 1e-15);
    assert_eq!(
        cert.compensation[3].correction_arcsec,
        -cert.points[3].value_arcsec
    );
}

#[test]
fn unknown_random_part_gives_no_expanded_uncertainty() {
    // One row per shift at a single shift: no residual degrees of freedom, no stated σ.
    let n = 4;
    let readings: Vec<Reading> = (1..=n)
        .flat_map(|j| (1..=n).map(move |i| Reading::new(0.0, j, i, 0.01 * (i * j) as f64)))
        .collect();
    let set = ReadingSet::new(n, readings[..n * n].to_vec()).unwrap();
    let cal = calibrate(
        &set,
        &Options {
            method: gonio_calib::shift_angle::Method::Paper,
            ..Options::default()
        },
    )
    .unwrap();
    let cert = Certificate::from_shift_angle(&cal, &set, false, 1, &instrument()).unwrap();
    if cal.residuals.dof == 0 {
        assert!(cert.points.iter().all(|p| p.expanded_arcsec.is_none()));
    }
    // Stated σ: ν = ∞, k = z.
    let cal = calibrate(
        &set,
        &Options {
            sigma_arcsec: Some(0.01),
            ..Options::default()
        },
    )
    .unwrap();
    let cert = Certificate::from_shift_angle(&cal, &set, true, 1, &Instrument::default()).unwrap();
    let p = cert.points[0];
    assert_eq!(p.nu_eff, Some(f64::INFINITY));
    assert!((p.k.unwrap() - 1.959964).abs() < 1e-6);
}

fn selfcal_result(turns: usize) -> selfcal::SelfcalResult {
    let heads = Heads::preset("eda:4").unwrap();
    let ns = 360;
    let mut rng = ChaCha8Rng::seed_from_u64(5);
    let noise = Normal::new(0.0, 0.01).unwrap();
    let a = |t: f64| 0.5 * (3.0 * t.to_radians()).sin() + 0.2 * (7.0 * t.to_radians()).cos();
    let turns: Vec<Turn> = (0..turns)
        .map(|_| {
            let positions_deg: Vec<f64> = (0..ns).map(|i| i as f64).collect();
            let differences_arcsec = heads.angles_deg()[1..]
                .iter()
                .map(|&p| {
                    positions_deg
                        .iter()
                        .map(|&t| a(t + p) - a(t) + noise.sample(&mut rng))
                        .collect()
                })
                .collect();
            Turn {
                positions_deg,
                differences_arcsec,
            }
        })
        .collect();
    selfcal::calibrate(&heads, &turns, &SelfcalOptions::default()).unwrap()
}

#[test]
fn selfcal_certificate_k_from_the_turns_dof_at_the_chosen_coverage() {
    // Six turns: u from their spread with ν = 5; k = t_0.975(5) = 2.571 (JCGM 100 Table G.2).
    let r = selfcal_result(6);
    let cert = Certificate::from_selfcal(&r, &Instrument::default()).unwrap();
    assert_eq!(cert.procedure, Procedure::SelfCalibration);
    assert_eq!(cert.uncertainty.source, "repeated turns");
    let p = cert.points[10];
    assert_eq!(p.nu_eff, Some(5.0));
    assert!((p.k.unwrap() - 2.571).abs() < 1e-3);
    // At p = 99 %: t_0.995(5) = 4.032.
    let inst = Instrument::default().with_coverage(0.99).unwrap();
    let cert = Certificate::from_selfcal(&r, &inst).unwrap();
    assert!((cert.points[10].k.unwrap() - 4.032).abs() < 1e-3);
    assert_eq!(cert.points[10].p, Some(0.99));
    assert_eq!(cert.undetectable_orders, r.undetectable_orders);
    assert_eq!(cert.spectrum.invisible[0].orders, r.undetectable_orders);
    assert!(
        cert.spectrum
            .lines
            .iter()
            .any(|l| l.order == 4 && !l.visible)
    );
}

#[test]
fn json_round_trip_and_legacy_keys() {
    let set = shift_angle_set(2);
    let cal = calibrate(&set, &Options::default()).unwrap();
    let sa = Certificate::from_shift_angle(&cal, &set, false, 2, &instrument()).unwrap();
    let sc = Certificate::from_selfcal(&selfcal_result(1), &instrument()).unwrap();
    for cert in [sa, sc] {
        let text = serde_json::to_string(&cert).unwrap();
        let back: Certificate = serde_json::from_str(&text).unwrap();
        // NaN never equals itself: compare the JSON forms.
        assert_eq!(serde_json::to_string(&back).unwrap(), text);
        let v: serde_json::Value = serde_json::from_str(&text).unwrap();
        assert_eq!(v["format"], "gonio.certificate/1");
        assert_eq!(v["undetectable_harmonics"], v["undetectable_orders"]);
        match cert.procedure {
            Procedure::ShiftAngle => {
                assert!(v["encoder_errors"][0]["U_arcsec"].is_number());
                assert!(v.get("errors").is_none());
                assert_eq!(v["faces"], 24);
            }
            _ => {
                assert_eq!(v["errors"][5]["position_deg"], v["errors"][5]["angle_deg"]);
                assert!(v.get("encoder_errors").is_none());
                assert!(v["heads_deg"].is_array());
            }
        }
    }
    // A wrong format tag or a missing method section is an error that says what was expected.
    let set = shift_angle_set(3);
    let cal = calibrate(&set, &Options::default()).unwrap();
    let cert = Certificate::from_shift_angle(&cal, &set, false, 2, &instrument()).unwrap();
    let mut v: serde_json::Value = serde_json::to_value(&cert).unwrap();
    v["format"] = "gonio-selfcal-result".into();
    let e = serde_json::from_value::<Certificate>(v.clone()).unwrap_err();
    assert!(e.to_string().contains("gonio.certificate/1"), "{e}");
    v["format"] = "gonio.certificate/1".into();
    v.as_object_mut().unwrap().remove("faces");
    let e = serde_json::from_value::<Certificate>(v).unwrap_err();
    assert!(e.to_string().contains("faces"), "{e}");
}

/// An 8-face polygon at shifts 0°, 5°, …, 40° (a 5° grid) and 4 equally spaced heads at 360
/// positions, one encoder α = 0.3·sin 2θ + 0.1·sin 4θ + 0.05·sin 8θ with white noise: the heads
/// cannot see 4 and 8, the polygon cannot see 8.
fn joint_lab(seed: u64) -> gonio_calib::joint::JointCalibration {
    use gonio_calib::joint::{JointOptions, calibrate as joint};
    let alpha = |t: f64| {
        let r = t.to_radians();
        0.3 * (2.0 * r).sin() + 0.1 * (4.0 * r).sin() + 0.05 * (8.0 * r + 0.4).sin()
    };
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let noise = Normal::new(0.0, 0.01).unwrap();
    let heads = Heads::preset("eda:4").unwrap();
    let positions_deg: Vec<f64> = (0..360).map(f64::from).collect();
    let differences_arcsec = heads.angles_deg()[1..]
        .iter()
        .map(|&p| {
            positions_deg
                .iter()
                .map(|&t| alpha(t + p) - alpha(t) + noise.sample(&mut rng))
                .collect()
        })
        .collect();
    let turn = Turn {
        positions_deg,
        differences_arcsec,
    };
    let mut readings = Vec::new();
    for s in 0..9 {
        let shift = 5.0 * s as f64;
        for j in 1..=8 {
            for i in 1..=8 {
                let theta = shift + (i - 1) as f64 * 45.0;
                readings.push(Reading::new(
                    shift,
                    j,
                    i,
                    alpha(theta) + noise.sample(&mut rng),
                ));
            }
        }
    }
    let set = ReadingSet::new(8, readings).unwrap();
    let opts = JointOptions {
        max_order: 36,
        ..JointOptions::default()
    };
    joint(&set, &heads, &[turn], &opts).unwrap()
}

#[test]
fn joint_certificate_carries_both_instruments_and_reads_back() {
    let cal = joint_lab(5);
    let inst = instrument();
    let cert = Certificate::from_joint(&cal, &inst).unwrap();
    assert_eq!(cert.procedure, Procedure::Joint);
    assert_eq!(cert.points.len(), 72);
    // U attached once: the joint random part (with its own ν) and the instrument terms.
    for (p, a) in cert.points.iter().zip(&cal.alpha) {
        assert_eq!(p.u_random_arcsec, a.u_arcsec);
        let c = inst.terms.combine(a.u_arcsec, a.nu_eff).unwrap();
        assert_eq!(p.expanded_arcsec, Some(c.expanded));
    }
    // Order 4 comes from the polygon alone; 8 is invisible to both and marked so.
    assert!(cert.spectrum.lines[3].visible);
    assert!(!cert.spectrum.lines[7].visible);
    // 36 is the Nyquist order of the polygon's 5° grid: its sine vanishes at every angle.
    assert_eq!(cert.undetectable_orders, vec![8, 16, 24, 32, 36]);
    assert_eq!(
        cal.harmonics[35].invisible,
        Some(gonio_calib::joint::Invisible::Unresolved { alias_of: None })
    );
    let by: Vec<&str> = cert
        .spectrum
        .invisible
        .iter()
        .map(|i| i.by.as_str())
        .collect();
    assert_eq!(
        by,
        [
            "8-face polygon",
            "4 read heads",
            "joint estimate (both instruments)"
        ]
    );
    assert!(cert.spectrum.invisible[1].orders.contains(&4));
    assert_eq!(cert.pitch_deviations().unwrap().len(), 8);
    let text = serde_json::to_string(&cert).unwrap();
    let back: Certificate = serde_json::from_str(&text).unwrap();
    assert_eq!(serde_json::to_string(&back).unwrap(), text);
    let v: serde_json::Value = serde_json::from_str(&text).unwrap();
    assert!(v["encoder_errors"][0]["U_arcsec"].is_number());
    assert_eq!(
        v["joint"]["covariance_alpha_arcsec2"][71]
            .as_array()
            .unwrap()
            .len(),
        72
    );
    let mut v = v;
    v.as_object_mut().unwrap().remove("joint");
    let e = serde_json::from_value::<Certificate>(v).unwrap_err();
    assert!(e.to_string().contains("joint"), "{e}");
}
