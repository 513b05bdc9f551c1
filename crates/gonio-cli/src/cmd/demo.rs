//! `gonio demo`: the built-in simulated lab, end to end, with the truth to compare against.

use anyhow::Result;
use gonio_calib::certificate::{Certificate, Instrument};
use gonio_calib::compare::{Curve, compare};
use gonio_calib::selfcal::{self, Heads, SelfcalOptions};
use gonio_calib::shift_angle::{Calibration, Method, Options, ReadingSet, calibrate};
use gonio_cli::output::Outputs;
use gonio_cli::say;
use gonio_io::formats::report::{self, ReportInput};
use gonio_sim::EncoderModel;
use gonio_sim::selfcal::SelfcalSimConfig;
use gonio_sim::shift_angle::{Rows, ShiftAngleConfig, ShiftAngleTruth, simulate};
use gonio_sim::station::BatchReport;
use gonio_sim::station::{BatchConfig, run_batch};
use gonio_station::controller::Strategy;
use gonio_station::published::YU_2024;
use gonio_uncertainty::instrument::InstrumentFile;
use std::path::PathBuf;

/// The example certificate metadata (fictitious laboratory and customer).
const META: &str = include_str!("../../../../examples/certificate-meta.toml");

/// The instrument terms of the shift-angle calibration (Table 3 of Hsieh et al., 2022, corrected).
const INSTRUMENT_SHIFT_ANGLE: &str =
    include_str!("../../../../examples/instrument-shift-angle.toml");
/// The instrument terms of the SelfA self-calibration.
const INSTRUMENT_SELFCAL: &str = include_str!("../../../../examples/instrument-selfcal.toml");

/// Arguments of `gonio demo`.
#[derive(Debug, clap::Args)]
#[command(after_help = "\
1. Mounting (Yu et al., 2024): a batch of 25 gratings on the simulated station, with the paper's
   strategy and with gonio's default, against the paper's 25 real parts.
2. Calibration by the shift-angle method (Hsieh et al., 2022): the simulated encoder measured
   with a 24-face polygon at S = 0°…14° (the full matrix at 0°, one row at every other shift, as
   in the paper), calibrated by least squares and by the paper's algorithm, against the truth.
3. Self-calibration: the same encoder on SelfA's 12 heads, compared with the shift-angle result
   (each the average of six runs, as in the paper's Fig. 11–12), with En from each certificate's
   expanded uncertainty.
4. Joint calibration: an encoder with a planted order-24 term on both rigs, the polygon and the
   heads in one least squares: the polygon alone misses order 24, the joint estimate recovers it
   (and order 84, which the heads miss); only order 168 stays invisible.
5. A rotary axis to ISO 230-2: the simulated axis (error, backlash 1.5″, repeatability σ 0.3″)
   at the 24-face polygon's faces and 360°, 5 runs each way, against its own parameters.
It then writes the certificates, the comparison, the axis, the batch and one HTML report with every plot
into --out (gonio-demo/report.html by default; a directory that holds files only with --force)
and prints the report's path.

Example:
  gonio demo --seed 3 --out demo3")]
pub struct Args {
    /// Seed of the simulated lab.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Autocollimator noise per reading, arcsec.
    #[arg(long, default_value_t = 0.05, value_parser = gonio_cli::flag::real(gonio_cli::flag::SIGMA_ARCSEC))]
    pub sigma: f64,
    /// Directory for the report, the certificates, the comparison and the batch.
    #[arg(long, default_value = "gonio-demo")]
    pub out: PathBuf,
    /// Write into --out even when it holds files (those of an earlier demo are replaced).
    #[arg(long)]
    pub force: bool,
}

struct Score {
    alpha_rms: f64,
    alpha_max: f64,
    beta_rms: f64,
    u_alpha_rms: f64,
}

/// Errors against the truth over the shifts `keep` selects.
fn score(cal: &Calibration, truth: &ShiftAngleTruth, keep: impl Fn(f64) -> bool) -> Score {
    let (mut ss, mut max, mut uu, mut count) = (0.0f64, 0.0f64, 0.0f64, 0usize);
    for t in truth.encoder_errors.iter().filter(|t| keep(t.shift_deg)) {
        count += 1;
        let s = cal
            .shifts
            .iter()
            .find(|s| s.shift_deg == t.shift_deg)
            .expect("every simulated shift is calibrated");
        let e = s.alpha_arcsec[t.step - 1] - t.value_arcsec;
        ss += e * e;
        max = max.max(e.abs());
        uu += s.u_alpha_arcsec[t.step - 1].powi(2);
    }
    let n = count as f64;
    let bss: f64 = truth
        .pitch_deviations
        .iter()
        .map(|p| (cal.beta_arcsec[p.face - 1] - p.value_arcsec).powi(2))
        .sum();
    Score {
        alpha_rms: (ss / n).sqrt(),
        alpha_max: max,
        beta_rms: (bss / truth.pitch_deviations.len() as f64).sqrt(),
        u_alpha_rms: (uu / n).sqrt(),
    }
}

/// Runs `gonio demo`.
pub fn run(args: Args) -> Result<()> {
    // Before any work: a directory with files in it is only written into with --force.
    if !args.force
        && let Ok(mut d) = std::fs::read_dir(&args.out)
        && d.next().is_some()
    {
        anyhow::bail!(
            "--out {}: the directory is not empty: choose a new directory, or give --force to replace the demo's files in it",
            args.out.display()
        );
    }
    say!(
        "gonio demo: the built-in simulated lab and station (seed {})",
        args.seed
    )?;
    say!()?;
    let batch = mounting(args.seed)?;
    say!()?;
    let encoder = EncoderModel::default_with_seed(args.seed);
    let cfg = ShiftAngleConfig {
        faces: 24,
        shifts_deg: (0..15).map(f64::from).collect(),
        rows: Rows::Seed,
        noise_sigma_arcsec: args.sigma,
        seed: args.seed,
        ..ShiftAngleConfig::default()
    };
    let sim = simulate(&encoder, &cfg)?;
    let set = ReadingSet::new(cfg.faces, sim.readings.clone())?;
    say!("Calibration: shift-angle method (Hsieh et al., 2022)")?;
    say!(
        "  encoder: {} harmonics + {}″ graduation error; polygon: {} faces, β σ {}″",
        encoder.harmonics().len(),
        encoder.graduation().sigma_arcsec,
        cfg.faces,
        cfg.pitch_sigma_arcsec
    )?;
    say!(
        "  runs: S = 0°…14° (full {n}×{n} matrix at 0°, start face 1 elsewhere): {} readings, \
         autocollimator σ {}″, resolution {}″",
        set.len(),
        cfg.noise_sigma_arcsec,
        cfg.resolution_arcsec,
        n = cfg.faces
    )?;
    say!()?;
    say!(
        "  {:<34} {:>10} {:>12} {:>12} {:>12} {:>14}",
        "method",
        "angles",
        "α err RMS",
        "α err max",
        "β err RMS",
        "reported u(α)"
    )?;
    let line = |name: &str, angles: &str, s: &Score| {
        say!(
            "  {:<34} {:>10} {:>11.4}″ {:>11.4}″ {:>11.4}″ {:>13.4}″",
            name,
            angles,
            s.alpha_rms,
            s.alpha_max,
            s.beta_rms,
            s.u_alpha_rms
        )
    };
    let mut at_zero = Vec::new();
    for method in [Method::LeastSquares, Method::Paper] {
        let cal = calibrate(
            &set,
            &Options {
                method,
                ..Options::default()
            },
        )?;
        let name = match method {
            Method::LeastSquares => "least squares",
            Method::Paper => "paper's algorithm",
        };
        let z = score(&cal, &sim.truth, |s| s == 0.0);
        line(name, "S = 0°", &z)?;
        line("", "S = 1…14°", &score(&cal, &sim.truth, |s| s != 0.0))?;
        at_zero.push(z.alpha_rms);
    }
    // The same lab with every start face measured at every shift: least squares uses it all.
    let full_cfg = ShiftAngleConfig {
        rows: Rows::Full,
        ..cfg.clone()
    };
    let full = simulate(&encoder, &full_cfg)?;
    let full_set = ReadingSet::new(cfg.faces, full.readings.clone())?;
    let cal = calibrate(&full_set, &Options::default())?;
    line(
        &format!("least squares, full matrices ({})", full_set.len()),
        "all 360",
        &score(&cal, &full.truth, |_| true),
    )?;
    say!()?;
    say!(
        "  At S = 0° (full matrix) least squares is {:.1}× closer than the paper's algorithm \
         (theory: √(N−1) = {:.1}×); with one row per shift both are limited by that row's noise.",
        at_zero[1] / at_zero[0],
        ((cfg.faces - 1) as f64).sqrt()
    )?;
    say!(
        "  Invisible to a {}-face polygon: harmonics {}, {}, … (the demo encoder has a 0.008″ \
         order-24 term).",
        cfg.faces,
        cfg.faces,
        2 * cfg.faces
    )?;
    say!()?;
    let (shift_cert, selfcal_cert, comparison) = self_calibration(&encoder, &cfg, args.seed)?;
    say!()?;
    let joint_cert = joint_calibration(args.seed)?;
    say!()?;
    let axis = rotary_axis(args.seed, args.sigma)?;
    write_report(
        &args,
        &[&shift_cert, &selfcal_cert, &joint_cert],
        &comparison,
        &axis,
        &batch,
    )
}

/// Part 5: a simulated rotary axis tested to ISO 230-2, against its own parameters.
fn rotary_axis(seed: u64, sigma: f64) -> Result<gonio_calib::axis::AxisResult> {
    use gonio_calib::axis::{AxisInput, Direction, analyse};
    use gonio_sim::axis::{AxisModel, AxisTest, simulate};
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
    say!("Rotary axis to ISO 230-2:2014 (beyond the encoder: the same bench tests an axis)")?;
    say!(
        "  axis: 3″ first-order error, scale {}″/turn, backlash {}″, repeatability σ {}″; 25 targets \
         (every 15°), 5 runs each way, reference σ {sigma}″",
        model.scale_arcsec_per_turn,
        model.backlash_arcsec,
        model.repeatability_arcsec
    )?;
    say!(
        "  {:<10} {:>10} {:>10} {:>12}",
        "parameter",
        "measured",
        "U (k = 2)",
        "the axis's"
    )?;
    let u = doc.uncertainty.parameters.named();
    for (((name, v), (_, uu)), (_, t)) in
        doc.parameters.named().into_iter().zip(u).zip(truth.named())
    {
        if let (Some(v), Some(uu), Some(t)) = (v, uu, t) {
            say!("  {name:<10} {v:>9.3}″ {uu:>9.3}″ {t:>11.3}″")?;
        }
    }
    Ok(doc)
}

/// Writes the certificates, the comparison, the axis, the batch and the HTML report into
/// `args.out`.
fn write_report(
    args: &Args,
    certs: &[&Certificate; 3],
    comparison: &gonio_calib::compare::Comparison,
    axis: &gonio_calib::axis::AxisResult,
    batch: &BatchReport,
) -> Result<()> {
    let meta = gonio_io::formats::meta::parse("examples/certificate-meta.toml", META)?;
    let with_meta = |c: &Certificate| {
        let mut m = meta.clone();
        m.remarks = Some(format!(
            "Simulated measurement (gonio demo, seed {}): the laboratory, customer and standards are fictitious.",
            args.seed
        ));
        c.clone().with_meta(m)
    };
    let mut out = Outputs::new();
    // A directory with files in it only with --force (checked before the work, again here).
    out.dir("--out", &args.out, args.force)?;
    let certs: Vec<Certificate> = certs.iter().map(|c| with_meta(c)).collect();
    let names = ["shift-angle.json", "selfcal.json", "joint.json"];
    let mut inputs = Vec::new();
    for (name, c) in names.iter().zip(&certs) {
        let p = args.out.join(name);
        let id = out.file("--out", &p)?;
        out.json(id, c)?;
        inputs.push((
            p.display().to_string(),
            ReportInput::Certificate(Box::new(c.clone())),
        ));
    }
    let p = args.out.join("compare.json");
    let id = out.file("--out", &p)?;
    out.json(id, comparison)?;
    inputs.push((
        p.display().to_string(),
        ReportInput::Comparison(Box::new(comparison.clone())),
    ));
    let p = args.out.join("axis.json");
    let id = out.file("--out", &p)?;
    out.json(id, axis)?;
    inputs.push((
        p.display().to_string(),
        ReportInput::Axis(Box::new(axis.clone())),
    ));
    let p = args.out.join("batch.json");
    let id = out.file("--out", &p)?;
    out.json(id, batch)?;
    // The report reads the batch as `gonio report batch.json` would: through its JSON.
    let view = serde_json::from_value(serde_json::to_value(batch)?)?;
    inputs.push((p.display().to_string(), ReportInput::Batch(Box::new(view))));
    let report = report::build(
        inputs,
        None,
        Some("gonio demo: simulated calibration and mounting"),
    )?;
    let html = args.out.join("report.html");
    let id = out.file("--out", &html)?;
    out.write(id, report.render().as_bytes())?;
    out.commit()?;
    say!()?;
    say!(
        "Report: {} ({} plots; certificates, comparison, axis and batch as JSON beside it)",
        html.display(),
        report.figures().len()
    )?;
    Ok(())
}

/// Part 1: 25 gratings mounted on the simulated station; returns the default strategy's batch.
fn mounting(seed: u64) -> Result<BatchReport> {
    say!(
        "Mounting: 25 gratings on the simulated station (the plant of Yu et al., 2024, fast fidelity)"
    )?;
    say!(
        "  {:<28} {:>12} {:>12} {:>14} {:>10}",
        "strategy",
        "mean pushes",
        "max pushes",
        "mean final e",
        "mean time"
    )?;
    let y = &YU_2024;
    say!(
        "  {:<28} {:>12} {:>12} {:>13}µm {:>9}s",
        format!("Yu et al., 2024, {} parts", y.parts),
        y.mean_pushes,
        y.max_pushes,
        y.mean_final_e_um,
        y.mean_time_s
    )?;
    let mut default_batch = None;
    for strategy in [Strategy::Paper, Strategy::Learned, Strategy::Live] {
        let cfg = BatchConfig {
            parts: 25,
            strategy,
            ..BatchConfig::default()
        };
        let report = run_batch(&cfg, seed, &mut |_, _, _| {})?;
        let s = &report.summary;
        let name = match strategy {
            Strategy::Paper => "paper's strategy (simulated)",
            Strategy::Learned => "gonio default (learned)",
            Strategy::Live => "live-baseline feedback",
            Strategy::LeastSquares => "least squares",
        };
        say!(
            "  {:<28} {:>12.2} {:>12} {:>13}µm {:>9}s{}",
            name,
            s.mean_pushes,
            s.max_pushes,
            crate::table::fixed(s.mean_final_e_um, 2),
            crate::table::fixed(s.mean_time_s, 1),
            if s.rejected > 0 {
                format!("  ({} rejected)", s.rejected)
            } else {
                String::new()
            }
        )?;
        if strategy == Strategy::Learned {
            default_batch = Some(report);
        }
    }
    say!("  (`gonio mount --sim --strategy …` for per-part records; 25 parts take milliseconds)")?;
    default_batch.ok_or_else(|| anyhow::anyhow!("no batch was run"))
}

/// Part 3: SelfA self-calibration of the same encoder and the comparison (Hsieh et al., 2022,
/// Fig. 11–12); returns both certificates and the comparison.
fn self_calibration(
    encoder: &EncoderModel,
    shift_cfg: &ShiftAngleConfig,
    seed: u64,
) -> Result<(Certificate, Certificate, gonio_calib::compare::Comparison)> {
    say!("Self-calibration: SelfA (12 heads; sets of 3, 4 and 7) vs the shift-angle method")?;
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
    say!(
        "  shift-angle: 24 faces, S = 0°…14°, six repeats ({} readings); SelfA: {} positions, \
         heads σ {}″",
        set.len(),
        sc_cfg.positions,
        sc_cfg.noise_sigma_arcsec
    )?;
    say!(
        "  {:>8} {:>14} {:>14} {:>14} {:>8}",
        "angle",
        "shift-angle α",
        "SelfA a",
        "difference",
        "En"
    )?;
    for p in c
        .points
        .iter()
        .filter(|p| (p.angle_deg.round() as i64) % 30 == 0)
    {
        say!(
            "  {:>7.0}° {:>13.4}″ {:>13.4}″ {:>13.4}″ {:>8}",
            p.angle_deg,
            p.a_arcsec,
            p.b_arcsec,
            p.difference_arcsec,
            p.en.map_or("–".into(), |e| format!("{e:.2}"))
        )?;
    }
    say!(
        "  {} common angles: largest |difference| {:.4}″ at {}° (Hsieh et al., 2022: within ±0.1″), RMS {:.4}″; \
         largest En {} at {}° (Hsieh et al., 2022: 0.69); {}",
        c.points.len(),
        c.max_abs_difference_arcsec,
        c.max_abs_difference_angle_deg,
        c.rms_difference_arcsec,
        crate::table::fixed(c.max_en, 2),
        crate::table::fixed(c.max_en_angle_deg, 3),
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
    say!(
        "  Blind spots: the polygon cannot see harmonics {:?}…, SelfA cannot see {:?}…; the \
         comparison is blind to both.",
        &c.undetectable_harmonics.a[..c.undetectable_harmonics.a.len().min(3)],
        &c.undetectable_harmonics.b[..c.undetectable_harmonics.b.len().min(2)]
    )?;
    Ok((shift_cert, selfcal_cert, c))
}

/// Part 4: the polygon and SelfA's heads in one least squares, on an encoder with a planted
/// order-24 term (invisible to a 24-face polygon).
fn joint_calibration(seed: u64) -> Result<Certificate> {
    use gonio_calib::joint::{self, JointOptions};
    use gonio_core::HarmonicFitSpec;
    use gonio_sim::encoder::HarmonicArcsec;
    use gonio_sim::joint::{
        JointSimConfig, simulate as simulate_both, true_coefficients, truth_without,
    };

    say!("Joint calibration: the polygon and SelfA's heads in one least squares")?;
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
    say!(
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
    say!(
        "  {:>6} {:>10} {:>20} {:>20} {:>24}",
        "order",
        "true",
        "polygon alone",
        "SelfA alone",
        "joint"
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
        say!("  {k:>6} {:>9.5}″ {p:>20} {a:>20} {jt:>24}", c.hypot(s))?;
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
    say!(
        "  α at the {} polygon angles against the true error: polygon alone RMS {:.4}″ (its closure \
         drops order 24), joint RMS {:.4}″ with u {:.4}″ (SelfA alone u {:.4}″)",
        angles.len(),
        polygon_rms,
        joint_rms,
        u_joint,
        selfa.errors[0].u_arcsec
    )?;
    say!(
        "  Invisible to the joint estimate up to order {}: {:?} (multiples of lcm(24, 84) = 168, and \
         heads-blind orders above the polygon's 1° grid).",
        cal.blind.max_order,
        cal.blind.joint
    )?;
    // The certificate carries the encoder's resolution (the instrument terms of any calibration
    // of this encoder) on top of the random part.
    let instrument = Instrument::new(
        InstrumentFile::parse(INSTRUMENT_SELFCAL)?,
        Some("examples/instrument-selfcal.toml".into()),
    );
    Ok(Certificate::from_joint(&cal, &instrument)?)
}
