//! Part 5 of the demo: a simulated rotary axis (error, backlash 1.5″, repeatability σ 0.3″)
//! tested to ISO 230-2 at the 24-face polygon's faces and 360°, 5 runs each way, against its own
//! parameters (″).

use anyhow::Result;
use gonio_calib::axis::{AxisInput, AxisResult, Direction, analyse};
use gonio_calib::certificate::Instrument;
use gonio_sim::axis::{AxisModel, AxisTest, simulate};
use std::io::Write;

/// Part 5: a simulated rotary axis tested to ISO 230-2 with reference noise `sigma` (″), its
/// narrative to `w`.
///
/// # Errors
/// A write error on `w`, or a simulation or analysis that fails.
pub fn run(seed: u64, sigma: f64, w: &mut dyn Write) -> Result<AxisResult> {
    let model = AxisModel::default_with_seed(seed);
    let targets: Vec<f64> = (0..=24).map(|k| f64::from(k) * 15.0).collect();
    let test = AxisTest {
        targets_deg: targets.clone(),
        runs: 5,
        directions: Direction::BOTH.to_vec(),
        reference_sigma_arcsec: sigma,
        resolution_arcsec: 0.001,
    };
    let readings = simulate(&model, &test)?;
    let doc = analyse(&AxisInput::Deviations(readings), &Instrument::default())?;
    let truth = model.truth(&targets).parameters;
    writeln!(
        w,
        "Rotary axis to ISO 230-2:2014 (beyond the encoder: the same bench tests an axis)"
    )?;
    writeln!(
        w,
        "  axis: 3″ first-order error, scale {}″/turn, backlash {}″, repeatability σ {}″; 25 targets \
         (every 15°), 5 runs each way, reference σ {sigma}″",
        model.scale_arcsec_per_turn, model.backlash_arcsec, model.repeatability_arcsec
    )?;
    writeln!(
        w,
        "  {:<10} {:>10} {:>10} {:>12}",
        "parameter", "measured", "U (k = 2)", "the axis's"
    )?;
    let u = doc.uncertainty.parameters.named();
    for (((name, v), (_, uu)), (_, t)) in
        doc.parameters.named().into_iter().zip(u).zip(truth.named())
    {
        if let (Some(v), Some(uu), Some(t)) = (v, uu, t) {
            writeln!(w, "  {name:<10} {v:>9.3}″ {uu:>9.3}″ {t:>11.3}″")?;
        }
    }
    Ok(doc)
}
