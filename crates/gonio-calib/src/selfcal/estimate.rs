//! The estimators: per-harmonic linear combinations of the head differences (Fourier least
//! squares, EDA, SelfA), their noise gains, and the position-domain EDA reference.

use super::data::validate;
use super::scratch;
use super::*;
use gonio_core::Harmonic;
use realfft::num_complex::Complex;

type C64 = Complex<f64>;

/// A harmonic whose least-squares noise gain 1/Σ|w|² would exceed this is treated as undetectable.
pub const MAX_NOISE_GAIN: f64 = 1e6;

/// The least-squares noise gain `1/Σ_h |e^{ikφ_h} − 1|²` of harmonic `order`, or `None` if the
/// harmonic is undetectable (gain above [`MAX_NOISE_GAIN`]).
///
/// ```
/// use gonio_calib::selfcal::{noise_gain, Heads};
/// let g = noise_gain(&Heads::selfa12(), 1).unwrap();
/// assert!((g - 1.0 / 28.0).abs() < 1e-12);
/// assert!(noise_gain(&Heads::selfa12(), 84).is_none());
/// ```
pub fn noise_gain(heads: &Heads, order: u32) -> Option<f64> {
    let s: f64 = heads.angles_deg()[1..]
        .iter()
        .map(|&p| (w_of(order as f64, p)).norm_sqr())
        .sum();
    (s * MAX_NOISE_GAIN >= 1.0).then(|| 1.0 / s)
}

#[inline]
fn w_of(k: f64, phi_deg: f64) -> C64 {
    // e^{ikφ} − 1, with k·φ reduced exactly in degrees first (so k·φ ≡ 0 gives exactly 0
    // for whole-degree heads).
    let x = (k * phi_deg).rem_euclid(360.0).to_radians();
    let (s, c) = x.sin_cos();
    C64::new(c - 1.0, s)
}

/// The head weights `w_hk = e^{ikφ_h} − 1` of the heads at `phi` (degrees; heads 2..M) for
/// orders k = 0..nbins−1, stored `w[k·(M−1) + (h − 2)]`.
///
/// e^{ikφ_h} comes from a recurrence (one complex product per head and order), re-anchored
/// exactly every 64 orders so the rounding error stays below 1e-14.
pub(crate) fn phasor_table(phi: &[f64], nbins: usize) -> Vec<C64> {
    let m1 = phi.len();
    let mut w = scratch::complex(nbins * m1);
    let step: Vec<C64> = phi.iter().map(|&p| w_of(1.0, p) + 1.0).collect();
    let mut cur: Vec<C64> = vec![C64::new(1.0, 0.0); m1];
    for k in 1..nbins {
        let row_w = &mut w[k * m1..(k + 1) * m1];
        if k % 64 == 0 {
            for ((wc, c), &p) in row_w.iter_mut().zip(cur.iter_mut()).zip(phi) {
                *wc = w_of(k as f64, p);
                *c = *wc + 1.0;
            }
        } else {
            for ((wc, c), z) in row_w.iter_mut().zip(cur.iter_mut()).zip(&step) {
                *c *= z;
                *wc = *c - 1.0;
            }
        }
    }
    w
}

/// The spectra of validated head differences: one forward real FFT per channel and turn.
pub(crate) struct HeadSpectra {
    /// Rotation positions per turn NS.
    pub ns: usize,
    /// The first rotation position θ_0, degrees.
    pub theta0_deg: f64,
    /// Bins 0..=NS/2.
    pub nbins: usize,
    /// The Nyquist bin NS/2 when NS is even.
    pub nyquist: Option<usize>,
    /// `turns[t][h − 2][k]` = Σ_m D_h(θ_m)·e^{−2πikm/NS} of turn t (unnormalised DFT).
    pub turns: Vec<Vec<Vec<C64>>>,
}

impl HeadSpectra {
    /// Hands the spectra's memory back for the next self-calibration on this thread.
    pub fn recycle(self) {
        for turn in self.turns {
            for s in turn {
                scratch::give_complex(s);
            }
        }
    }
}

/// Validates the turns against the heads and transforms every channel (realfft).
///
/// # Errors
/// As [`calibrate`]'s input checks.
pub(crate) fn head_spectra(heads: &Heads, turns: &[Turn]) -> Result<HeadSpectra, SelfcalError> {
    let (ns, theta0_deg) = validate(heads, turns)?;
    let r2c = scratch::forward(ns);
    let mut work = scratch::complex(r2c.get_scratch_len());
    let mut input = scratch::real(ns);
    let spectra = turns
        .iter()
        .map(|turn| {
            turn.differences_arcsec
                .iter()
                .map(|col| {
                    let mut out = scratch::complex(ns / 2 + 1);
                    input.copy_from_slice(col);
                    r2c.process_with_scratch(&mut input, &mut out, &mut work)
                        .expect("buffer sizes are the planner's");
                    out
                })
                .collect()
        })
        .collect();
    scratch::give_complex(work);
    scratch::give_real(input);
    Ok(HeadSpectra {
        ns,
        theta0_deg,
        nbins: ns / 2 + 1,
        nyquist: (ns % 2 == 0).then_some(ns / 2),
        turns: spectra,
    })
}

/// The seed's equal-division average (Eq. 9) computed literally in the position domain, for one
/// set of heads (0-based indices, containing 0): `μ_i = −(1/NH)·Σ_j D_j(θ_i)`, mean removed.
///
/// This is the reference implementation [`calibrate`]'s spectral EDA is tested against.
pub fn eda_direct(set: &[usize], turn: &Turn) -> Vec<f64> {
    let ns = turn.positions_deg.len();
    let nh = set.len() as f64;
    let mut mu = vec![0.0; ns];
    for &j in set.iter().filter(|&&j| j > 0) {
        for (m, d) in mu.iter_mut().zip(&turn.differences_arcsec[j - 1]) {
            *m -= d / nh;
        }
    }
    gonio_core::closure::remove_mean(&mut mu);
    mu
}

/// Per-harmonic coefficients of a linear estimator: `v` (one per difference channel), the head
/// weights `w`, detectability.
struct BinTable {
    m1: usize,
    /// `v[k·m1 + c]`.
    v: Vec<C64>,
    /// `w[k·m1 + c]`.
    w: Vec<C64>,
    detectable: Vec<bool>,
}

fn bin_table(
    heads: &Heads,
    method: Method,
    nbins: usize,
    nyquist: Option<usize>,
) -> Result<(BinTable, &'static str), SelfcalError> {
    let m1 = heads.len() - 1;
    let mut v = scratch::complex(nbins * m1);
    let w = phasor_table(&heads.angles_deg()[1..], nbins);
    let mut detectable = vec![false; nbins];
    let sets = heads.sets();
    let name = match method {
        Method::Fourier => "selfcal-fourier",
        Method::Eda => match sets.len() {
            0 => {
                return Err(SelfcalError::NoEqualDivision {
                    message: format!(
                        "the {} heads at {:?}° are not equally spaced and no equal-division sets were given (use --method fourier, or list sets in the heads file)",
                        heads.len(),
                        heads.angles_deg()
                    ),
                });
            }
            1 => "selfcal-eda",
            _ => "selfcal-selfa",
        },
    };
    // Inverse-variance weight of each set's EDA (independent-difference noise: (NH−1)/NH²).
    let set_weight: Vec<f64> = sets
        .iter()
        .map(|s| {
            let nh = s.len() as f64;
            nh * nh / (nh - 1.0)
        })
        .collect();
    for k in 1..nbins {
        let row_w = &w[k * m1..(k + 1) * m1];
        if Some(k) == nyquist && !(method == Method::Eda && sets.len() == 1) {
            // Not estimated (v = 0): the sign of the order is ambiguous at NS/2. Plain EDA keeps
            // it, its coefficients being real (the seed's formula in the position domain).
            continue;
        }
        let row_v = &mut v[k * m1..(k + 1) * m1];
        match method {
            Method::Fourier => {
                let s: f64 = row_w.iter().map(|x| x.norm_sqr()).sum();
                if s * MAX_NOISE_GAIN >= 1.0 {
                    detectable[k] = true;
                    for (vc, wc) in row_v.iter_mut().zip(row_w.iter()) {
                        *vc = wc.conj() / s;
                    }
                }
            }
            Method::Eda => {
                // A set passes k when mean_j e^{ikφ_j} = 0 (NH does not divide k).
                let passes = |s: &Vec<usize>| {
                    let sum: C64 = s
                        .iter()
                        .map(|&j| {
                            if j == 0 {
                                C64::new(1.0, 0.0)
                            } else {
                                row_w[j - 1] + 1.0
                            }
                        })
                        .sum();
                    sum.norm() / (s.len() as f64) < 1e-9
                };
                if sets.len() == 1 {
                    // Plain EDA: the seed's formula at every harmonic.
                    let s = &sets[0];
                    let nh = s.len() as f64;
                    for &j in s.iter().filter(|&&j| j > 0) {
                        row_v[j - 1] = C64::new(-1.0 / nh, 0.0);
                    }
                    detectable[k] = passes(s);
                } else {
                    let mut wsum = 0.0;
                    for (s, &ws) in sets.iter().zip(&set_weight) {
                        if passes(s) {
                            let nh = s.len() as f64;
                            for &j in s.iter().filter(|&&j| j > 0) {
                                row_v[j - 1] -= C64::new(ws / nh, 0.0);
                            }
                            wsum += ws;
                        }
                    }
                    if wsum > 0.0 {
                        detectable[k] = true;
                        for vc in row_v.iter_mut() {
                            *vc /= wsum;
                        }
                    }
                }
            }
        }
    }
    Ok((
        BinTable {
            m1,
            v,
            w,
            detectable,
        },
        name,
    ))
}

/// Self-calibrates: estimates a(θ) at every rotation position from one or more turns of head
/// differences.
///
/// The result's `errors` is the error of the reference reading (head 1 by default) with zero
/// mean over the circle; undetectable harmonics are absent from it (their amplitude is 0).
/// With two or more turns the turns are averaged and u comes from their spread.
///
/// # Errors
/// [`SelfcalError`] for an empty input, a channel count or length that does not match the heads,
/// positions not equally spaced over one turn (or differing between turns), a non-finite value,
/// `Method::Eda` without equal-division sets, or a bad reference head.
pub fn calibrate(
    heads: &Heads,
    turns: &[Turn],
    options: &SelfcalOptions,
) -> Result<SelfcalResult, SelfcalError> {
    let spectra = head_spectra(heads, turns)?;
    let (ns, theta0) = (spectra.ns, spectra.theta0_deg);
    if options.reference_heads.is_empty() {
        return Err(SelfcalError::Reference {
            message: "expected at least one reference head".into(),
        });
    }
    if let Some(&r) = options.reference_heads.iter().find(|&&r| r >= heads.len()) {
        return Err(SelfcalError::Reference {
            message: format!("head {} does not exist ({} heads)", r + 1, heads.len()),
        });
    }
    let (nbins, nyquist) = (spectra.nbins, spectra.nyquist);
    let (table, method_name) = bin_table(heads, options.method, nbins, nyquist)?;
    let m1 = table.m1;
    let nt = turns.len();
    let nsf = ns as f64;

    // Reference filter f_k = mean_r e^{ikφ_r}.
    let refs: Vec<f64> = options
        .reference_heads
        .iter()
        .map(|&r| heads.angles_deg()[r])
        .collect();
    let mut filt = scratch::complex(nbins);
    for (k, f) in filt.iter_mut().enumerate() {
        *f = refs.iter().map(|&p| w_of(k as f64, p) + 1.0).sum::<C64>() / refs.len() as f64;
    }
    // Weight of bin k in the full (two-sided) spectrum.
    let bin_weight = |k: usize| -> f64 {
        if k == 0 || Some(k) == nyquist {
            1.0
        } else {
            2.0
        }
    };

    let c2r = scratch::inverse(ns);
    let mut scratch_i = scratch::complex(c2r.get_scratch_len());
    let mut ahat = scratch::complex(nbins);
    let mut spec_tmp = scratch::complex(nbins);
    let mut time_tmp = scratch::real(ns);
    let mut sum_spec = scratch::complex(nbins);
    let mut sum_a = scratch::real(ns);
    let mut sumsq_a = scratch::real(ns);
    let mut offsets = vec![0.0; m1];
    let mut rss_parseval = 0.0;
    let mut max_abs: f64 = 0.0;

    for dhat in &spectra.turns {
        for (c, d) in dhat.iter().enumerate() {
            offsets[c] += d[0].re / nsf / nt as f64;
        }
        ahat[0] = C64::new(0.0, 0.0);
        for k in 1..nbins {
            let v = &table.v[k * m1..(k + 1) * m1];
            ahat[k] = v.iter().zip(dhat).map(|(vc, d)| vc * d[k]).sum();
        }
        // Residuals: R_hk = D̂_hk − w_hk·Â_k (bin 0 absorbed by the offsets).
        for (c, d) in dhat.iter().enumerate() {
            spec_tmp[0] = C64::new(0.0, 0.0);
            for k in 1..nbins {
                let r = d[k] - table.w[k * m1 + c] * ahat[k];
                rss_parseval += bin_weight(k) * r.norm_sqr();
                spec_tmp[k] = r;
            }
            if let Some(nq) = nyquist {
                spec_tmp[nq].im = 0.0;
            }
            c2r.process_with_scratch(&mut spec_tmp, &mut time_tmp, &mut scratch_i)
                .expect("buffer sizes are the planner's");
            for x in &time_tmp {
                max_abs = max_abs.max((x / nsf).abs());
            }
        }
        // Output spectrum (reference filter) and its position-domain values.
        for k in 0..nbins {
            let o = filt[k] * ahat[k];
            sum_spec[k] += o;
            spec_tmp[k] = o;
        }
        spec_tmp[0].im = 0.0;
        if let Some(nq) = nyquist {
            spec_tmp[nq].im = 0.0;
        }
        c2r.process_with_scratch(&mut spec_tmp, &mut time_tmp, &mut scratch_i)
            .expect("buffer sizes are the planner's");
        for ((s, q), x) in sum_a.iter_mut().zip(sumsq_a.iter_mut()).zip(&time_tmp) {
            let a = x / nsf;
            *s += a;
            *q += a * a;
        }
    }

    // Noise gains and the expected residual trace per bin.
    let readings = options.noise_model == NoiseModel::Readings;
    let m1f = m1 as f64;
    let mut trace_sum = 0.0; // Σ_k weight·E|R_k|²/(NS σ²), per turn
    let mut gain_sum = 0.0; // Σ_k weight·g_k (output, chosen model)
    // Noise gains (differences, readings), unfiltered.
    let (mut gains_d, mut gains_r) = (scratch::real(nbins), scratch::real(nbins));
    for k in 1..nbins {
        let v = &table.v[k * m1..(k + 1) * m1];
        let w = &table.w[k * m1..(k + 1) * m1];
        let v2: f64 = v.iter().map(|x| x.norm_sqr()).sum();
        let vs: C64 = v.iter().sum();
        let ws: C64 = w.iter().sum();
        let s: f64 = w.iter().map(|x| x.norm_sqr()).sum();
        let vw: C64 = v.iter().zip(w).map(|(a, b)| a * b).sum();
        let g_d = v2;
        let g_r = v2 + vs.norm_sqr();
        (gains_d[k], gains_r[k]) = (g_d, g_r);
        // tr((I − w vᵀ) C (I − w vᵀ)ᴴ) for C = I, plus |(I − w vᵀ)1|² for C = I + 11ᵀ.
        let mut tr = m1f - 2.0 * vw.re + s * v2;
        if readings {
            tr += m1f - 2.0 * (vs * ws).re + s * vs.norm_sqr();
        }
        trace_sum += bin_weight(k) * tr;
        let f2 = filt[k].norm_sqr();
        gain_sum += bin_weight(k) * f2 * if readings { g_r } else { g_d };
    }
    let dof = trace_sum * nt as f64;
    let sigma2 = if dof > 0.0 {
        rss_parseval / (nsf * dof)
    } else {
        0.0
    };
    let u_res = (sigma2 * gain_sum / nsf / nt as f64).sqrt();
    let rms = (rss_parseval / nsf / (nsf * m1f * nt as f64)).sqrt();

    let u_turns = (nt >= 2).then(|| {
        let ntf = nt as f64;
        let pooled: f64 = sum_a
            .iter()
            .zip(&sumsq_a)
            .map(|(s, q)| ((q - s * s / ntf) / (ntf - 1.0)).max(0.0))
            .sum::<f64>()
            / nsf;
        (pooled / ntf).sqrt()
    });
    let (u, nu, source) = match u_turns {
        Some(ut) => (ut, (nt - 1) as f64, "repeated turns"),
        None => (u_res, dof, "residuals"),
    };
    let step = 360.0 / nsf;
    let errors = sum_a
        .iter()
        .enumerate()
        .map(|(i, s)| ErrorPoint {
            position_deg: gonio_core::Degrees(theta0 + i as f64 * step).normalized().0,
            value_arcsec: s / nt as f64,
            u_arcsec: u,
            nu_eff: nu,
        })
        .collect();

    let max_order = options.max_order.min(((ns - 1) / 2) as u32);
    let sigma_turn_mean = (sigma2 / nt as f64).sqrt();
    let mut harmonics = Vec::with_capacity(max_order as usize);
    let mut undetectable_orders = Vec::new();
    for order in 1..=max_order {
        let k = order as usize;
        let x = sum_spec[k] / nt as f64;
        let ph = -(order as f64) * theta0.to_radians();
        let c = x * 2.0 / nsf * C64::new(ph.cos(), ph.sin());
        let h = Harmonic::from_cos_sin(order, c.re, -c.im);
        let det = table.detectable[k];
        if !det {
            undetectable_orders.push(order);
        }
        let f2 = filt[k].norm_sqr();
        let g = if readings { gains_r[k] } else { gains_d[k] };
        harmonics.push(HarmonicRow {
            order,
            amplitude_arcsec: h.amplitude,
            phase_rad: h.phase_rad,
            detectable: det,
            noise_gain: if det { gains_d[k] } else { 0.0 },
            noise_gain_readings: if det { gains_r[k] } else { 0.0 },
            u_coefficient_arcsec: sigma_turn_mean * (2.0 * f2 * g / nsf).sqrt(),
        });
    }

    spectra.recycle();
    for v in [table.v, table.w, filt, scratch_i, ahat, spec_tmp, sum_spec] {
        scratch::give_complex(v);
    }
    for v in [time_tmp, sum_a, sumsq_a, gains_d, gains_r] {
        scratch::give_real(v);
    }
    Ok(SelfcalResult {
        method: method_name.to_string(),
        heads_deg: heads.angles_deg().to_vec(),
        reference_heads: options.reference_heads.iter().map(|r| r + 1).collect(),
        positions: ns,
        turns: nt,
        noise_model: options.noise_model,
        errors,
        harmonics,
        undetectable_orders,
        max_order,
        head_offsets_arcsec: offsets,
        residuals: Residuals {
            rms_arcsec: rms,
            max_abs_arcsec: max_abs,
            dof,
            sigma_arcsec: sigma2.sqrt(),
        },
        uncertainty: UncertaintyInfo {
            source: source.to_string(),
            u_residuals_arcsec: u_res,
            u_turns_arcsec: u_turns,
        },
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn raw_readings_give_differences() {
        let heads = Heads::preset("eda:3").unwrap();
        let t = Turn::from_raw(
            &heads,
            vec![0.0, 1.0],
            &[
                vec![0.0, 1.0],
                vec![120.0 + 1.0 / 3600.0, 121.0],
                vec![-120.0 - 2.0 / 3600.0, 241.0 + 0.5 / 3600.0],
            ],
        )
        .unwrap();
        assert!((t.differences_arcsec[0][0] - 1.0).abs() < 1e-9);
        assert!((t.differences_arcsec[1][0] + 2.0).abs() < 1e-9);
        assert!((t.differences_arcsec[1][1] - 0.5).abs() < 1e-9);
    }
}
