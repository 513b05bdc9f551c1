//! Instrument terms of a calibration (autocollimator, encoder, set-up, reading heads) read from a
//! TOML file and combined with the random part of each calibrated angle into u_c, ν_eff, k and U.
//!
//! The random part is a standard uncertainty with its degrees of freedom, typically the square
//! root of a diagonal element of the least-squares covariance of the estimator (ν = number of
//! observations − number of parameters). Each instrument section is one contribution, written in
//! the same syntax as a budget contribution (see `docs/budget-format.md`); every section is
//! optional, and `[[contribution]]` tables add any other term:
//!
//! ```toml
//! coverage = 0.95          # optional (default 0.95)
//! unit = "arcsec"          # optional (default "arcsec"); every u below is in this unit
//! [autocollimator_resolution]
//! distribution = "resolution"
//! step = 0.001
//! relative_uncertainty = 0.10
//! [autocollimator_certificate]
//! distribution = "normal"
//! expanded = 0.01
//! k = 2
//! [[contribution]]
//! name = "thermal drift"
//! distribution = "rectangular"
//! half_width = 0.002
//! ```
//!
//! Sections: `autocollimator_resolution`, `autocollimator_certificate`,
//! `autocollimator_linearity`, `encoder_resolution`, `setup_residual`, `polygon_setup`,
//! `head_noise`. A section's name defaults to the section key with spaces.
//!
//! ```
//! use gonio_uncertainty::instrument::InstrumentFile;
//! let inst = InstrumentFile::parse("[encoder_resolution]\ndistribution = \"resolution\"\nstep = 0.04\nrelative_uncertainty = 0.1\n").unwrap();
//! // Random part from the estimator: 0.0041″ with 5 degrees of freedom.
//! let r = inst.combine(0.0041, 5.0).unwrap();
//! assert!((r.u_c - (0.0041f64.powi(2) + 0.04f64.powi(2) / 12.0).sqrt()).abs() < 1e-15);
//! assert_eq!(r.nu_eff, 54.0);
//! ```

use crate::budget::{Budget, Combined, Contribution, Source, Term, combine};
use crate::file::{
    BudgetFileError, RawContribution, build_contribution, decode_text, err_at, toml_error,
};
use crate::limits::MAX_ROWS;
use crate::{UncertaintyError, check_coverage, short};
use serde::Deserialize;
use toml::Spanned;

/// The named instrument sections, as (TOML key, display name).
pub const SECTIONS: [(&str, &str); 7] = [
    ("autocollimator_resolution", "autocollimator resolution"),
    ("autocollimator_certificate", "autocollimator certificate"),
    ("autocollimator_linearity", "autocollimator linearity"),
    ("encoder_resolution", "encoder resolution"),
    ("setup_residual", "setup residual"),
    ("polygon_setup", "polygon setup"),
    ("head_noise", "head noise"),
];

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawInstrument {
    coverage: Option<Spanned<f64>>,
    unit: Option<String>,
    autocollimator_resolution: Option<Spanned<RawContribution>>,
    autocollimator_certificate: Option<Spanned<RawContribution>>,
    autocollimator_linearity: Option<Spanned<RawContribution>>,
    encoder_resolution: Option<Spanned<RawContribution>>,
    setup_residual: Option<Spanned<RawContribution>>,
    polygon_setup: Option<Spanned<RawContribution>>,
    head_noise: Option<Spanned<RawContribution>>,
    #[serde(default)]
    contribution: Vec<Spanned<RawContribution>>,
}

/// An instrument file: coverage, unit and the instrument contributions, in section order then
/// `[[contribution]]` order.
#[derive(Debug, Clone, PartialEq)]
pub struct InstrumentFile {
    /// Coverage probability p (default 0.95).
    pub coverage: f64,
    /// Unit of every u (default `arcsec`).
    pub unit: String,
    /// The instrument terms (none of them is a nested budget).
    pub contributions: Vec<Contribution>,
}

impl Default for InstrumentFile {
    /// No instrument terms, p = 0.95, unit arcsec: the result is the random part alone.
    fn default() -> InstrumentFile {
        InstrumentFile {
            coverage: 0.95,
            unit: "arcsec".into(),
            contributions: Vec::new(),
        }
    }
}

impl InstrumentFile {
    /// Parses an instrument file.
    ///
    /// # Errors
    /// [`BudgetFileError`] at the offending line: TOML syntax, an unknown section or field, an
    /// unknown distribution, u < 0, ν ≤ 0, coverage outside (0, 1), or a `from` reference
    /// (instrument terms cannot be nested budgets), more than [`MAX_ROWS`] terms, or terms whose
    /// combination overflows (U = k·u_c beyond the floating-point range, at the largest term).
    pub fn parse(text: &str) -> Result<InstrumentFile, BudgetFileError> {
        let raw: RawInstrument = toml::from_str(text).map_err(|e| toml_error(text, e))?;
        if raw.contribution.len() > MAX_ROWS {
            return Err(err_at(
                text,
                &raw.contribution[MAX_ROWS].span(),
                format!(
                    "{} [[contribution]] tables, more than the limit of {MAX_ROWS}",
                    raw.contribution.len()
                ),
            ));
        }
        let coverage = match &raw.coverage {
            Some(c) => {
                check_coverage(*c.get_ref()).map_err(|e| err_at(text, &c.span(), e.to_string()))?
            }
            None => 0.95,
        };
        let sections = [
            &raw.autocollimator_resolution,
            &raw.autocollimator_certificate,
            &raw.autocollimator_linearity,
            &raw.encoder_resolution,
            &raw.setup_residual,
            &raw.polygon_setup,
            &raw.head_noise,
        ];
        let mut contributions: Vec<Contribution> = Vec::new();
        let mut spans = Vec::new();
        let mut names = std::collections::HashSet::new();
        let mut add = |rc: &Spanned<RawContribution>, default: Option<&str>| {
            if let Some(f) = &rc.get_ref().from {
                return Err(err_at(
                    text,
                    &f.span(),
                    "an instrument term cannot refer to a budget (from): give u, a distribution or observations",
                ));
            }
            let c = build_contribution(text, rc, default)?;
            if !names.insert(c.name.clone()) {
                return Err(err_at(
                    text,
                    &rc.span(),
                    format!("duplicate instrument term '{}'", short(&c.name)),
                ));
            }
            spans.push(rc.span());
            contributions.push(c);
            Ok(())
        };
        for (sec, (_, display)) in sections.iter().zip(SECTIONS) {
            if let Some(rc) = sec {
                add(rc, Some(display))?;
            }
        }
        for rc in &raw.contribution {
            add(rc, None)?;
        }
        // The terms alone must combine to a finite U at the file's coverage (a random part of 0
        // only lowers ν_eff's denominator); otherwise name the largest term.
        if let Err(e) = combine_with_instrument(0.0, f64::INFINITY, &contributions, coverage) {
            let largest = contributions
                .iter()
                .enumerate()
                .max_by(|a, b| {
                    (a.1.sensitivity * a.1.u)
                        .abs()
                        .total_cmp(&(b.1.sensitivity * b.1.u).abs())
                })
                .map_or(0, |(i, _)| i);
            let span = spans.get(largest).cloned().unwrap_or(0..0);
            return Err(err_at(text, &span, e.to_string()));
        }
        Ok(InstrumentFile {
            coverage,
            unit: raw.unit.unwrap_or_else(|| "arcsec".into()),
            contributions,
        })
    }

    /// Parses an instrument file from its bytes ([`decode_text`]: UTF-8, a byte-order mark
    /// skipped, at most [`crate::limits::MAX_FILE_BYTES`]).
    ///
    /// # Errors
    /// As [`decode_text`] and [`parse`](Self::parse).
    pub fn parse_bytes(bytes: &[u8]) -> Result<InstrumentFile, BudgetFileError> {
        Self::parse(decode_text(bytes)?)
    }

    /// Combines a random part (standard uncertainty `u_random` with `nu_random` degrees of
    /// freedom, `f64::INFINITY` allowed) with the instrument terms at the file's coverage.
    ///
    /// # Errors
    /// As [`combine_with_instrument`].
    pub fn combine(&self, u_random: f64, nu_random: f64) -> Result<Combined, UncertaintyError> {
        combine_with_instrument(u_random, nu_random, &self.contributions, self.coverage)
    }

    /// As [`combine`](Self::combine) at coverage p.
    ///
    /// # Errors
    /// As [`combine_with_instrument`].
    pub fn combine_at(
        &self,
        u_random: f64,
        nu_random: f64,
        coverage: f64,
    ) -> Result<Combined, UncertaintyError> {
        combine_with_instrument(u_random, nu_random, &self.contributions, coverage)
    }

    /// The full budget for one angle (random part first, named `random_name`), for printing a
    /// table with [`Budget::evaluate`].
    pub fn budget(&self, name: &str, random_name: &str, u_random: f64, nu_random: f64) -> Budget {
        let mut b = Budget::new(name);
        b.unit = Some(self.unit.clone());
        b.push(Contribution::direct(random_name, u_random).with_dof(nu_random));
        b.contributions.extend(self.contributions.iter().cloned());
        b
    }
}

/// Combines the random part u_random (ν_random degrees of freedom) with instrument terms into
/// {u_c, ν_eff, ν_eff_raw, k, U} at coverage p (Welch–Satterthwaite, ν_eff truncated).
///
/// # Errors
/// [`UncertaintyError::BadUncertainty`] for u_random < 0 or not finite,
/// [`UncertaintyError::BadDof`] for ν_random ≤ 0, any invalid instrument term, a nested-budget
/// term ([`UncertaintyError::BadParameter`]), [`UncertaintyError::BadCoverage`],
/// [`UncertaintyError::NonFinite`] when c·u, u_c, k or U overflows.
///
/// ```
/// use gonio_uncertainty::{Contribution, instrument::combine_with_instrument};
/// let inst = [Contribution::direct("encoder resolution", 0.0101).with_dof(50.0)];
/// let r = combine_with_instrument(0.01 / 6f64.sqrt(), 5.0, &inst, 0.95).unwrap();
/// assert_eq!(r.nu_eff, 53.0); // Hsieh et al. (2022)'s self-calibration budget
/// ```
pub fn combine_with_instrument(
    u_random: f64,
    nu_random: f64,
    instrument: &[Contribution],
    coverage: f64,
) -> Result<Combined, UncertaintyError> {
    Contribution::direct("random part", u_random)
        .with_dof(nu_random)
        .validate()?;
    let mut terms = Vec::with_capacity(instrument.len() + 1);
    terms.push(Term {
        u: u_random,
        c: 1.0,
        nu: nu_random,
    });
    for c in instrument {
        c.validate()?;
        if !(c.sensitivity * c.u).is_finite() {
            return Err(UncertaintyError::NonFinite {
                budget: String::new(),
                contribution: Some(c.name.clone()),
                quantity: format!("|c·u| = |{:e} × {:e}|", c.sensitivity, c.u),
            });
        }
        if matches!(c.source, Source::Budget { .. }) {
            return Err(UncertaintyError::BadParameter {
                name: c.name.clone(),
                what: "an instrument term cannot be a nested budget".into(),
            });
        }
        terms.push(Term {
            u: c.u,
            c: c.sensitivity,
            nu: c.nu,
        });
    }
    combine(&terms, &[], coverage)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn example(name: &str) -> String {
        let p = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../../examples")
            .join(name);
        std::fs::read_to_string(&p).unwrap_or_else(|e| panic!("{}: {e}", p.display()))
    }

    /// The project's shift-angle instrument terms with the seed's random part (ε repeatability
    /// 0.13″/√6, ν = 5): the corrected autocollimator error (0.05″ rectangular) and encoder
    /// resolution (0.04″ step) lower u(ε) from the printed 0.0677″.
    #[test]
    fn shift_angle_example_file() {
        let inst = InstrumentFile::parse(&example("instrument-shift-angle.toml")).unwrap();
        assert_eq!(inst.unit, "arcsec");
        let names: Vec<&str> = inst.contributions.iter().map(|c| c.name.as_str()).collect();
        assert!(names.contains(&"autocollimator linearity"), "{names:?}");
        let lin = inst
            .contributions
            .iter()
            .find(|c| c.name == "autocollimator linearity")
            .unwrap();
        assert!((lin.u - 0.05 / 3f64.sqrt()).abs() < 1e-15);
        let enc = inst
            .contributions
            .iter()
            .find(|c| c.name == "encoder resolution")
            .unwrap();
        assert!((enc.u - 0.04 / 12f64.sqrt()).abs() < 1e-15);
        let r = inst.combine(0.13 / 6f64.sqrt(), 5.0).unwrap();
        // Hand sum of squares of the file's terms: 0.0531² + 0.000289² + 0.005² + 0.0289² +
        // 0.0115² + 0.0000289² + 0.0144² → u_c = 0.0646.
        let hand = (0.13f64.powi(2) / 6.0
            + 0.001f64.powi(2) / 12.0
            + 0.005f64.powi(2)
            + 0.05f64.powi(2) / 3.0
            + 0.04f64.powi(2) / 12.0
            + 0.00005f64.powi(2) / 3.0
            + 0.025f64.powi(2) / 3.0)
            .sqrt();
        assert!((r.u_c - hand).abs() < 1e-12, "{} vs {hand}", r.u_c);
        assert!(r.nu_eff >= 5.0 && r.k > 2.0);
    }

    #[test]
    fn selfcal_example_file() {
        let inst = InstrumentFile::parse(&example("instrument-selfcal.toml")).unwrap();
        let r = inst.combine(0.01 / 6f64.sqrt(), 5.0).unwrap();
        // Corrected encoder resolution 0.0115″: u_c = 0.0122″, ν_eff = 54.7 → 54, U = 0.0245″.
        assert!((r.u_c - 0.012247).abs() < 1e-6);
        assert_eq!(r.nu_eff, 54.0);
        assert!((r.expanded - 0.0245).abs() < 1e-4);
    }

    #[test]
    fn errors_have_lines() {
        let e = InstrumentFile::parse("[encoder_resolution]\ndistribution = \"box\"\nstep = 1\n")
            .unwrap_err();
        assert_eq!((e.line, e.column), (2, 16));
        let e = InstrumentFile::parse("[head_noise]\nu = 0.01\n[encoder_resolutoin]\nu = 1\n")
            .unwrap_err();
        assert_eq!(e.line, 3, "{e}");
        let e = InstrumentFile::parse("[head_noise]\nfrom = \"x\"\n").unwrap_err();
        assert_eq!(e.line, 2);
        assert!(combine_with_instrument(-1.0, 5.0, &[], 0.95).is_err());
        assert!(combine_with_instrument(1.0, 0.0, &[], 0.95).is_err());
        // No instrument terms: the random part alone, k from its ν.
        let r = combine_with_instrument(0.1, 10.0, &[], 0.95).unwrap();
        assert!((r.k - 2.228138852).abs() < 1e-8 && r.u_c == 0.1);
    }
}
