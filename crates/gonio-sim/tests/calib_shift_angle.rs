//! The shift-angle estimators against the simulator's ground truth and the spec's formulas.

use gonio_calib::shift_angle::{
    CovarianceLevel, Method, Options, Reading, ReadingSet, ShiftAngleError, calibrate,
    harmonic_check,
};
use gonio_sim::EncoderModel;
use gonio_sim::encoder::HarmonicArcsec;
use gonio_sim::shift_angle::{Rows, ShiftAngleConfig, ShiftAngleSim, ShiftAngleTruth, simulate};

fn noise_free(faces: usize, shifts: &[f64], rows: Rows, seed: u64) -> ShiftAngleSim {
    let enc = EncoderModel::default_with_seed(seed);
    simulate(
        &enc,
        &ShiftAngleConfig {
            faces,
            shifts_deg: shifts.to_vec(),
            rows,
            noise_sigma_arcsec: 0.0,
            resolution_arcsec: 0.0,
            seed,
            ..ShiftAngleConfig::default()
        },
    )
    .unwrap()
}

fn options(method: Method) -> Options {
    Options {
        method,
        ..Options::default()
    }
}

/// Largest deviation of the estimates from the truth over α, β and the estimated U.
fn max_error(cal: &gonio_calib::shift_angle::Calibration, truth: &ShiftAngleTruth) -> f64 {
    let mut worst: f64 = 0.0;
    for t in &truth.encoder_errors {
        let s = cal
            .shifts
            .iter()
            .find(|s| s.shift_deg == t.shift_deg)
            .unwrap();
        worst = worst.max((s.alpha_arcsec[t.step - 1] - t.value_arcsec).abs());
    }
    for p in &truth.pitch_deviations {
        worst = worst.max((cal.beta_arcsec[p.face - 1] - p.value_arcsec).abs());
    }
    for u in &cal.setup {
        let t = truth
            .setup_errors
            .iter()
            .find(|t| t.shift_deg == u.shift_deg && t.start_face == u.start_face)
            .unwrap();
        worst = worst.max((u.value_arcsec - t.value_arcsec).abs());
    }
    worst
}

#[test]
fn noise_free_data_recovered_by_both_methods() {
    for faces in [6, 12, 24, 36] {
        for rows in [Rows::Seed, Rows::Full] {
            // Shifts 0 and 10° would repeat every angle of the 36-face polygon (refused: a shift and the
            // same shift plus a pitch give each angle twice); 7.5° is no multiple of any pitch here.
            let sim = noise_free(faces, &[0.0, 5.0, 7.5], rows, faces as u64);
            let set = ReadingSet::new(faces, sim.readings.clone()).unwrap();
            for method in [Method::LeastSquares, Method::Paper] {
                let cal = calibrate(&set, &options(method)).unwrap();
                let err = max_error(&cal, &sim.truth);
                assert!(err < 1e-9, "N={faces} {rows:?} {method:?}: {err:e}″");
                assert!(cal.residuals.rms_arcsec < 1e-9);
            }
        }
    }
}

#[test]
fn any_shift_set_and_odd_faces() {
    let sim = noise_free(7, &[0.0, 3.3, 17.0, 40.0], Rows::Full, 3);
    let set = ReadingSet::new(7, sim.readings.clone()).unwrap();
    let cal = calibrate(&set, &Options::default()).unwrap();
    assert!(max_error(&cal, &sim.truth) < 1e-9);
    // 40° is beyond one pitch (51.4°/…): angles wrap correctly.
    assert_eq!(cal.shifts.len(), 4);
    assert_eq!(cal.undetectable_harmonics, vec![7, 14]);
}

/// The spec's table of standard deviations (white noise σ, N = 24, seed protocol).
#[test]
fn reported_uncertainties_match_the_spec_formulas() {
    let n = 24usize;
    let nf = n as f64;
    let sigma = 0.05;
    let sim = noise_free(n, &[0.0, 5.0, 10.0], Rows::Seed, 2);
    let set = ReadingSet::new(n, sim.readings).unwrap();
    let opts = |method| Options {
        method,
        sigma_arcsec: Some(sigma),
        covariance: CovarianceLevel::Diagonal,
    };
    let ls = calibrate(&set, &opts(Method::LeastSquares)).unwrap();
    let pa = calibrate(&set, &opts(Method::Paper)).unwrap();
    let close = |a: f64, b: f64| (a - b).abs() < 1e-12;
    for i in 0..n {
        assert!(close(
            ls.shifts[0].u_alpha_arcsec[i],
            sigma * (nf - 1.0).sqrt() / nf
        ));
        assert!(close(
            pa.shifts[0].u_alpha_arcsec[i],
            sigma * (nf - 1.0) / nf
        ));
        assert!(close(
            pa.shifts[1].u_alpha_arcsec[i],
            sigma * (nf * nf - 1.0).sqrt() / nf
        ));
        assert!(close(ls.u_beta_arcsec[i], sigma * (2.0 / nf).sqrt()));
        assert!(close(pa.u_beta_arcsec[i], sigma * (2.0 / nf).sqrt()));
    }
    for u in ls.setup.iter().filter(|u| u.shift_deg == 0.0) {
        assert!(
            close(u.u_arcsec, sigma * (2.0 * nf - 1.0).sqrt() / nf),
            "{u:?}"
        );
    }
}

/// Monte Carlo: least squares beats the paper's α at S = 0 by ≈ √(N−1), and the reported u
/// matches the empirical spread.
#[test]
fn monte_carlo_least_squares_gain_and_honest_uncertainty() {
    let n = 24usize;
    let sigma = 0.05;
    let trials = 300;
    let enc = EncoderModel::default_with_seed(11);
    let (mut ss_ls, mut ss_pa, mut ss_beta, mut count) = (0.0, 0.0, 0.0, 0usize);
    let (mut u_ls, mut u_pa, mut u_beta) = (0.0, 0.0, 0.0);
    for t in 0..trials {
        let sim = simulate(
            &enc,
            &ShiftAngleConfig {
                faces: n,
                shifts_deg: vec![0.0, 5.0, 10.0],
                noise_sigma_arcsec: sigma,
                resolution_arcsec: 0.0,
                seed: 1000 + t,
                ..ShiftAngleConfig::default()
            },
        )
        .unwrap();
        let set = ReadingSet::new(n, sim.readings).unwrap();
        let ls = calibrate(&set, &options(Method::LeastSquares)).unwrap();
        let pa = calibrate(&set, &options(Method::Paper)).unwrap();
        for a in sim
            .truth
            .encoder_errors
            .iter()
            .filter(|a| a.shift_deg == 0.0)
        {
            let i = a.step - 1;
            ss_ls += (ls.shifts[0].alpha_arcsec[i] - a.value_arcsec).powi(2);
            ss_pa += (pa.shifts[0].alpha_arcsec[i] - a.value_arcsec).powi(2);
            u_ls += ls.shifts[0].u_alpha_arcsec[i].powi(2);
            u_pa += pa.shifts[0].u_alpha_arcsec[i].powi(2);
            count += 1;
        }
        for p in &sim.truth.pitch_deviations {
            ss_beta += (ls.beta_arcsec[p.face - 1] - p.value_arcsec).powi(2);
            u_beta += ls.u_beta_arcsec[p.face - 1].powi(2);
        }
    }
    let rms = |ss: f64, k: usize| (ss / k as f64).sqrt();
    let (e_ls, e_pa) = (rms(ss_ls, count), rms(ss_pa, count));
    let ratio = e_pa / e_ls;
    let expected = ((n - 1) as f64).sqrt();
    eprintln!(
        "α at S=0 error RMS: least squares {e_ls:.5}″ (reported u {:.5}″), paper {e_pa:.5}″ \
         (reported u {:.5}″); ratio {ratio:.3} vs √(N−1) = {expected:.3}",
        rms(u_ls, count),
        rms(u_pa, count)
    );
    // 7200 pooled errors: the relative standard error of an RMS is ≈ 1/√(2·7200) ≈ 0.8 %
    // (more with the correlation inside a shift); 10 % is the tolerance.
    assert!(
        (ratio / expected - 1.0).abs() < 0.10,
        "ratio {ratio}, expected {expected}"
    );
    assert!(
        (rms(u_ls, count) / e_ls - 1.0).abs() < 0.10,
        "LS u {} vs spread {e_ls}",
        rms(u_ls, count)
    );
    assert!(
        (rms(u_pa, count) / e_pa - 1.0).abs() < 0.10,
        "paper u {} vs spread {e_pa}",
        rms(u_pa, count)
    );
    let k = trials as usize * n;
    assert!((rms(u_beta, k) / rms(ss_beta, k) - 1.0).abs() < 0.10);
}

#[test]
fn harmonic_check_recovers_planted_a_b_u() {
    // Hsieh et al., 2022, §3.1: α = A·sin(2θ + B) with A = 1.0314″, B = −2.4233; U planted per run.
    let enc = EncoderModel::harmonics_only(vec![HarmonicArcsec {
        order: 2,
        amplitude_arcsec: 1.0314,
        phase_rad: -2.4233,
    }])
    .unwrap();
    let sim = simulate(
        &enc,
        &ShiftAngleConfig {
            faces: 24,
            shifts_deg: vec![0.0, 5.0, 10.0],
            noise_sigma_arcsec: 0.0,
            resolution_arcsec: 0.0,
            seed: 4,
            ..ShiftAngleConfig::default()
        },
    )
    .unwrap();
    let set = ReadingSet::new(24, sim.readings.clone()).unwrap();
    for method in [Method::LeastSquares, Method::Paper] {
        let cal = calibrate(&set, &options(method)).unwrap();
        let chk = harmonic_check(&cal, 2).unwrap();
        assert!((chk.amplitude_arcsec - 1.0314).abs() < 1e-9);
        assert!((chk.phase_rad + 2.4233).abs() < 1e-9);
        for s in &chk.shifts {
            let planted = sim
                .truth
                .setup_errors
                .iter()
                .find(|u| u.shift_deg == s.shift_deg && u.start_face == 1)
                .unwrap()
                .planted_arcsec;
            assert!(
                (s.u_fit_arcsec - planted).abs() < 1e-9,
                "{s:?} vs {planted}"
            );
            assert!(s.difference_arcsec.abs() < 1e-9);
        }
    }
}

#[test]
fn missing_step_names_the_undetermined_angle() {
    let sim = noise_free(12, &[0.0, 5.0], Rows::Seed, 8);
    let readings: Vec<Reading> = sim
        .readings
        .into_iter()
        .filter(|r| !(r.shift_deg == 5.0 && r.step == 3))
        .collect();
    let set = ReadingSet::new(12, readings).unwrap();
    let err = calibrate(&set, &Options::default()).unwrap_err();
    match &err {
        ShiftAngleError::Undetermined { names, .. } => {
            assert!(names.contains("α(65°) [shift 5°, step 3]"), "{names}");
            assert!(!names.contains("β_"), "{names}");
        }
        e => panic!("unexpected {e}"),
    }
    // One row per shift cannot separate α from β.
    let one = noise_free(6, &[0.0, 10.0], Rows::One, 8);
    let set = ReadingSet::new(6, one.readings).unwrap();
    let err = calibrate(&set, &Options::default())
        .unwrap_err()
        .to_string();
    assert!(err.contains("β_"), "{err}");
}

#[test]
fn paper_method_explains_what_it_needs() {
    let sim = noise_free(6, &[0.0, 5.0], Rows::Full, 1);
    let readings: Vec<Reading> = sim
        .readings
        .into_iter()
        .filter(|r| !(r.start_face == 2 && r.step == 2))
        .collect();
    let set = ReadingSet::new(6, readings).unwrap();
    let err = calibrate(&set, &options(Method::Paper)).unwrap_err();
    assert!(matches!(err, ShiftAngleError::PaperNeeds { .. }), "{err}");
    // Least squares copes with the same data.
    assert!(calibrate(&set, &Options::default()).is_ok());
}

#[test]
fn repeats_average_and_chi2_accepts_the_true_sigma() {
    let enc = EncoderModel::default_with_seed(2);
    let sigma = 0.05;
    let sim = simulate(
        &enc,
        &ShiftAngleConfig {
            repeats: 3,
            resolution_arcsec: 0.0,
            rows: Rows::Full,
            seed: 77,
            ..ShiftAngleConfig::default()
        },
    )
    .unwrap();
    let set = ReadingSet::new(24, sim.readings).unwrap();
    let cal = calibrate(
        &set,
        &Options {
            sigma_arcsec: Some(sigma),
            ..Options::default()
        },
    )
    .unwrap();
    let chi = cal.residuals.chi2.unwrap();
    // χ²/dof ≈ 1 ± √(2/dof) (dof ≈ 5000); 5 standard deviations.
    let dof = chi.dof as f64;
    assert!(
        (chi.chi2 / dof - 1.0).abs() < 5.0 * (2.0 / dof).sqrt(),
        "{chi:?}"
    );
    // A stated σ twice too small is flagged.
    let bad = calibrate(
        &set,
        &Options {
            sigma_arcsec: Some(sigma / 2.0),
            ..Options::default()
        },
    )
    .unwrap();
    assert!(!bad.residuals.chi2.unwrap().consistent);
}

#[test]
fn full_covariance_diagonal_matches_the_reported_u() {
    let enc = EncoderModel::default_with_seed(2);
    let sim = simulate(
        &enc,
        &ShiftAngleConfig {
            seed: 5,
            ..ShiftAngleConfig::default()
        },
    )
    .unwrap();
    let set = ReadingSet::new(24, sim.readings).unwrap();
    let cal = calibrate(
        &set,
        &Options {
            covariance: CovarianceLevel::Full,
            sigma_arcsec: Some(0.05),
            ..Options::default()
        },
    )
    .unwrap();
    let cov = cal.covariance.as_ref().unwrap();
    for (s, sh) in cal.shifts.iter().enumerate() {
        for i in 0..24 {
            let d = cov.alpha[(s * 24 + i, s * 24 + i)].sqrt();
            assert!((d - sh.u_alpha_arcsec[i]).abs() < 1e-12);
        }
        // Closure: every row of a shift's block sums to zero.
        let row: f64 = (0..24).map(|i| cov.alpha[(s * 24, s * 24 + i)]).sum();
        assert!(row.abs() < 1e-12);
    }
    for k in 0..24 {
        assert!((cov.beta[(k, k)].sqrt() - cal.u_beta_arcsec[k]).abs() < 1e-12);
    }
}

#[test]
fn bad_readings_are_typed_errors() {
    let r = |face, step, v| Reading::new(0.0, face, step, v);
    assert!(matches!(
        ReadingSet::new(6, vec![r(7, 1, 0.0)]),
        Err(ShiftAngleError::OutOfRange {
            what: "start_face",
            found: 7,
            ..
        })
    ));
    assert!(matches!(
        ReadingSet::new(6, vec![r(1, 0, 0.0)]),
        Err(ShiftAngleError::OutOfRange { what: "step", .. })
    ));
    assert!(matches!(
        ReadingSet::new(6, vec![r(1, 1, 0.0), r(1, 1, 0.5)]),
        Err(ShiftAngleError::ConflictingDuplicate {
            index: 1,
            first: 0,
            ..
        })
    ));
    assert_eq!(
        ReadingSet::new(6, vec![r(1, 1, 0.5), r(1, 1, 0.5)])
            .unwrap()
            .duplicates_ignored(),
        1
    );
    assert!(matches!(
        ReadingSet::new(2, vec![r(1, 1, 0.0)]),
        Err(ShiftAngleError::TooFewFaces { .. })
    ));
    assert!(matches!(
        ReadingSet::new(6, vec![r(1, 1, f64::NAN)]),
        Err(ShiftAngleError::NotFinite { .. })
    ));
}
