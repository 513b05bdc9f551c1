//! Self-calibration estimators against planted harmonics, each other, and Monte Carlo.

use gonio_calib::selfcal::{
    Heads, Method, NoiseModel, SelfcalOptions, SelfcalResult, Turn, calibrate, eda_direct,
    noise_gain,
};
use gonio_core::Harmonic;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal, Uniform};

/// Harmonics planted at `orders` with random amplitudes (0.1–1″) and phases.
fn plant(orders: impl IntoIterator<Item = u32>, seed: u64) -> Vec<Harmonic> {
    let mut r = ChaCha8Rng::seed_from_u64(seed);
    let amp = Uniform::new(0.1, 1.0).unwrap();
    let ph = Uniform::new(-3.1, 3.1).unwrap();
    orders
        .into_iter()
        .map(|order| Harmonic {
            order,
            amplitude: amp.sample(&mut r),
            phase_rad: ph.sample(&mut r),
        })
        .collect()
}

fn a_of(h: &[Harmonic], t_deg: f64) -> f64 {
    h.iter()
        .map(|x| x.eval(gonio_core::Radians(t_deg.to_radians())))
        .sum()
}

/// D_h(θ) = a(θ + φ_h) − a(θ) + c_h + (independent noise on each D_h, or on each reading).
fn synth(
    heads: &Heads,
    h: &[Harmonic],
    ns: usize,
    start_deg: f64,
    noise: Option<(NoiseModel, f64, &mut ChaCha8Rng)>,
) -> Turn {
    let positions_deg: Vec<f64> = (0..ns)
        .map(|i| start_deg + i as f64 * 360.0 / ns as f64)
        .collect();
    let m = heads.len();
    let mut d: Vec<Vec<f64>> = heads.angles_deg()[1..]
        .iter()
        .enumerate()
        .map(|(c, &p)| {
            positions_deg
                .iter()
                .map(|&t| a_of(h, t + p) - a_of(h, t) + 0.7 * (c as f64 + 1.0) - 3.0)
                .collect()
        })
        .collect();
    if let Some((model, sigma, rng)) = noise {
        let n = Normal::new(0.0, sigma).unwrap();
        for i in 0..ns {
            let n1 = if model == NoiseModel::Readings {
                n.sample(rng)
            } else {
                0.0
            };
            for col in d.iter_mut().take(m - 1) {
                col[i] += n.sample(rng) - n1;
            }
        }
    }
    Turn {
        positions_deg,
        differences_arcsec: d,
    }
}

fn opts(method: Method, max_order: u32) -> SelfcalOptions {
    SelfcalOptions {
        method,
        max_order,
        ..SelfcalOptions::default()
    }
}

fn planted_amp(h: &[Harmonic], order: u32) -> f64 {
    h.iter()
        .find(|x| x.order == order)
        .map_or(0.0, |x| x.amplitude)
}

fn cos_sin(r: &SelfcalResult, order: u32) -> (f64, f64) {
    let row = &r.harmonics[order as usize - 1];
    assert_eq!(row.order, order);
    Harmonic {
        order,
        amplitude: row.amplitude_arcsec,
        phase_rad: row.phase_rad,
    }
    .cos_sin()
}

#[test]
fn eda_passes_non_multiples_and_removes_multiples_of_nh() {
    for nh in [3usize, 4, 5, 7] {
        let heads = Heads::equal_division(nh).unwrap();
        let h = plant(1..=40, nh as u64);
        let turn = synth(&heads, &h, 720, 0.25, None);
        let r = calibrate(&heads, std::slice::from_ref(&turn), &opts(Method::Eda, 40)).unwrap();
        assert_eq!(r.method, "selfcal-eda");
        for row in &r.harmonics {
            let k = row.order;
            let (a, b) = cos_sin(&r, k);
            let planted = h.iter().find(|x| x.order == k).unwrap();
            if (k as usize).is_multiple_of(nh) {
                assert!(!row.detectable, "NH={nh} k={k}");
                assert!(row.amplitude_arcsec < 1e-10, "NH={nh} k={k}: {row:?}");
            } else {
                let (pa, pb) = planted.cos_sin();
                assert!(row.detectable);
                assert!(
                    (a - pa).abs() < 1e-10 && (b - pb).abs() < 1e-10,
                    "NH={nh} k={k}"
                );
            }
        }
        let want: Vec<u32> = (1..=40)
            .filter(|k| (*k as usize).is_multiple_of(nh))
            .collect();
        assert_eq!(r.undetectable_orders, want);
        // The spectral EDA is the seed's Eq. 9 computed literally.
        let direct = eda_direct(&heads.sets()[0], &turn);
        for (e, d) in r.errors.iter().zip(&direct) {
            assert!((e.value_arcsec - d).abs() < 1e-10);
        }
    }
}

#[test]
fn spectral_eda_equals_seed_formula_with_noise() {
    let heads = Heads::equal_division(6).unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(11);
    let h = plant([1, 2, 3, 6, 12, 13], 3);
    let turn = synth(
        &heads,
        &h,
        360,
        0.0,
        Some((NoiseModel::Readings, 0.05, &mut rng)),
    );
    let r = calibrate(&heads, std::slice::from_ref(&turn), &opts(Method::Eda, 100)).unwrap();
    let direct = eda_direct(&heads.sets()[0], &turn);
    for (e, d) in r.errors.iter().zip(&direct) {
        assert!((e.value_arcsec - d).abs() < 1e-10);
    }
}

#[test]
fn selfa_loses_exactly_the_multiples_of_84() {
    let heads = Heads::selfa12();
    let h = plant(1..=200, 84);
    let turn = synth(&heads, &h, 1800, 0.0, None);
    for method in [Method::Eda, Method::Fourier] {
        let r = calibrate(&heads, std::slice::from_ref(&turn), &opts(method, 200)).unwrap();
        assert_eq!(r.undetectable_orders, vec![84, 168], "{method:?}");
        for row in &r.harmonics {
            let k = row.order;
            if k % 84 == 0 {
                assert!(!row.detectable && row.amplitude_arcsec < 1e-10);
            } else {
                let (a, b) = cos_sin(&r, k);
                let (pa, pb) = h[k as usize - 1].cos_sin();
                assert!(
                    (a - pa).abs() < 1e-9 && (b - pb).abs() < 1e-9,
                    "{method:?} k={k}: {a} {b} vs {pa} {pb}"
                );
            }
        }
        // a(θ) itself: the truth minus its multiples of 84.
        let visible: Vec<Harmonic> = h.iter().filter(|x| x.order % 84 != 0).copied().collect();
        for e in r.errors.iter().step_by(7) {
            assert!((e.value_arcsec - a_of(&visible, e.position_deg)).abs() < 1e-9);
        }
    }
    let r = calibrate(&heads, &[turn], &opts(Method::Eda, 10)).unwrap();
    assert_eq!(r.method, "selfcal-selfa");
}

#[test]
fn fourier_equals_eda_on_equal_divisions() {
    for nh in [2usize, 3, 4, 8] {
        let heads = Heads::equal_division(nh).unwrap();
        let h = plant(1..=60, 100 + nh as u64);
        let turn = synth(&heads, &h, 500, 3.0, None);
        let f = calibrate(
            &heads,
            std::slice::from_ref(&turn),
            &opts(Method::Fourier, 60),
        )
        .unwrap();
        let e = calibrate(&heads, std::slice::from_ref(&turn), &opts(Method::Eda, 60)).unwrap();
        assert_eq!(f.undetectable_orders, e.undetectable_orders);
        for (x, y) in f.errors.iter().zip(&e.errors) {
            assert!((x.value_arcsec - y.value_arcsec).abs() < 1e-10, "NH={nh}");
        }
        // Offsets recovered: c_h = 0.7·(h−1) − 3.
        for (c, o) in f.head_offsets_arcsec.iter().enumerate() {
            assert!((o - (0.7 * (c as f64 + 1.0) - 3.0)).abs() < 1e-9);
        }
    }
}

#[test]
fn fourier_recovers_planted_harmonics_for_random_heads() {
    let mut rng = ChaCha8Rng::seed_from_u64(2024);
    let ang = Uniform::new(1.0, 359.0).unwrap();
    for trial in 0..5 {
        let mut angles: Vec<f64> = (0..4).map(|_| ang.sample(&mut rng)).collect();
        angles.sort_by(f64::total_cmp);
        angles.insert(0, 0.0);
        let heads = Heads::new(angles).unwrap();
        let h = plant(1..=30, trial);
        // Noise-free: exact.
        let turn = synth(&heads, &h, 400, 0.0, None);
        let r = calibrate(&heads, &[turn], &opts(Method::Fourier, 30)).unwrap();
        assert!(r.undetectable_orders.is_empty());
        for row in &r.harmonics {
            let (a, b) = cos_sin(&r, row.order);
            let (pa, pb) = h[row.order as usize - 1].cos_sin();
            assert!((a - pa).abs() < 1e-8 && (b - pb).abs() < 1e-8);
        }
        // With noise: every coefficient within 4.5 of its own standard uncertainty.
        let turn = synth(
            &heads,
            &h,
            400,
            0.0,
            Some((NoiseModel::Readings, 0.02, &mut rng)),
        );
        let r = calibrate(&heads, &[turn], &opts(Method::Fourier, 30)).unwrap();
        for row in &r.harmonics {
            let (a, b) = cos_sin(&r, row.order);
            let (pa, pb) = h[row.order as usize - 1].cos_sin();
            let u = row.u_coefficient_arcsec;
            assert!(
                (a - pa).abs() < 4.5 * u && (b - pb).abs() < 4.5 * u,
                "trial {trial} k={}: {a} vs {pa}, {b} vs {pb}, u {u}",
                row.order
            );
        }
        assert!(planted_amp(&h, 31) == 0.0);
    }
}

/// The noise gain 1/Σ|w|² (and its readings-model version) against a Monte Carlo; σ̂ and u
/// against the spread of repeated estimates.
#[test]
fn noise_gain_matches_monte_carlo() {
    let heads = Heads::selfa12();
    assert!((noise_gain(&heads, 1).unwrap() - 1.0 / 28.0).abs() < 1e-12);
    let ns = 256;
    let sigma = 0.1;
    let trials = 400;
    let orders = [1u32, 2, 5, 12, 30];
    for model in [NoiseModel::Differences, NoiseModel::Readings] {
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        let mut sum2 = vec![0.0; orders.len()];
        let mut pos2 = 0.0;
        let mut sig2 = 0.0;
        let mut u_rep = 0.0;
        let o = SelfcalOptions {
            noise_model: model,
            max_order: 40,
            ..SelfcalOptions::default()
        };
        for _ in 0..trials {
            let turn = synth(&heads, &[], ns, 0.0, Some((model, sigma, &mut rng)));
            let r = calibrate(&heads, &[turn], &o).unwrap();
            for (s, &k) in sum2.iter_mut().zip(&orders) {
                let (a, b) = cos_sin(&r, k);
                *s += a * a + b * b;
            }
            pos2 += r.errors.iter().map(|e| e.value_arcsec.powi(2)).sum::<f64>() / ns as f64;
            sig2 += r.residuals.sigma_arcsec.powi(2);
            u_rep = r.errors[0].u_arcsec;
        }
        let n = (2 * trials) as f64; // cos and sin pooled
        for (s, &k) in sum2.iter().zip(&orders) {
            let var = s / n;
            let g = if model == NoiseModel::Differences {
                noise_gain(&heads, k).unwrap()
            } else {
                // Readings: head 1's noise is common to every D_h: 1/S + |Σw|²/S².
                let w: Vec<(f64, f64)> = heads.angles_deg()[1..]
                    .iter()
                    .map(|p| {
                        let x = (k as f64 * p).to_radians();
                        (x.cos() - 1.0, x.sin())
                    })
                    .collect();
                let s: f64 = w.iter().map(|(a, b)| a * a + b * b).sum();
                let (sa, sb) = w
                    .iter()
                    .fold((0.0, 0.0), |acc, x| (acc.0 + x.0, acc.1 + x.1));
                1.0 / s + (sa * sa + sb * sb) / (s * s)
            };
            let want = 2.0 * sigma * sigma * g / ns as f64;
            // Relative standard error of a variance from n normal draws: √(2/n) = 5 %.
            let tol = 4.0 * (2.0 / n).sqrt();
            assert!(
                (var / want - 1.0).abs() < tol,
                "{model:?} k={k}: Monte Carlo {var:.3e}, formula {want:.3e}"
            );
        }
        // σ̂ from the residuals is unbiased for σ² (mean of 400 estimates, each with ~2800 dof).
        let s2 = sig2 / trials as f64;
        assert!(
            (s2 / (sigma * sigma) - 1.0).abs() < 0.01,
            "{model:?}: σ̂² {s2}"
        );
        // u of a(θ) matches the spread of a(θ) over the trials (pooled over positions; the
        // positions are correlated, so allow 4·√(2/trials)).
        let u_mc = (pos2 / trials as f64).sqrt();
        let tol = 4.0 * (2.0 / trials as f64).sqrt();
        assert!(
            (u_mc / u_rep - 1.0).abs() < tol,
            "{model:?}: u reported {u_rep}, Monte Carlo {u_mc}"
        );
    }
}

#[test]
fn repeated_turns_give_u_from_their_spread() {
    let heads = Heads::preset("eda:4").unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(5);
    let h = plant([1, 2, 3], 9);
    let turns: Vec<Turn> = (0..6)
        .map(|_| {
            synth(
                &heads,
                &h,
                360,
                0.0,
                Some((NoiseModel::Readings, 0.01, &mut rng)),
            )
        })
        .collect();
    let r = calibrate(&heads, &turns, &SelfcalOptions::default()).unwrap();
    assert_eq!(r.uncertainty.source, "repeated turns");
    assert_eq!(r.errors[0].nu_eff, 5.0);
    let ut = r.uncertainty.u_turns_arcsec.unwrap();
    // Turn spread and residual-based u estimate the same thing (ν = 5 per position, pooled
    // over 360 positions).
    assert!(
        (ut / r.uncertainty.u_residuals_arcsec - 1.0).abs() < 0.15,
        "{ut} vs {}",
        r.uncertainty.u_residuals_arcsec
    );
}

#[test]
fn reference_average_of_heads_1_and_7_calibrates_their_mean_reading() {
    let heads = Heads::selfa12();
    let h = plant(1..=10, 17);
    let turn = synth(&heads, &h, 720, 0.0, None);
    let o = SelfcalOptions {
        method: Method::Eda,
        reference_heads: vec![0, 6],
        ..SelfcalOptions::default()
    };
    let r = calibrate(&heads, &[turn], &o).unwrap();
    assert_eq!(r.reference_heads, vec![1, 7]);
    for e in r.errors.iter().step_by(11) {
        let want = 0.5 * (a_of(&h, e.position_deg) + a_of(&h, e.position_deg + 180.0));
        assert!((e.value_arcsec - want).abs() < 1e-9);
    }
}

#[test]
fn bad_inputs_are_typed_errors() {
    use gonio_calib::selfcal::SelfcalError as E;
    let heads = Heads::preset("eda:3").unwrap();
    let good = synth(&heads, &[], 36, 0.0, None);
    let o = SelfcalOptions::default();
    let mut t = good.clone();
    t.differences_arcsec.pop();
    assert!(matches!(
        calibrate(&heads, &[t], &o),
        Err(E::ChannelCount { .. })
    ));
    let mut t = good.clone();
    t.positions_deg[5] += 0.5;
    assert!(matches!(
        calibrate(&heads, &[t], &o),
        Err(E::Spacing { index: 5, .. })
    ));
    // Half a turn: spacing implies 10° steps for 36 rows; 5° steps are not a full turn.
    let mut t = good.clone();
    for (i, p) in t.positions_deg.iter_mut().enumerate() {
        *p = i as f64 * 5.0;
    }
    assert!(matches!(
        calibrate(&heads, &[t], &o),
        Err(E::Spacing { index: 1, .. })
    ));
    let mut t = good.clone();
    t.differences_arcsec[1][7] = f64::NAN;
    assert!(matches!(
        calibrate(&heads, &[t], &o),
        Err(E::NotFinite {
            head: 3,
            index: 7,
            ..
        })
    ));
    assert!(matches!(calibrate(&heads, &[], &o), Err(E::NoReadings)));
    let odd = Heads::new(vec![0.0, 10.0, 100.0]).unwrap();
    let t = synth(&odd, &[], 36, 0.0, None);
    assert!(matches!(
        calibrate(&odd, &[t], &opts(Method::Eda, 5)),
        Err(E::NoEqualDivision { .. })
    ));
    let o = SelfcalOptions {
        reference_heads: vec![5],
        ..SelfcalOptions::default()
    };
    assert!(matches!(
        calibrate(&heads, &[good], &o),
        Err(E::Reference { .. })
    ));
}
