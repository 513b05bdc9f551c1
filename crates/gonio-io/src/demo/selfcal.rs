//! Part 3 of the demo: the same encoder on SelfA's 12 heads, compared with the shift-angle
//! result (each the average of six runs, as in Hsieh et al., 2022, Fig. 11–12), with En from each
//! certificate's expanded uncertainty (″).

use super::{INSTRUMENT_SELFCAL, INSTRUMENT_SHIFT_ANGLE};
use crate::table::fixed;
use anyhow::Result;
use gonio_calib::certificate::{Certificate, Instrument};
use gonio_calib::compare::{Comparison, Curve, compare};
use gonio_calib::selfcal::{self, Heads, SelfcalOptions};
use gonio_calib::shift_angle::{Options, ReadingSet, calibrate};
use gonio_sim::EncoderModel;
use gonio_sim::selfcal::SelfcalSimConfig;
use gonio_sim::shift_angle::{ShiftAngleConfig, simulate};
use gonio_uncertainty::instrument::InstrumentFile;
use std::io::Write;

/// Part 3: SelfA self-calibration of the same encoder and the comparison (Hsieh et al., 2022,
/// Fig. 11–12), its narrative to `w`; returns both certificates and the comparison.
///
/// # Errors
/// A write error on `w`, or a simulation, calibration or comparison that fails.
pub fn run(
    encoder: &EncoderModel,
    shift_cfg: &ShiftAngleConfig,
    seed: u64,
    w: &mut dyn Write,
) -> Result<(Certificate, Certificate, Comparison)> {
    writeln!(
        w,
        "Self-calibration: SelfA (12 heads; sets of 3, 4 and 7) vs the shift-angle method"
    )?;
    // The paper averages six measurement results of the shift-angle method.
    let six = ShiftAngleConfig {
        repeats: 6,
        ..shift_cfg.clone()
    };
    let sim = simulate(encoder, &six)?;
    let set = ReadingSet::new(six.faces, sim.readings)?;
    let cal = calibrate(&set, &Options::default())?;
    let shift_instrument = Instrument::new(
        InstrumentFile::parse(INSTRUMENT_SHIFT_ANGLE)?,
        Some("examples/instrument-shift-angle.toml".into()),
    );
    let shift_cert = Certificate::from_shift_angle(&cal, &set, false, 2, &shift_instrument)?;
    let a = Curve::from(&shift_cert);

    let heads = Heads::selfa12();
    let sc_cfg = SelfcalSimConfig::new(heads.clone(), seed + 1000);
    let sc_sim = gonio_sim::selfcal::simulate(encoder, &sc_cfg)?;
    let result = selfcal::calibrate(&heads, &sc_sim.turns, &SelfcalOptions::default())?;
    let selfcal_instrument = Instrument::new(
        InstrumentFile::parse(INSTRUMENT_SELFCAL)?,
        Some("examples/instrument-selfcal.toml".into()),
    );
    let selfcal_cert = Certificate::from_selfcal(&result, &selfcal_instrument)?;
    let b = Curve::from(&selfcal_cert);
    let c = compare(&a, &b)?;
    writeln!(
        w,
        "  shift-angle: 24 faces, S = 0°…14°, six repeats ({} readings); SelfA: {} positions, \
         heads σ {}″",
        set.len(),
        sc_cfg.positions,
        sc_cfg.noise_sigma_arcsec
    )?;
    writeln!(
        w,
        "  {:>8} {:>14} {:>14} {:>14} {:>8}",
        "angle", "shift-angle α", "SelfA a", "difference", "En"
    )?;
    for p in c
        .points
        .iter()
        .filter(|p| (p.angle_deg.round() as i64) % 30 == 0)
    {
        writeln!(
            w,
            "  {:>7.0}° {:>13.4}″ {:>13.4}″ {:>13.4}″ {:>8}",
            p.angle_deg,
            p.a_arcsec,
            p.b_arcsec,
            p.difference_arcsec,
            p.en.map_or("–".into(), |e| format!("{e:.2}"))
        )?;
    }
    writeln!(
        w,
        "  {} common angles: largest |difference| {:.4}″ at {}° (Hsieh et al., 2022: within ±0.1″), RMS {:.4}″; \
         largest En {} at {}° (Hsieh et al., 2022: 0.69); {}",
        c.points.len(),
        c.max_abs_difference_arcsec,
        c.max_abs_difference_angle_deg,
        c.rms_difference_arcsec,
        fixed(c.max_en, 2),
        fixed(c.max_en_angle_deg, 3),
        if c.all_en_pass {
            "every En ≤ 1".to_string()
        } else {
            format!(
                "{} of {} En > 1",
                c.points
                    .iter()
                    .filter(|p| p.en.is_some_and(|e| e > 1.0))
                    .count(),
                c.points.len()
            )
        }
    )?;
    writeln!(
        w,
        "  Blind spots: the polygon cannot see harmonics {:?}…, SelfA cannot see {:?}…; the \
         comparison is blind to both.",
        &c.undetectable_harmonics.a[..c.undetectable_harmonics.a.len().min(3)],
        &c.undetectable_harmonics.b[..c.undetectable_harmonics.b.len().min(2)]
    )?;
    Ok((shift_cert, selfcal_cert, c))
}
