//! `gonio simulate frames`: rendered camera frames of a rotating, eccentric grating, with truth.

use super::SceneArg;
use anyhow::{Result, bail};
use gonio_cli::flag;
use gonio_cli::output::Outputs;
use gonio_core::bound::Bound;
use gonio_io::formats::frames::{load_optics, load_scene};
use gonio_io::input::Inputs;
use gonio_sim::frames::{
    FrameTruth, GratingScene, RenderedFrames, SceneChoice, SceneDraw, SceneFamily, ScenePreset,
    Turn,
};
use gonio_sim::frames::{MAX_FEATURES, scene};
use gonio_vision::FrameSource;
use serde::Serialize;
use std::path::PathBuf;

/// Arguments of `gonio simulate frames`.
#[derive(Debug, clap::Args)]
#[command(after_help = "\
Writes DIR/frame_00000.png … (8-bit grey, the optics' window), DIR/angles.csv
(frame,theta_deg,time_s; for `gonio detect --angles`) and DIR/truth.json (per frame θ, the ring
centre line's mean column c_true_px over the window's rows, the ring's width and visible contrast,
the focus position; the optics and scene used; with --scene random, each frame's drawn scene).
With --raw also DIR/frames.raw: the same frames back to back as raw 8-bit pixels, as a camera
streams them (`gonio detect --raw WIDTHxHEIGHT < DIR/frames.raw`).

Scenes (docs/scenes.md describes the features and the ranges of the random family):
  clean      the ring alone
  realistic  track-border circles on both sides, incremental lines, code bars, dust, vignetting
  dense      everything at once and close to the ring
  random     every parameter drawn from the family, a new scene per frame
--scene-file SCENE.toml gives every field yourself (a truth.json's \"scene\" is a valid start).

Examples:
  gonio simulate frames --count 200 --eccentricity-um 120 --seed 1 --out frames
  gonio simulate frames --scene dense --count 20 --defocus 60 --noise 4 --seed 2 --out dense
  gonio simulate frames --scene random --count 500 --seed 3 --out family
  gonio simulate frames --scene-file my-grating.toml --count 50 --seed 4 --out mine
  gonio simulate frames --count 5 --no-ring --seed 5 --out empty
  gonio simulate frames --scene dense --count 400 --seed 1 --raw --out dense")]
pub struct Args {
    /// Number of frames (1 to 1000000).
    #[arg(long, value_parser = flag::whole::<usize>(COUNT))]
    pub count: usize,
    /// The scene.
    #[arg(
        long,
        value_enum,
        default_value = "realistic",
        conflicts_with = "scene_file"
    )]
    pub scene: SceneArg,
    /// A scene TOML file (every feature as data; see docs/scenes.md).
    #[arg(long, value_name = "SCENE.toml")]
    pub scene_file: Option<PathBuf>,
    /// Eccentricity of the grating on the shaft, µm.
    #[arg(long, default_value_t = 100.0, allow_hyphen_values = true, value_parser = flag::real(flag::ECCENTRICITY_UM))]
    pub eccentricity_um: f64,
    /// Eccentricity angle in the grating's frame, degrees.
    #[arg(long, default_value_t = 30.0, allow_hyphen_values = true, value_parser = flag::real(flag::ANGLE_DEG))]
    pub ecc_angle_deg: f64,
    /// Read noise, grey levels RMS (default: the scene's; shot noise is added on top).
    #[arg(long, value_parser = flag::real(scene::READ_NOISE_GREY))]
    pub noise: Option<f64>,
    /// No shot noise.
    #[arg(long)]
    pub no_shot_noise: bool,
    /// Dust specks per frame (default: the scene's).
    #[arg(long, value_parser = flag::whole::<usize>(DUST))]
    pub dust: Option<usize>,
    /// Focus position relative to best focus, µm (blur σ = √(σ₀² + (NA·Δz/2)²)).
    #[arg(long, default_value_t = 0.0, allow_hyphen_values = true, value_parser = flag::real(scene::FOCUS_UM))]
    pub defocus: f64,
    /// Exposure factor (above ≈ 1.3 the background saturates; default: the scene's).
    #[arg(long, value_parser = flag::real(scene::EXPOSURE))]
    pub exposure: Option<f64>,
    /// No alignment ring (a frame the detector must call ring-less).
    #[arg(long)]
    pub no_ring: bool,
    /// No code tracks and no track borders.
    #[arg(long)]
    pub no_tracks: bool,
    /// Table speed, degrees per second.
    #[arg(long, default_value_t = 180.0, allow_hyphen_values = true, value_parser = flag::real(flag::SPEED_DEG_S))]
    pub speed_deg_s: f64,
    /// Frame rate, frames per second.
    #[arg(long, default_value_t = 100.0, value_parser = flag::real(flag::FPS))]
    pub fps: f64,
    /// θ of frame 0, degrees.
    #[arg(long, default_value_t = 0.0, allow_hyphen_values = true, value_parser = flag::real(flag::ANGLE_DEG))]
    pub start_deg: f64,
    /// Optics TOML (as for `gonio detect --optics`).
    #[arg(long, value_name = "OPTICS.toml")]
    pub optics: Option<PathBuf>,
    /// Seed of noise, dust and (with --scene random) the scenes.
    #[arg(long)]
    pub seed: u64,
    /// Output directory (new or empty; see --force).
    #[arg(long)]
    pub out: PathBuf,
    /// Also write DIR/frames.raw: the frames back to back, raw 8-bit (for `gonio detect --raw`).
    #[arg(long)]
    pub raw: bool,
    /// Write into a non-empty output directory: its frames, angles and truth are replaced, and
    /// frames of an earlier, longer run are removed (so `gonio detect DIR` never reads them).
    #[arg(long)]
    pub force: bool,
}

#[derive(Serialize)]
struct TruthFrame {
    frame: usize,
    file: String,
    time_s: f64,
    #[serde(flatten)]
    truth: FrameTruth,
    #[serde(skip_serializing_if = "Option::is_none")]
    scene: Option<GratingScene>,
}

impl Args {
    /// The scene with the command line's overrides applied.
    fn scene(&self, inputs: &Inputs) -> Result<SceneChoice> {
        let overrides = self.noise.is_some()
            || self.no_shot_noise
            || self.dust.is_some()
            || self.exposure.is_some()
            || self.no_ring
            || self.no_tracks;
        let mut s = match (&self.scene_file, self.scene) {
            (Some(p), _) => load_scene(inputs, p)?,
            (None, SceneArg::Random) => {
                if overrides {
                    bail!(
                        "--scene random draws every parameter from the family: --noise, --dust, \
                         --exposure, --no-ring, --no-shot-noise and --no-tracks do not apply"
                    );
                }
                return Ok(SceneChoice::Random(Box::default()));
            }
            (None, SceneArg::Clean) => GratingScene::preset(ScenePreset::Clean),
            (None, SceneArg::Realistic) => GratingScene::preset(ScenePreset::Realistic),
            (None, SceneArg::Dense) => GratingScene::preset(ScenePreset::Dense),
        };
        if let Some(n) = self.noise {
            s.read_noise_grey = n;
        }
        if self.no_shot_noise {
            s.electrons_per_grey = 0.0;
        }
        if let Some(d) = self.dust {
            s.dust_per_frame = d;
        }
        if let Some(x) = self.exposure {
            s.exposure = x;
        }
        if self.no_ring {
            s.ring_present = false;
        }
        if self.no_tracks {
            s.code_tracks = false;
            s.track_borders.clear();
        }
        Ok(SceneChoice::Scene(Box::new(s)))
    }
}

/// `--count`: frames in one run.
const COUNT: Bound = Bound::new(1.0, 1e6, "frames");
/// `--dust`: specks per frame.
const DUST: Bound = Bound::new(0.0, MAX_FEATURES as f64, "");

/// Runs `gonio simulate frames`.
pub fn run(a: Args) -> Result<()> {
    let inputs = Inputs::new();
    let optics = load_optics(&inputs, a.optics.as_deref())?;
    let choice = a.scene(&inputs)?;
    let random = matches!(choice, SceneChoice::Random(_));
    let turn = Turn {
        start_deg: a.start_deg,
        speed_deg_s: a.speed_deg_s,
        fps: a.fps,
        eccentricity_um: a.eccentricity_um,
        ecc_angle_deg: a.ecc_angle_deg,
        focus_um: a.defocus,
        ..Turn::default()
    };
    let mut src = RenderedFrames::new(&optics, choice, turn, a.count as u64, a.seed)?;
    let mut out = Outputs::with_inputs(inputs);
    out.dir("--out", &a.out, a.force)?;
    out.remove_stale(&a.out, "frame_", ".png");
    let mut buf = Vec::new();
    let mut truths = Vec::with_capacity(a.count);
    let mut csv = Vec::with_capacity(a.count);
    let (mut w, mut h) = (0, 0);
    let bar = indicatif::ProgressBar::new(a.count as u64);
    let raw_path = a.out.join("frames.raw");
    let raw = if a.raw {
        Some(out.file("--raw", &raw_path)?)
    } else {
        None
    };
    while let Some(hdr) = src.next_frame(&mut buf)? {
        if let Some(id) = raw {
            out.write(id, &buf)?;
        }
        let k = hdr.stamp.index as usize;
        (w, h) = (hdr.width, hdr.height);
        let t = k as f64 / a.fps;
        let theta = hdr.stamp.theta_deg.unwrap_or(f64::NAN);
        let name = format!("frame_{k:05}.png");
        let img = image::GrayImage::from_raw(w as u32, h as u32, std::mem::take(&mut buf))
            .ok_or_else(|| anyhow::anyhow!("frame buffer size"))?;
        let mut bytes = Vec::new();
        img.write_to(
            &mut std::io::Cursor::new(&mut bytes),
            image::ImageFormat::Png,
        )?;
        buf = img.into_raw();
        out.put("--out", &a.out.join(&name), &bytes)?;
        csv.push(vec![k.to_string(), format!("{theta}"), format!("{t}")]);
        let truth = *src
            .last_truth()
            .ok_or_else(|| anyhow::anyhow!("renderer gave no truth"))?;
        truths.push(TruthFrame {
            frame: k,
            file: name,
            time_s: t,
            truth,
            scene: src.last_draw().map(|d: &SceneDraw| d.scene.clone()),
        });
        bar.inc(1);
    }
    bar.finish_and_clear();
    let angles = out.file("--out", &a.out.join("angles.csv"))?;
    out.csv(angles, &["frame", "theta_deg", "time_s"], &csv)?;
    let scene = if random {
        serde_json::json!({"random": SceneFamily::default()})
    } else {
        serde_json::to_value(src.renderer().scene())?
    };
    let truth = out.file("--out", &a.out.join("truth.json"))?;
    // A frame without a ring has no true column: NaN, written as null on purpose.
    out.json_with_nulls(
        truth,
        &serde_json::json!({
            "format": "gonio-frames-truth",
            "version": 2,
            "width_px": w,
            "height_px": h,
            "seed": a.seed,
            "optics": optics,
            "scene": scene,
            "frames": truths,
        }),
    )?;
    out.commit()?;
    gonio_cli::note!(
        "{} frames of {w}×{h} written to {}",
        a.count,
        a.out.display()
    );
    Ok(())
}
