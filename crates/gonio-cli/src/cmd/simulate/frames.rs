//! `gonio simulate frames`: rendered camera frames of a rotating, eccentric grating, with truth.

use crate::cmd::detect::load_optics;
use crate::io;
use anyhow::{Result, bail};
use gonio_sim::frames::{FrameTruth, GratingRenderer, GratingScene};
use serde::Serialize;
use std::path::PathBuf;

/// Arguments of `gonio simulate frames`.
#[derive(Debug, clap::Args)]
#[command(after_help = "\
Writes DIR/frame_00000.png … (8-bit grey, the optics' window), DIR/angles.csv
(frame,theta_deg,time_s; for `gonio detect --angles`) and DIR/truth.json (per frame θ, the ring
centre line's mean column c_true_px over the window's rows, the focus position; the optics and
scene used).

Examples:
  gonio simulate frames --count 200 --eccentricity-um 120 --seed 1 --out frames
  gonio simulate frames --count 20 --defocus 60 --noise 4 --dust 40 --seed 2 --out blurry
  gonio simulate frames --count 5 --no-ring --seed 3 --out empty")]
pub struct Args {
    /// Number of frames.
    #[arg(long)]
    pub count: usize,
    /// Eccentricity of the grating on the shaft, µm.
    #[arg(long, default_value_t = 100.0)]
    pub eccentricity_um: f64,
    /// Eccentricity angle in the grating's frame, degrees.
    #[arg(long, default_value_t = 30.0)]
    pub ecc_angle_deg: f64,
    /// Read noise, grey levels RMS (shot noise is added on top; 0 with --no-shot-noise).
    #[arg(long, default_value_t = 2.0)]
    pub noise: f64,
    /// No shot noise.
    #[arg(long)]
    pub no_shot_noise: bool,
    /// Dust specks per frame.
    #[arg(long, default_value_t = 12)]
    pub dust: usize,
    /// Focus position relative to best focus, µm (blur σ = √(σ₀² + (NA·Δz/2)²)).
    #[arg(long, default_value_t = 0.0, allow_hyphen_values = true)]
    pub defocus: f64,
    /// Exposure factor (above ≈ 1.3 the background saturates).
    #[arg(long, default_value_t = 1.0)]
    pub exposure: f64,
    /// No alignment ring (a frame the detector must call ring-less).
    #[arg(long)]
    pub no_ring: bool,
    /// No code tracks.
    #[arg(long)]
    pub no_tracks: bool,
    /// Table speed, degrees per second.
    #[arg(long, default_value_t = 180.0)]
    pub speed_deg_s: f64,
    /// Frame rate, frames per second.
    #[arg(long, default_value_t = 100.0)]
    pub fps: f64,
    /// θ of frame 0, degrees.
    #[arg(long, default_value_t = 0.0, allow_hyphen_values = true)]
    pub start_deg: f64,
    /// Optics TOML (as for `gonio detect --optics`).
    #[arg(long, value_name = "OPTICS.toml")]
    pub optics: Option<PathBuf>,
    /// Seed of noise and dust.
    #[arg(long)]
    pub seed: u64,
    /// Output directory.
    #[arg(long)]
    pub out: PathBuf,
}

#[derive(Serialize)]
struct TruthFrame {
    frame: usize,
    file: String,
    time_s: f64,
    #[serde(flatten)]
    truth: FrameTruth,
}

/// Runs `gonio simulate frames`.
pub fn run(a: Args) -> Result<()> {
    if a.count == 0 {
        bail!("--count 0: expected at least one frame");
    }
    if !a.fps.is_finite() || a.fps <= 0.0 || !a.speed_deg_s.is_finite() {
        bail!(
            "--speed-deg-s {} --fps {}: expected a finite speed and fps > 0",
            a.speed_deg_s,
            a.fps
        );
    }
    let optics = load_optics(a.optics.as_deref())?;
    let scene = GratingScene {
        ring_present: !a.no_ring,
        code_tracks: !a.no_tracks,
        dust_per_frame: a.dust,
        read_noise_grey: a.noise,
        electrons_per_grey: if a.no_shot_noise {
            0.0
        } else {
            GratingScene::default().electrons_per_grey
        },
        exposure: a.exposure,
        ..GratingScene::default()
    };
    let r = GratingRenderer::new(&optics, scene)?;
    io::ensure_dir(&a.out)?;
    let (w, h) = r.size();
    let mut buf = vec![0u8; r.frame_len()];
    let mut truths = Vec::with_capacity(a.count);
    let mut csv = Vec::with_capacity(a.count);
    let bar = indicatif::ProgressBar::new(a.count as u64);
    for k in 0..a.count {
        let t = k as f64 / a.fps;
        let theta = a.start_deg + a.speed_deg_s * t;
        let seed = a
            .seed
            .wrapping_mul(0x9E37_79B9_7F4A_7C15)
            .wrapping_add(k as u64);
        let truth = r.render(
            theta,
            a.eccentricity_um,
            a.ecc_angle_deg,
            a.defocus,
            seed,
            &mut buf,
        )?;
        let name = format!("frame_{k:05}.png");
        let img = image::GrayImage::from_raw(w as u32, h as u32, buf.clone())
            .ok_or_else(|| anyhow::anyhow!("frame buffer size"))?;
        let mut bytes = Vec::new();
        img.write_to(
            &mut std::io::Cursor::new(&mut bytes),
            image::ImageFormat::Png,
        )?;
        io::write_atomic(&a.out.join(&name), &bytes)?;
        csv.push(vec![k.to_string(), format!("{theta}"), format!("{t}")]);
        truths.push(TruthFrame {
            frame: k,
            file: name,
            time_s: t,
            truth,
        });
        bar.inc(1);
    }
    bar.finish_and_clear();
    io::write_csv(
        &a.out.join("angles.csv"),
        &["frame", "theta_deg", "time_s"],
        &csv,
    )?;
    io::write_json(
        &a.out.join("truth.json"),
        &serde_json::json!({
            "format": "gonio-frames-truth",
            "version": 1,
            "width_px": w,
            "height_px": h,
            "seed": a.seed,
            "optics": r.optics(),
            "scene": r.scene(),
            "frames": truths,
        }),
    )?;
    eprintln!(
        "{} frames of {w}×{h} written to {}",
        a.count,
        a.out.display()
    );
    Ok(())
}
