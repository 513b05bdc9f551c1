//! Building a certificate: one function per method, and the one place where the instrument terms
//! are combined with an estimator's random part into u, ν_eff, k and U.

use super::JointSection;
use super::{
    AnglePoint, CERTIFICATE_FORMAT, Certificate, CertificateError, CompensationRow, InstrumentTerm,
    InvisibleOrders, PitchDeviation, Procedure, Residuals, SelfcalSection, ShiftAngleSection,
    Software, Spectrum, SpectrumLine, UncertaintySummary,
};
use crate::joint::JointCalibration;
use crate::selfcal::{NoiseModel, SelfcalResult};
use crate::shift_angle::{Calibration, ReadingSet, harmonic_check};
use gonio_core::HarmonicFitSpec;
use gonio_uncertainty::instrument::InstrumentFile;
use gonio_uncertainty::student::coverage_factor;
use gonio_uncertainty::{BudgetResult, Combined};

/// The instrument terms of a calibration and where they came from.
///
/// ```
/// use gonio_calib::certificate::Instrument;
/// let i = Instrument::default().with_coverage(0.99).unwrap();
/// assert_eq!(i.terms.coverage, 0.99);
/// assert!(Instrument::default().with_coverage(1.5).is_err());
/// ```
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Instrument {
    /// The terms and the coverage probability (no terms and p = 0.95 by default).
    pub terms: InstrumentFile,
    /// The file they were read from, for the record.
    pub source: Option<String>,
}

impl Instrument {
    /// Terms read from `source`.
    pub fn new(terms: InstrumentFile, source: Option<String>) -> Self {
        Instrument { terms, source }
    }

    /// The same terms at coverage probability `p`.
    ///
    /// # Errors
    /// [`CertificateError::BadCoverage`] for p outside (0, 1).
    pub fn with_coverage(mut self, p: f64) -> Result<Self, CertificateError> {
        if !(p > 0.0 && p < 1.0) {
            return Err(CertificateError::BadCoverage { coverage: p });
        }
        self.terms.coverage = p;
        Ok(self)
    }

    /// `source`, followed by the instrument terms' origin when there are terms.
    fn with_terms(&self, source: String) -> String {
        if self.terms.contributions.is_empty() {
            return source;
        }
        match &self.source {
            Some(f) => format!("{source} + instrument terms ({f})"),
            None => format!("{source} + instrument terms"),
        }
    }

    fn summary(&self, source: String, random_dof: f64) -> UncertaintySummary {
        UncertaintySummary {
            source,
            coverage: self.terms.coverage,
            random_dof,
            instrument_file: self.source.clone(),
            instrument_terms: self
                .terms
                .contributions
                .iter()
                .map(|c| InstrumentTerm {
                    name: c.name.clone(),
                    u: c.u,
                    c: c.sensitivity,
                    nu: c.nu,
                })
                .collect(),
            u_residuals_arcsec: None,
            u_turns_arcsec: None,
        }
    }
}

/// Combines random parts with the instrument terms, remembering the last combination (every
/// self-calibration position, and most shift-angle angles, share one random part).
struct Attach<'a> {
    instrument: &'a Instrument,
    last: Option<((u64, u64), Option<Combined>)>,
}

impl<'a> Attach<'a> {
    fn new(instrument: &'a Instrument) -> Self {
        Attach {
            instrument,
            last: None,
        }
    }

    /// u_c, ν_eff, k, U for a random part u (ν degrees of freedom); `None` when u is unknown
    /// (NaN: no residual degrees of freedom and no stated σ).
    fn combine(
        &mut self,
        u_random: f64,
        nu_random: f64,
    ) -> Result<Option<Combined>, CertificateError> {
        let key = (u_random.to_bits(), nu_random.to_bits());
        if let Some((k, c)) = self.last
            && k == key
        {
            return Ok(c);
        }
        let c = if !u_random.is_finite() || nu_random.is_nan() || nu_random <= 0.0 {
            None
        } else {
            Some(self.instrument.terms.combine(u_random, nu_random)?)
        };
        self.last = Some((key, c));
        Ok(c)
    }

    /// The certificate point of an estimate: the one place U is attached.
    fn point(
        &mut self,
        angle_deg: f64,
        value_arcsec: f64,
        u_random: f64,
        nu_random: f64,
    ) -> Result<AnglePoint, CertificateError> {
        let c = self.combine(u_random, nu_random)?;
        Ok(AnglePoint {
            angle_deg,
            value_arcsec,
            u_arcsec: c.map_or(u_random, |c| c.u_c),
            u_random_arcsec: u_random,
            expanded_arcsec: c.map(|c| c.expanded),
            k: c.map(|c| c.k),
            nu_eff: c.map(|c| c.nu_eff),
            p: c.map(|c| c.coverage),
            shift_deg: None,
            step: None,
        })
    }

    /// The budget table of the point with the largest U (or u when none has U).
    fn budget(&self, points: &[AnglePoint], nu_random: f64) -> Option<BudgetResult> {
        self.budget_with(points, |_| nu_random)
    }

    /// As [`Attach::budget`], with the random part's ν of each point (by index).
    fn budget_with(
        &self,
        points: &[AnglePoint],
        nu_of: impl Fn(usize) -> f64,
    ) -> Option<BudgetResult> {
        let (index, worst) = points.iter().enumerate().max_by(|(_, a), (_, b)| {
            let key = |p: &AnglePoint| p.expanded_arcsec.unwrap_or(p.u_arcsec);
            key(a).total_cmp(&key(b))
        })?;
        let nu_random = nu_of(index);
        if !worst.u_random_arcsec.is_finite() || nu_random.is_nan() || nu_random <= 0.0 {
            return None;
        }
        let name = format!("α at {}°", trim_angle(worst.angle_deg));
        self.instrument
            .terms
            .budget(
                &name,
                "random part (estimator)",
                worst.u_random_arcsec,
                nu_random,
            )
            .evaluate(self.instrument.terms.coverage)
            .ok()
    }
}

fn trim_angle(a: f64) -> String {
    let s = format!("{a:.6}");
    s.trim_end_matches('0').trim_end_matches('.').to_string()
}

fn compensation(points: &[AnglePoint]) -> Vec<CompensationRow> {
    points
        .iter()
        .map(|p| CompensationRow {
            angle_deg: p.angle_deg,
            correction_arcsec: -p.value_arcsec,
        })
        .collect()
}

/// The pitch deviations β with their u and U = k·u (random part only).
fn pitch_rows(beta: &[f64], u_beta: &[f64], k: f64) -> Vec<PitchDeviation> {
    beta.iter()
        .zip(u_beta)
        .enumerate()
        .map(|(i, (&v, &u))| PitchDeviation {
            face: i + 1,
            value_arcsec: v,
            u_arcsec: u,
            expanded_arcsec: finite(k * u),
            k: finite(k),
        })
        .collect()
}

fn finite(v: f64) -> Option<f64> {
    v.is_finite().then_some(v)
}

/// Highest order of a certificate's spectrum (one cycle a degree).
pub const MAX_SPECTRUM_ORDER: u32 = 360;

/// The harmonic spectrum of α from its values at the calibrated angles (least squares over
/// orders 1…K, with K below the grid's Nyquist order and at most [`MAX_SPECTRUM_ORDER`]; the
/// orders `invisible` lists are marked).
fn spectrum_of(points: &[AnglePoint], invisible: InvisibleOrders) -> Spectrum {
    let n = points.len();
    let theta: Vec<f64> = points.iter().map(|p| p.angle_deg.to_radians()).collect();
    let y: Vec<f64> = points.iter().map(|p| p.value_arcsec).collect();
    let u2: Vec<f64> = points
        .iter()
        .map(|p| p.u_random_arcsec.powi(2))
        .filter(|v| v.is_finite())
        .collect();
    let sigma = (!u2.is_empty()).then(|| (u2.iter().sum::<f64>() / u2.len() as f64).sqrt());
    let step = 360.0 / n.max(1) as f64;
    let uniform = points
        .iter()
        .enumerate()
        .all(|(i, p)| (p.angle_deg - points[0].angle_deg - i as f64 * step).abs() < 1e-6);
    let mut kmax = if uniform {
        n.saturating_sub(1) / 2
    } else {
        n.saturating_sub(1) / 4
    } as u32;
    // At most one order a degree: the fit is a dense least squares (n × K), and a 1,000-face
    // polygon at 10 shifts (10,000 angles) would otherwise ask for 5,000 orders: minutes and
    // gigabytes for lines no certificate reader uses.
    kmax = kmax.min(MAX_SPECTRUM_ORDER);
    let hidden = |k: u32| invisible.orders.contains(&k);
    while kmax >= 1 {
        let orders: Vec<u32> = (1..=kmax).filter(|&k| !hidden(k)).collect();
        if let Ok(fit) = HarmonicFitSpec::new(&orders).fit(&theta, &y, sigma) {
            let lines = (1..=kmax)
                .map(|k| match fit.harmonic(k) {
                    Some(h) => SpectrumLine {
                        order: k,
                        amplitude_arcsec: h.amplitude,
                        u_amplitude_arcsec: fit.harmonic_uncertainty(k).map_or(f64::NAN, |u| u.0),
                        phase_rad: h.phase_rad,
                        visible: true,
                    },
                    None => SpectrumLine {
                        order: k,
                        amplitude_arcsec: 0.0,
                        u_amplitude_arcsec: f64::NAN,
                        phase_rad: 0.0,
                        visible: false,
                    },
                })
                .collect();
            let orders = invisible
                .orders
                .iter()
                .copied()
                .filter(|&k| k <= kmax)
                .collect();
            return Spectrum {
                lines,
                invisible: vec![InvisibleOrders {
                    by: invisible.by,
                    orders,
                }],
            };
        }
        kmax /= 2;
    }
    Spectrum {
        lines: Vec::new(),
        invisible: vec![invisible],
    }
}

impl Certificate {
    /// The certificate of a shift-angle calibration (Hsieh et al., 2022).
    ///
    /// The random part of every α is the estimator's standard uncertainty with the residual
    /// degrees of freedom (∞ when `sigma_stated`: σ was given, not estimated); the instrument
    /// terms are combined with it into u_c, ν_eff, k and U at the instrument's coverage.
    /// `check_order` is the order of the harmonic check of the setup error (2 in the paper).
    ///
    /// # Errors
    /// [`CertificateError::Empty`] without calibrated angles;
    /// [`CertificateError::Uncertainty`] for an invalid instrument term.
    pub fn from_shift_angle(
        cal: &Calibration,
        set: &ReadingSet,
        sigma_stated: bool,
        check_order: u32,
        instrument: &Instrument,
    ) -> Result<Certificate, CertificateError> {
        let random_dof = if sigma_stated {
            f64::INFINITY
        } else {
            cal.residuals.dof as f64
        };
        let mut attach = Attach::new(instrument);
        let merged = cal.merged();
        if merged.is_empty() {
            return Err(CertificateError::Empty);
        }
        let mut points = Vec::with_capacity(merged.len());
        for m in &merged {
            let mut p = attach.point(m.angle_deg, m.value_arcsec, m.u_arcsec, random_dof)?;
            p.shift_deg = Some(m.shift_deg);
            p.step = Some(m.step);
            points.push(p);
        }
        let pitch_deviations = pitch_rows(
            &cal.beta_arcsec,
            &cal.u_beta_arcsec,
            coverage_factor(instrument.terms.coverage, random_dof),
        );
        let sigma_source = if sigma_stated { "stated" } else { "residuals" };
        let source = format!(
            "{} covariance, σ {}",
            cal.method.name(),
            if sigma_stated {
                "stated"
            } else {
                "from the residuals"
            }
        );
        let spectrum = spectrum_of(
            &points,
            InvisibleOrders {
                by: format!("{}-face polygon", cal.faces),
                orders: cal.undetectable_harmonics.clone(),
            },
        );
        Ok(Certificate {
            format: CERTIFICATE_FORMAT.into(),
            procedure: Procedure::ShiftAngle,
            method: cal.method.name().into(),
            budget: attach.budget(&points, random_dof),
            compensation: compensation(&points),
            residuals: Residuals {
                rms_arcsec: cal.residuals.rms_arcsec,
                max_abs_arcsec: cal.residuals.max_abs_arcsec,
                dof: cal.residuals.dof as f64,
                count: Some(cal.residuals.count),
                sigma_hat_arcsec: finite(cal.residuals.sigma_hat_arcsec),
                sigma_arcsec: finite(cal.residuals.sigma_hat_arcsec),
                chi2: cal.residuals.chi2,
            },
            uncertainty: instrument.summary(source, random_dof),
            undetectable_orders: cal.undetectable_harmonics.clone(),
            spectrum,
            points,
            shift_angle: Some(ShiftAngleSection {
                faces: cal.faces,
                readings: set.len(),
                shifts_deg: set.shifts_deg().to_vec(),
                sigma_arcsec: finite(cal.sigma_used_arcsec),
                sigma_source: sigma_source.into(),
                pitch_deviations,
                setup_errors: cal.setup.clone(),
                harmonic_check: harmonic_check(cal, check_order).ok(),
                duplicates_ignored: cal.duplicates_ignored,
                reading_residuals_arcsec: cal.reading_residuals(set),
            }),
            selfcal: None,
            joint: None,
            software: Software::default(),
            meta: None,
        })
    }

    /// The certificate of a self-calibration.
    ///
    /// The random part of every a(θ) is the result's u with its degrees of freedom (residual
    /// degrees of freedom, or turns − 1 with repeated turns); the instrument terms are combined
    /// with it at the instrument's coverage.
    ///
    /// # Errors
    /// [`CertificateError::Empty`] without positions;
    /// [`CertificateError::Uncertainty`] for an invalid instrument term.
    pub fn from_selfcal(
        r: &SelfcalResult,
        instrument: &Instrument,
    ) -> Result<Certificate, CertificateError> {
        if r.errors.is_empty() {
            return Err(CertificateError::Empty);
        }
        let mut attach = Attach::new(instrument);
        let mut points = Vec::with_capacity(r.errors.len());
        for e in &r.errors {
            points.push(attach.point(e.position_deg, e.value_arcsec, e.u_arcsec, e.nu_eff)?);
        }
        points.sort_by(|a, b| a.angle_deg.total_cmp(&b.angle_deg));
        let random_dof = r.errors[0].nu_eff;
        let source = instrument.with_terms(r.uncertainty.source.clone());
        let mut uncertainty = instrument.summary(source, random_dof);
        uncertainty.u_residuals_arcsec = Some(r.uncertainty.u_residuals_arcsec);
        uncertainty.u_turns_arcsec = r.uncertainty.u_turns_arcsec;
        let m = r.heads_deg.len();
        let heads = if r.method == "selfcal-selfa" {
            format!("{m} read heads (SelfA)")
        } else {
            format!("{m} read heads")
        };
        let spectrum = Spectrum {
            lines: r
                .harmonics
                .iter()
                .map(|h| SpectrumLine {
                    order: h.order,
                    amplitude_arcsec: h.amplitude_arcsec,
                    u_amplitude_arcsec: h.u_coefficient_arcsec,
                    phase_rad: h.phase_rad,
                    visible: h.detectable,
                })
                .collect(),
            invisible: vec![InvisibleOrders {
                by: heads,
                orders: r.undetectable_orders.clone(),
            }],
        };
        Ok(Certificate {
            format: CERTIFICATE_FORMAT.into(),
            procedure: Procedure::SelfCalibration,
            method: r.method.clone(),
            budget: attach.budget(&points, random_dof),
            compensation: compensation(&points),
            residuals: Residuals {
                rms_arcsec: r.residuals.rms_arcsec,
                max_abs_arcsec: r.residuals.max_abs_arcsec,
                dof: r.residuals.dof,
                count: Some(r.positions * m.saturating_sub(1) * r.turns),
                sigma_hat_arcsec: finite(r.residuals.sigma_arcsec),
                sigma_arcsec: finite(r.residuals.sigma_arcsec),
                chi2: None,
            },
            uncertainty,
            undetectable_orders: r.undetectable_orders.clone(),
            spectrum,
            points,
            shift_angle: None,
            selfcal: Some(SelfcalSection {
                heads_deg: r.heads_deg.clone(),
                reference_heads: r.reference_heads.clone(),
                positions: r.positions,
                turns: r.turns,
                noise_model: r.noise_model,
                harmonics: r.harmonics.clone(),
                max_order: r.max_order,
                head_offsets_arcsec: r.head_offsets_arcsec.clone(),
            }),
            joint: None,
            software: Software::default(),
            meta: None,
        })
    }

    /// The certificate of a joint calibration (the polygon and the read heads in one least
    /// squares, [`crate::joint`]).
    ///
    /// The random part of every α is the joint estimate's standard uncertainty with its
    /// Welch–Satterthwaite degrees of freedom over the two instruments' σ (each stated, ν = ∞, or
    /// estimated from its own residuals); the instrument terms are combined with it at the
    /// instrument's coverage. The spectrum marks the orders each instrument cannot see and the
    /// orders invisible to both.
    ///
    /// # Errors
    /// [`CertificateError::Empty`] without calibrated angles;
    /// [`CertificateError::Uncertainty`] for an invalid instrument term.
    pub fn from_joint(
        cal: &JointCalibration,
        instrument: &Instrument,
    ) -> Result<Certificate, CertificateError> {
        if cal.alpha.is_empty() {
            return Err(CertificateError::Empty);
        }
        let mut attach = Attach::new(instrument);
        let mut points = Vec::with_capacity(cal.alpha.len());
        for a in &cal.alpha {
            points.push(attach.point(a.angle_deg, a.value_arcsec, a.u_arcsec, a.nu_eff)?);
        }
        let random_dof = cal
            .alpha
            .iter()
            .map(|a| a.nu_eff)
            .fold(f64::INFINITY, f64::min);
        let sp = cal.sigma_polygon;
        let pitch_deviations = pitch_rows(
            &cal.beta_arcsec,
            &cal.u_beta_arcsec,
            coverage_factor(instrument.terms.coverage, sp.dof),
        );
        let sigma_text = |s: &crate::joint::SigmaUsed| {
            if s.stated {
                "stated".to_string()
            } else {
                format!("from its residuals (ν = {})", s.dof)
            }
        };
        let source = instrument.with_terms(format!(
            "joint least-squares covariance; polygon σ {}, heads σ {}; ν per angle by Welch–Satterthwaite",
            sigma_text(&sp),
            sigma_text(&cal.sigma_heads)
        ));
        let m = cal.heads_deg.len();
        let spectrum = Spectrum {
            lines: cal
                .harmonics
                .iter()
                .map(|h| SpectrumLine {
                    order: h.order,
                    amplitude_arcsec: h.amplitude_arcsec,
                    u_amplitude_arcsec: if h.estimated {
                        (0.5 * (h.u_cos_arcsec.powi(2) + h.u_sin_arcsec.powi(2))).sqrt()
                    } else {
                        f64::NAN
                    },
                    phase_rad: h.phase_rad,
                    visible: h.estimated,
                })
                .collect(),
            invisible: vec![
                InvisibleOrders {
                    by: format!("{}-face polygon", cal.faces),
                    orders: cal.blind.polygon.clone(),
                },
                InvisibleOrders {
                    by: format!("{m} read heads"),
                    orders: cal.blind.heads.clone(),
                },
                InvisibleOrders {
                    by: "joint estimate (both instruments)".into(),
                    orders: cal.blind.joint.clone(),
                },
            ],
        };
        let budget = attach.budget_with(&points, |i| cal.alpha[i].nu_eff);
        Ok(Certificate {
            format: CERTIFICATE_FORMAT.into(),
            procedure: Procedure::Joint,
            method: "joint-least-squares".into(),
            budget,
            compensation: compensation(&points),
            residuals: Residuals {
                rms_arcsec: cal.residuals_polygon.rms_arcsec,
                max_abs_arcsec: cal.residuals_polygon.max_abs_arcsec,
                dof: sp.dof,
                count: Some(cal.residuals_polygon.count),
                sigma_hat_arcsec: (!sp.stated).then_some(sp.sigma_arcsec),
                sigma_arcsec: (!sp.stated).then_some(sp.sigma_arcsec),
                chi2: None,
            },
            uncertainty: instrument.summary(source, random_dof),
            undetectable_orders: cal.blind.joint.clone(),
            spectrum,
            points,
            shift_angle: None,
            selfcal: None,
            joint: Some(JointSection {
                faces: cal.faces,
                readings: cal.polygon_readings,
                shifts_deg: cal.shifts_deg.clone(),
                pitch_deviations,
                setup_errors: cal.setup.clone(),
                heads_deg: cal.heads_deg.clone(),
                positions: cal.positions,
                noise_model: cal.noise_model,
                head_angles: cal.head_angles,
                interpolation: cal.interpolation,
                head_offsets_arcsec: cal.head_offsets_arcsec.clone(),
                sigma_polygon: cal.sigma_polygon,
                sigma_heads: cal.sigma_heads,
                residuals_heads_rms_arcsec: cal.residuals_heads_rms_arcsec,
                random_part: cal.alpha.clone(),
                covariance_alpha_arcsec2: cal
                    .covariance_alpha
                    .row_iter()
                    .map(|r| r.iter().copied().collect())
                    .collect(),
                harmonics: cal.harmonics.clone(),
                blind_orders: cal.blind.clone(),
                consistency: cal.consistency,
            }),
            software: Software::default(),
            meta: None,
        })
    }

    /// What the noise model of a self-calibration certificate calls one reading (`reading` or
    /// `difference`); `None` for other procedures.
    pub fn noise_unit(&self) -> Option<&'static str> {
        self.selfcal.as_ref().map(|s| match s.noise_model {
            NoiseModel::Readings => "reading",
            NoiseModel::Differences => "difference",
        })
    }
}
