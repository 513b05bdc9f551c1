//! `gonio joint`: calibrate an encoder from polygon readings and read-head readings together.

use crate::db;
use anyhow::Result;
use gonio_calib::certificate::{Certificate, JointSection};
use gonio_calib::joint::{HeadAngles, Interpolation, JointHarmonic, SigmaUsed};
use gonio_calib::selfcal::NoiseModel;
use gonio_cli::flag;
use gonio_cli::output::Outputs;
use gonio_io::formats::heads;
use gonio_io::formats::source::{Document, Table};
use gonio_io::results::joint::{Request, check, evaluate};
use std::fmt::Write as _;
use std::path::PathBuf;

/// Arguments of `gonio joint`.
#[derive(Debug, clap::Args)]
#[command(after_help = "\
Inputs (the same encoder, read both ways):
  READINGS.csv  polygon + autocollimator readings, as for `gonio shift-angle`:
                shift_deg,start_face,step,reading_arcsec[,repeat]
  HEADS.csv     head differences, as for `gonio selfcal`: position_deg,head_2,…,head_M (arcsec;
                with --raw, position_deg,head_1,…,head_M in degrees); optional `turn` column.
Every polygon angle must be one of the head readings' rotation positions.

Each instrument is weighted by its own σ: --sigma-polygon/--sigma-heads, or estimated from its
own residuals (the polygon's shift-angle least squares, the heads' per-harmonic fit).
--json writes a gonio.certificate/1 (procedure `joint`, see docs/joint-calibration.md): α at every
distinct polygon angle with u, ν_eff, k and U; under `joint` the split of every u between the
instruments, the full covariance of α there, β and U, the harmonic table with each instrument's
share per order and the orders neither instrument sees. `gonio report` draws its spectrum with each
method's blind orders marked.

Examples:
  gonio simulate shift-angle --rows full --shifts 0:1:14 --seed 1 --out poly
  gonio simulate selfcal --heads selfa12 --seed 1 --out heads
  gonio joint poly/readings.csv heads/readings.csv --faces 24 --heads selfa12 --json joint.json")]
pub struct Args {
    /// Polygon readings CSV.
    pub readings: PathBuf,
    /// Head readings CSV.
    pub heads_readings: PathBuf,
    /// Polygon faces N.
    #[arg(long, value_parser = flag::whole::<usize>(flag::FACES))]
    pub faces: usize,
    /// Head arrangement: `selfa12`, `eda:N`, or a TOML/JSON heads file.
    #[arg(long)]
    pub heads: String,
    /// The head CSV holds raw head readings in degrees (`head_1..head_M`).
    #[arg(long)]
    pub raw: bool,
    /// σ of one polygon reading, arcsec (default: from the polygon's own residuals).
    #[arg(long, value_parser = flag::real(flag::SIGMA_ARCSEC))]
    pub sigma_polygon: Option<f64>,
    /// σ of one head reading (or difference, per --noise-model), arcsec (default: from the
    /// heads' own residuals).
    #[arg(long, value_parser = flag::real(flag::SIGMA_ARCSEC))]
    pub sigma_heads: Option<f64>,
    /// Heads' noise: `readings` (each head reading has its own noise) or `differences`.
    #[arg(long, value_enum, default_value_t, hide_possible_values = true)]
    pub noise_model: NoiseModel,
    /// Head angles in the heads' model: `measured` (nominal + each head's mean difference) or
    /// `nominal`.
    #[arg(long, value_enum, default_value_t, hide_possible_values = true)]
    pub head_angles: HeadAngles,
    /// The scale error between rotation positions: `linear` (as between graduation lines) or
    /// `trigonometric` (band-limited).
    #[arg(long, value_enum, default_value_t, hide_possible_values = true)]
    pub interpolation: Interpolation,
    /// Largest order of the harmonic table and the blind lists.
    #[arg(long, default_value_t = 360, value_parser = flag::whole::<u32>(flag::MAX_ORDER))]
    pub max_order: u32,
    /// Highest heads-blind order the polygon is asked to resolve (default: half the number of
    /// distinct polygon angles).
    #[arg(long, value_parser = flag::whole::<u32>(flag::MAX_ORDER))]
    pub blind_max_order: Option<u32>,
    /// Instrument terms (TOML, see examples/instrument-shift-angle.toml) combined with the
    /// random part into u, ν_eff, k and U of every angle.
    #[arg(long)]
    pub instrument: Option<PathBuf>,
    /// Coverage probability of U (default: the instrument file's, else 0.95).
    #[arg(long, value_parser = flag::real(gonio_uncertainty::COVERAGE))]
    pub coverage: Option<f64>,
    // `--json` and `--db`, shared with the other calibration commands.
    #[command(flatten)]
    pub to: db::CertificateTargets,
    /// Certificate metadata (TOML, ISO/IEC 17025 §7.8), carried in the certificate. See
    /// examples/certificate-meta.toml.
    #[arg(long)]
    pub meta: Option<PathBuf>,
    /// Write the compensation table `angle_deg,correction_arcsec` (correction = −α).
    #[arg(long)]
    pub compensation: Option<PathBuf>,
}

/// Runs `gonio joint`.
pub fn run(args: Args) -> Result<()> {
    check(args.faces, args.max_order, args.blind_max_order)?;
    let mut out = Outputs::new();
    if let Some(loc) = &args.to.db {
        db::reserve(out.inputs(), loc);
    }
    let json = out.optional("--json", args.to.json.as_deref())?;
    let comp = out.optional("--compensation", args.compensation.as_deref())?;
    let (heads, _) = heads::load(out.inputs(), &args.heads)?;
    let request = Request {
        readings: Table::File(args.readings.clone()),
        heads_readings: Table::File(args.heads_readings.clone()),
        faces: args.faces,
        heads,
        raw: args.raw,
        sigma_polygon_arcsec: args.sigma_polygon,
        sigma_heads_arcsec: args.sigma_heads,
        noise_model: args.noise_model,
        head_angles: args.head_angles,
        interpolation: args.interpolation,
        max_order: args.max_order,
        blind_max_order: args.blind_max_order,
        instrument: args.instrument.clone().map(Document::File),
        coverage: args.coverage,
        meta: args.meta.clone().map(Document::File),
    };
    let cert = evaluate(out.inputs(), request)?;
    let to_stdout = out.to_stdout(json);
    out.certificate(json, comp, &cert)?;
    if !to_stdout {
        gonio_cli::term::out(&summary(&cert))?;
    }
    out.commit()?;
    if let Some(loc) = &args.to.db {
        db::store_certificate(
            loc,
            &cert,
            &format!(
                "{} + {}",
                args.readings.display(),
                args.heads_readings.display()
            ),
        )?;
    }
    if !to_stdout {
        for p in [&args.to.json, &args.compensation].into_iter().flatten() {
            gonio_cli::note!("wrote {}", p.display());
        }
    }
    Ok(())
}

fn list(orders: &[u32]) -> String {
    if orders.is_empty() {
        "none".into()
    } else if orders.len() > 10 {
        format!("{:?}… ({} orders)", &orders[..10], orders.len())
    } else {
        format!("{orders:?}")
    }
}

fn summary(cert: &Certificate) -> String {
    let mut out = String::new();
    let Some(j) = &cert.joint else {
        return out;
    };
    let sigma = |s: &SigmaUsed| {
        if s.stated {
            format!("{:.4}″ (stated)", s.sigma_arcsec)
        } else {
            format!(
                "{:.4}″ (residuals, ν = {})",
                s.sigma_arcsec,
                crate::table::dof_text(s.dof)
            )
        }
    };
    let _ = writeln!(out, "{}", cert.procedure.title());
    let _ = writeln!(
        out,
        "  polygon            {} faces, {} shifts, {} readings; σ {}",
        j.faces,
        j.shifts_deg.len(),
        j.readings,
        sigma(&j.sigma_polygon)
    );
    let _ = writeln!(
        out,
        "  heads              {} heads × {} positions; σ {}",
        j.heads_deg.len(),
        j.positions,
        sigma(&j.sigma_heads)
    );
    worst_angle(&mut out, cert, j);
    let b = &j.blind_orders;
    let _ = writeln!(
        out,
        "  blind, up to {:<5} polygon {}; heads {}",
        b.max_order,
        list(&b.polygon),
        list(&b.heads)
    );
    let _ = writeln!(
        out,
        "  joint              sees {} from the polygon alone; still invisible: {}",
        list(&b.from_polygon),
        list(&b.joint)
    );
    let mut top: Vec<&JointHarmonic> = j.harmonics.iter().filter(|h| h.estimated).collect();
    top.sort_by(|a, b| b.amplitude_arcsec.total_cmp(&a.amplitude_arcsec));
    let _ = writeln!(
        out,
        "  largest harmonics  (order: amplitude ± u, heads' share of the information)"
    );
    for h in top.iter().take(6) {
        let _ = writeln!(
            out,
            "    {:>5}: {:.5}″ ± {:.5}″, heads {:>5.1} %",
            h.order,
            h.amplitude_arcsec,
            0.5 * (h.u_cos_arcsec + h.u_sin_arcsec),
            100.0 * h.heads_share
        );
    }
    if let Some(c) = &j.consistency {
        let _ = writeln!(
            out,
            "  agreement          Δχ² = {:.1} for {} dof, P = {:.3}: {}",
            c.chi2,
            c.dof,
            c.p_upper,
            if c.consistent {
                "the instruments agree"
            } else {
                "the instruments DISAGREE (check the set-up, the heads' angles, σ)"
            }
        );
    }
    out
}

/// The angle with the largest u: its value range, its u split and each method's own u.
fn worst_angle(out: &mut String, cert: &Certificate, j: &JointSection) {
    let Some((i, w)) = cert
        .points
        .iter()
        .enumerate()
        .max_by(|a, b| a.1.u_arcsec.total_cmp(&b.1.u_arcsec))
    else {
        return;
    };
    let r = &j.random_part[i];
    let _ = writeln!(
        out,
        "  encoder error α    {} angles, largest |α| {:.4}″; largest u {:.4}″ (heads {:.4}″, polygon {:.4}″){}",
        cert.points.len(),
        cert.max_abs_error_arcsec(),
        w.u_arcsec,
        r.u_heads_arcsec,
        r.u_polygon_arcsec,
        w.expanded_arcsec.map_or(String::new(), |x| format!(
            ", U {x:.4}″ (k = {})",
            crate::table::fixed(w.k, 3)
        ))
    );
    let _ = writeln!(
        out,
        "  each alone         heads {:.4}″, polygon {} at {}°",
        r.u_heads_alone_arcsec,
        r.u_polygon_alone_arcsec
            .map_or("–".into(), |u| format!("{u:.4}″")),
        w.angle_deg
    );
}
