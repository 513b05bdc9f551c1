//! Part 4 of the demo: an encoder with a planted order-24 term on both rigs, the polygon and the
//! heads in one least squares: the polygon alone misses order 24, the joint estimate recovers it
//! (and order 84, which the heads miss); only order 168 stays invisible (″).

use super::INSTRUMENT_SELFCAL;
use anyhow::Result;
use gonio_calib::certificate::{Certificate, Instrument};
use gonio_calib::joint::{self, JointOptions};
use gonio_calib::selfcal::{self, SelfcalOptions};
use gonio_calib::shift_angle::{Options, ReadingSet, calibrate};
use gonio_core::HarmonicFitSpec;
use gonio_sim::EncoderModel;
use gonio_sim::encoder::HarmonicArcsec;
use gonio_sim::joint::{
    JointSimConfig, simulate as simulate_both, true_coefficients, truth_without,
};
use gonio_uncertainty::instrument::InstrumentFile;
use std::io::Write;

/// Part 4: the polygon and SelfA's heads in one least squares, on an encoder with a planted
/// order-24 term (invisible to a 24-face polygon), its narrative to `w`; returns the joint
/// certificate.
///
/// # Errors
/// A write error on `w`, or a simulation, fit or calibration that fails.
pub fn run(seed: u64, w: &mut dyn Write) -> Result<Certificate> {
    writeln!(
        w,
        "Joint calibration: the polygon and SelfA's heads in one least squares"
    )?;
    let mut harmonics = EncoderModel::default_harmonics();
    harmonics.retain(|h| h.order != 24);
    harmonics.push(HarmonicArcsec {
        order: 24,
        amplitude_arcsec: 0.05,
        phase_rad: 0.7,
    });
    let encoder = EncoderModel::new(harmonics, EncoderModel::default_graduation(seed))?;
    let cfg = JointSimConfig::new(24, (0..15).map(f64::from).collect(), seed);
    let sim = simulate_both(&encoder, &cfg)?;
    let set = ReadingSet::new(24, sim.polygon.readings.clone())?;
    let heads = cfg.heads.heads.clone();
    let polygon = calibrate(&set, &Options::default())?;
    let selfa = selfcal::calibrate(&heads, &sim.heads.turns, &SelfcalOptions::default())?;
    let cal = joint::calibrate(&set, &heads, &sim.heads.turns, &JointOptions::default())?;
    writeln!(
        w,
        "  encoder: the demo encoder with a 0.05″ order-24 term; polygon: 24 faces, full matrices at \
         S = 0°…14° ({} readings, σ {}″); SelfA: {} positions (σ {}″)",
        set.len(),
        cfg.polygon.noise_sigma_arcsec,
        cfg.heads.positions,
        cfg.heads.noise_sigma_arcsec
    )?;
    // The polygon alone: the order-24 term of its merged α (each shift's closure removes it).
    let merged = polygon.merged();
    let theta: Vec<f64> = merged.iter().map(|m| m.angle_deg.to_radians()).collect();
    let values: Vec<f64> = merged.iter().map(|m| m.value_arcsec).collect();
    let polygon_amp = |k: u32| -> Result<f64> {
        Ok(HarmonicFitSpec::new(&[k])
            .fit(&theta, &values, None)?
            .harmonic(k)
            .map_or(0.0, |h| h.amplitude))
    };
    writeln!(
        w,
        "  {:>6} {:>10} {:>20} {:>20} {:>24}",
        "order", "true", "polygon alone", "SelfA alone", "joint"
    )?;
    for k in [24u32, 84, 168] {
        let (c, s) = true_coefficients(&sim.heads.truth, k);
        let p = if polygon.undetectable_harmonics.contains(&k) {
            format!("{:.5}″ (blind)", polygon_amp(k)?)
        } else {
            format!("{:.5}″", polygon_amp(k)?)
        };
        let h = &selfa.harmonics[k as usize - 1];
        let a = if h.detectable {
            format!("{:.5}″", h.amplitude_arcsec)
        } else {
            "– (blind)".to_string()
        };
        let j = &cal.harmonics[k as usize - 1];
        let jt = if j.estimated {
            format!(
                "{:.5}″ ± {:.5}″",
                j.amplitude_arcsec,
                0.5 * (j.u_cos_arcsec + j.u_sin_arcsec)
            )
        } else {
            "– (blind to both)".to_string()
        };
        writeln!(w, "  {k:>6} {:>9.5}″ {p:>20} {a:>20} {jt:>24}", c.hypot(s))?;
    }
    // α at the polygon's 360 angles against the encoder's true error.
    let angles: Vec<f64> = cal.alpha.iter().map(|a| a.angle_deg).collect();
    let truth = truth_without(&sim.heads.truth, &[], &angles);
    let rms = |e: &mut dyn Iterator<Item = f64>| {
        let v: Vec<f64> = e.collect();
        (v.iter().map(|x| x * x).sum::<f64>() / v.len() as f64).sqrt()
    };
    let joint_rms = rms(&mut cal
        .alpha
        .iter()
        .zip(&truth)
        .map(|(a, t)| a.value_arcsec - t));
    let polygon_rms = rms(&mut merged.iter().map(|m| {
        let q = angles
            .iter()
            .position(|&x| (x - m.angle_deg).abs() < 1e-9)
            .expect("every polygon angle is in the joint result");
        m.value_arcsec - truth[q]
    }));
    let u_joint = rms(&mut cal.alpha.iter().map(|a| a.u_arcsec));
    writeln!(
        w,
        "  α at the {} polygon angles against the true error: polygon alone RMS {:.4}″ (its closure \
         drops order 24), joint RMS {:.4}″ with u {:.4}″ (SelfA alone u {:.4}″)",
        angles.len(),
        polygon_rms,
        joint_rms,
        u_joint,
        selfa.errors[0].u_arcsec
    )?;
    writeln!(
        w,
        "  Invisible to the joint estimate up to order {}: {:?} (multiples of lcm(24, 84) = 168, and \
         heads-blind orders above the polygon's 1° grid).",
        cal.blind.max_order, cal.blind.joint
    )?;
    // The certificate carries the encoder's resolution (the instrument terms of any calibration
    // of this encoder) on top of the random part.
    let instrument = Instrument::new(
        InstrumentFile::parse(INSTRUMENT_SELFCAL)?,
        Some("examples/instrument-selfcal.toml".into()),
    );
    Ok(Certificate::from_joint(&cal, &instrument)?)
}
