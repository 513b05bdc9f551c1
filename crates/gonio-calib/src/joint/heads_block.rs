//! The read heads' block of the joint least squares: per-harmonic generalised least squares on
//! the spectra of the head differences (diagonal in the harmonic order, so no position-domain
//! matrix is ever formed).
//!
//! For order k the differences' spectrum is `D̂(k) = w_k·A(k) + noise`, `w_hk = e^{ikφ_h} − 1`,
//! with noise covariance `NS·σ²·Σ̃` over the M−1 channels: `Σ̃ = I` when each difference has its
//! own noise, `Σ̃ = I + 11ᵀ` when each head reading has (head 1's noise is in every difference).
//! The weighted least-squares estimate and its information are
//!
//! ```text
//! Â(k) = w_kᴴ Σ̃⁻¹ D̄(k) / q_k,      q_k = w_kᴴ Σ̃⁻¹ w_k,      Σ̃⁻¹ = I − 11ᵀ/M  (readings)
//! ```
//!
//! (for `Σ̃ = I` this is the self-calibration's Fourier least squares). Each real coefficient of
//! order k (cos and sin) then has variance `g_k·σ²` with `g_k = 2/(NS·turns·q_k)`, independent of
//! every other order; k is invisible to the heads when `q_k` vanishes for the nominal angles.
//!
//! Head angles: with [`HeadAngles::Measured`] the phasors use φ_h + c_h, the nominal angle plus
//! the head's mean difference to head 1 (which is its angular displacement when the heads read
//! one graduation with a common zero, as differences of raw readings do). A displacement of a few
//! arcseconds turns into a phase error k·δ that matters at high orders, where a random
//! graduation error has as much content as at low ones.
//!
//! Between rotation positions: a head that does not sit on a sampled position reads the scale
//! between two of them. With [`Interpolation::Linear`] the error varies linearly between
//! neighbouring positions (as between the lines of gonio's encoder model when the positions are
//! the lines), so for a head at φ = (j + f)·Δ
//!
//! ```text
//! w_hk = (1 − f)·(e^{ikjΔ} − 1) + f·(e^{ik(j+1)Δ} − 1)
//! ```
//!
//! exactly, for every order up to NS/2; [`Interpolation::Trigonometric`] takes the error as a
//! band-limited series, `w_hk = e^{ikφ} − 1` (the self-calibration's model). The two agree to
//! O((kΔ)²) and are identical for heads on positions.

use super::{HeadAngles, Interpolation};
use crate::selfcal::{
    HeadSpectra, Heads, MAX_NOISE_GAIN, NoiseModel, SelfcalError, Turn, head_spectra, phasor_table,
};
use realfft::RealFftPlanner;
use realfft::num_complex::Complex;

type C64 = Complex<f64>;

/// The heads' sufficient statistics for the joint solve (σ = 1 units where a variance is meant).
pub(crate) struct HeadsBlock {
    /// Rotation positions per turn NS (the encoder grid).
    pub ns: usize,
    /// First grid position, degrees.
    pub theta0_deg: f64,
    /// Bins 0..=NS/2.
    pub nbins: usize,
    /// Per order k (index k < nbins): variance of each real coefficient per unit σ², `g_k`;
    /// 0 where the heads are blind (and at 0 and the Nyquist order, which are not estimated).
    pub gain: Vec<f64>,
    /// Per order k: the heads-alone (cos, sin) coefficients in the physical angle, arcsec.
    pub coef: Vec<(f64, f64)>,
    /// Per order k: the heads-alone spectrum in the grid's phase, `Â(k)` (unnormalised DFT).
    spectrum: Vec<C64>,
    /// Head offsets c_h of heads 2..M, arcsec.
    pub offsets_arcsec: Vec<f64>,
    /// Weighted residual sum of squares of the heads-alone fit (σ = 1 units of Σ̃).
    pub rss: f64,
    /// Its degrees of freedom.
    pub dof: usize,
    /// Readings per position (M − 1 differences) times positions times turns.
    pub count: usize,
}

impl HeadsBlock {
    /// Transforms and fits the head readings.
    pub(crate) fn new(
        heads: &Heads,
        turns: &[Turn],
        model: NoiseModel,
        angles: HeadAngles,
        interpolation: Interpolation,
    ) -> Result<HeadsBlock, SelfcalError> {
        let sp: HeadSpectra = head_spectra(heads, turns)?;
        let (ns, nbins) = (sp.ns, sp.nbins);
        let m1 = heads.len() - 1;
        let heads_f = heads.len() as f64;
        let nt = sp.turns.len();
        let (nsf, ntf) = (ns as f64, nt as f64);
        let nominal = phasor_table(&heads.angles_deg()[1..], nbins);
        let offsets: Vec<f64> = (0..m1)
            .map(|c| sp.turns.iter().map(|t| t[c][0].re).sum::<f64>() / (nsf * ntf))
            .collect();
        let mut phi = heads.angles_deg()[1..].to_vec();
        if angles == HeadAngles::Measured {
            for (x, o) in phi.iter_mut().zip(&offsets) {
                *x += o / 3600.0;
            }
        }
        let w = match interpolation {
            Interpolation::Trigonometric => phasor_table(&phi, nbins),
            Interpolation::Linear => {
                let step = 360.0 / nsf;
                let pos: Vec<f64> = phi.iter().map(|p| p / step).collect();
                let lo: Vec<f64> = pos.iter().map(|p| p.floor() * step).collect();
                let hi: Vec<f64> = pos.iter().map(|p| (p.floor() + 1.0) * step).collect();
                let frac: Vec<f64> = pos.iter().map(|p| p - p.floor()).collect();
                let (wl, wh) = (phasor_table(&lo, nbins), phasor_table(&hi, nbins));
                (0..nbins * m1)
                    .map(|i| {
                        let f = frac[i % m1];
                        wl[i] * (1.0 - f) + wh[i] * f
                    })
                    .collect()
            }
        };
        let readings = model == NoiseModel::Readings;
        // |x|² in the metric Σ̃⁻¹.
        let norm2 = |x: &[C64]| -> f64 {
            let s: f64 = x.iter().map(|z| z.norm_sqr()).sum();
            if readings {
                s - x.iter().sum::<C64>().norm_sqr() / heads_f
            } else {
                s
            }
        };
        let mut gain = vec![0.0; nbins];
        let mut spectrum = vec![C64::new(0.0, 0.0); nbins];
        let mut coef = vec![(0.0, 0.0); nbins];
        let mut offsets_arcsec = vec![0.0; m1];
        let mut rss = 0.0;
        let mut fitted = 0usize;
        let mut dbar = vec![C64::new(0.0, 0.0); m1];
        let mut dev = vec![C64::new(0.0, 0.0); m1];
        for k in 0..nbins {
            for (c, d) in dbar.iter_mut().enumerate() {
                *d = sp.turns.iter().map(|t| t[c][k]).sum::<C64>() / ntf;
            }
            // Scatter of the turns about their mean (zero for one turn).
            let mut scatter = 0.0;
            if nt > 1 {
                for t in &sp.turns {
                    for (c, e) in dev.iter_mut().enumerate() {
                        *e = t[c][k] - dbar[c];
                    }
                    scatter += norm2(&dev);
                }
            }
            let weight = if k == 0 || Some(k) == sp.nyquist {
                1.0
            } else {
                2.0
            };
            if k == 0 {
                // The offsets absorb the mean of every channel.
                offsets_arcsec.copy_from_slice(&offsets);
                rss += weight * scatter;
                continue;
            }
            let wk = &w[k * m1..(k + 1) * m1];
            let q = norm2(wk);
            let sees = norm2(&nominal[k * m1..(k + 1) * m1]) * MAX_NOISE_GAIN >= 1.0;
            let resid = if Some(k) != sp.nyquist && sees {
                let ws: C64 = wk.iter().sum();
                let ds: C64 = dbar.iter().sum();
                let mut inner: C64 = wk.iter().zip(&dbar).map(|(a, d)| a.conj() * d).sum();
                if readings {
                    inner -= ws.conj() * ds / heads_f;
                }
                let a = inner / q;
                spectrum[k] = a;
                gain[k] = 2.0 / (nsf * ntf * q);
                let ph = -(k as f64) * sp.theta0_deg.to_radians();
                let b = a * C64::new(ph.cos(), ph.sin()) * (2.0 / nsf);
                coef[k] = (b.re, -b.im);
                fitted += 1;
                (norm2(&dbar) - q * a.norm_sqr()).max(0.0)
            } else {
                norm2(&dbar)
            };
            rss += weight * (scatter + ntf * resid);
        }
        let count = nt * ns * m1;
        Ok(HeadsBlock {
            ns,
            theta0_deg: sp.theta0_deg,
            nbins,
            gain,
            coef,
            spectrum,
            offsets_arcsec,
            rss: rss / nsf,
            dof: count.saturating_sub(m1 + 2 * fitted),
            count,
        })
    }

    /// Grid step 360°/NS, degrees.
    pub(crate) fn step_deg(&self) -> f64 {
        360.0 / self.ns as f64
    }

    /// σ̂ of one reading from the heads-alone residuals (NaN without degrees of freedom).
    pub(crate) fn sigma_hat(&self) -> f64 {
        if self.dof > 0 {
            (self.rss / self.dof as f64).sqrt()
        } else {
            f64::NAN
        }
    }

    /// Whether the heads see order k (k < nbins).
    pub(crate) fn sees(&self, k: usize) -> bool {
        self.gain.get(k).is_some_and(|&g| g > 0.0)
    }

    /// The covariance kernel of the heads-alone estimate per unit σ²: `c(m) = Σ_k g_k·cos(2πkm/NS)`
    /// for grid offsets m = 0..NS, and the heads-alone estimate â at every grid position, arcsec.
    pub(crate) fn kernel_and_estimate(&self) -> (Vec<f64>, Vec<f64>) {
        let mut planner = RealFftPlanner::<f64>::new();
        let c2r = planner.plan_fft_inverse(self.ns);
        let mut scratch = c2r.make_scratch_vec();
        let mut spec = c2r.make_input_vec();
        let mut kernel = c2r.make_output_vec();
        for (s, &g) in spec.iter_mut().zip(&self.gain) {
            *s = C64::new(0.5 * g, 0.0);
        }
        c2r.process_with_scratch(&mut spec, &mut kernel, &mut scratch)
            .expect("buffer sizes are the planner's");
        let mut estimate = c2r.make_output_vec();
        spec.copy_from_slice(&self.spectrum);
        c2r.process_with_scratch(&mut spec, &mut estimate, &mut scratch)
            .expect("buffer sizes are the planner's");
        let nsf = self.ns as f64;
        for e in &mut estimate {
            *e /= nsf;
        }
        (kernel, estimate)
    }
}
