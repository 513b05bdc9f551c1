//! `gonio simulate camera`: a GigE Vision camera (Aravis's fake camera, in-process) showing the
//! renderer's frames of a turning, eccentric grating.

use super::SceneArg;
use anyhow::{Result, bail};
use gonio_cli::flag;
use gonio_core::bound::{Bound, Num};
use std::path::PathBuf;

/// Arguments of `gonio simulate camera`.
#[derive(Debug, clap::Args)]
#[command(after_help = "\
Serves a GigE Vision camera (id Aravis-Fake-SERIAL, port 3956 of --addr) whose frames are the
renderer's (as `gonio simulate frames` draws them) of a grating turning at --speed-deg-s with
the given eccentricity. One turn is rendered before serving starts (360·fps/speed frames, which
must be a whole number; the same seed gives the same bytes) and served over and over, so the
camera keeps up at 100 frames/s on one core: serving a frame is one copy. The client's window
(Width × Height) gets the rendered window (the optics', default 1440×540) from its top-left
corner; set the client to the same window (`gonio detect --camera` does, from the same optics).
Frames are served free running at --fps; the k-th frame served is rendered at
θ = start + k·speed/fps. Ctrl-C (or --duration-s) stops, and the frames served, the fill time
per frame and the CPU time per frame are printed on standard error.

Needs a build with `--features genicam`. One GigE Vision camera per address: run it in its own
network namespace to keep it apart from others (docs/camera.md).

Examples:
  gonio simulate camera --eccentricity-um 40 --seed 1
  gonio simulate camera --serial LINE2 --scene dense --fps 100 --speed-deg-s 180 --duration-s 60
  gonio detect --camera Aravis-Fake-GONIO01 --frames 200 --speed-deg-s 180 --fps 100")]
pub struct Args {
    /// The interface address to serve on (loopback only in tests).
    #[arg(long, default_value = "127.0.0.1")]
    pub addr: String,
    /// The camera's serial number (its id is Aravis-Fake-SERIAL).
    #[arg(long, default_value = "GONIO01")]
    pub serial: String,
    /// The scene.
    #[arg(long, value_enum, default_value = "realistic")]
    pub scene: SceneArg,
    /// Eccentricity of the grating on the shaft, µm.
    #[arg(long, default_value_t = 100.0, allow_hyphen_values = true, value_parser = flag::real(flag::ECCENTRICITY_UM))]
    pub eccentricity_um: f64,
    /// Eccentricity angle in the grating's frame, degrees.
    #[arg(long, default_value_t = 30.0, allow_hyphen_values = true, value_parser = flag::real(flag::ANGLE_DEG))]
    pub ecc_angle_deg: f64,
    /// Table speed, degrees per second.
    #[arg(long, default_value_t = 180.0, value_parser = flag::real(SPEED_DEG_S))]
    pub speed_deg_s: f64,
    /// Frame rate, frames per second (at most 10000).
    #[arg(long, default_value_t = 100.0, value_parser = flag::real(FPS))]
    pub fps: f64,
    /// θ of the first frame served, degrees.
    #[arg(long, default_value_t = 0.0, allow_hyphen_values = true, value_parser = flag::real(flag::ANGLE_DEG))]
    pub start_deg: f64,
    /// Optics TOML (as for `gonio detect --optics`).
    #[arg(long, value_name = "OPTICS.toml")]
    pub optics: Option<PathBuf>,
    /// Seed of the rendered turn's noise and dust.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Stop after this many seconds (default: until Ctrl-C).
    #[arg(long, value_parser = flag::real(flag::DURATION_S))]
    pub duration_s: Option<f64>,
    /// Drop this fraction of the stream's packets (0 … 1), as a bad link would.
    #[arg(long, default_value_t = 0.0, value_parser = flag::real(flag::FRACTION))]
    pub lost_ratio: f64,
}

/// `--speed-deg-s`: one way round (the turn is pre-rendered).
const SPEED_DEG_S: Bound = Bound::new(0.0, 1e6, "°/s").lo_excluded();
/// `--fps`: what one process can render and serve.
const FPS: Bound = Bound::new(0.0, 10_000.0, "frames/s").lo_excluded();

/// Most bytes of one pre-rendered turn.
#[cfg(feature = "genicam")]
const MAX_TURN_BYTES: f64 = 1.5e9;

/// Runs `gonio simulate camera`.
pub fn run(a: Args) -> Result<()> {
    let per_turn = 360.0 * a.fps / a.speed_deg_s;
    if (per_turn - per_turn.round()).abs() > 1e-6 || per_turn.round() < 1.0 {
        bail!(
            "--fps {} --speed-deg-s {}: a turn must be a whole number of frames (360·fps/speed = {})",
            Num(a.fps),
            Num(a.speed_deg_s),
            Num(per_turn)
        );
    }
    serve(a, per_turn.round() as u64)
}

#[cfg(not(feature = "genicam"))]
fn serve(_: Args, _: u64) -> Result<()> {
    Err(gonio_camera::CameraError::NotBuilt.into())
}

#[cfg(feature = "genicam")]
fn serve(a: Args, per_turn: u64) -> Result<()> {
    use gonio_camera::{FakeConfig, FakeGvCamera, FillInfo};
    use gonio_io::formats::frames::load_optics;
    use gonio_sim::frames::{GratingScene, RenderedFrames, SceneChoice, ScenePreset, Turn};
    use gonio_vision::FrameSource;
    use std::sync::atomic::{AtomicBool, Ordering};
    use std::sync::{Arc, Mutex};
    use std::time::{Duration, Instant};

    let optics = load_optics(&gonio_io::input::Inputs::new(), a.optics.as_deref())?;
    let (w, h) = (
        optics.window_width_px as usize,
        optics.window_height_px as usize,
    );
    if per_turn as f64 * (w * h) as f64 > MAX_TURN_BYTES {
        bail!(
            "one turn is {per_turn} frames of {w}×{h}: more than {:.1} GB to pre-render; raise \
             --speed-deg-s or lower --fps",
            MAX_TURN_BYTES / 1e9
        );
    }
    let choice = match a.scene {
        SceneArg::Clean => SceneChoice::Scene(Box::new(GratingScene::preset(ScenePreset::Clean))),
        SceneArg::Realistic => {
            SceneChoice::Scene(Box::new(GratingScene::preset(ScenePreset::Realistic)))
        }
        SceneArg::Dense => SceneChoice::Scene(Box::new(GratingScene::preset(ScenePreset::Dense))),
        SceneArg::Random => SceneChoice::Random(Box::default()),
    };
    let turn = Turn {
        start_deg: a.start_deg,
        speed_deg_s: a.speed_deg_s,
        fps: a.fps,
        eccentricity_um: a.eccentricity_um,
        ecc_angle_deg: a.ecc_angle_deg,
        ..Turn::default()
    };
    let t0 = Instant::now();
    let mut src = RenderedFrames::new(&optics, choice, turn, per_turn, a.seed)?;
    let mut frames = Vec::with_capacity(per_turn as usize);
    let mut buf = Vec::new();
    while let Some(_hdr) = src.next_frame(&mut buf)? {
        frames.push(std::mem::take(&mut buf));
    }
    let rendered_s = t0.elapsed().as_secs_f64();
    let frames = Arc::new(frames);
    // Fill time per frame (thread CPU, s), kept for the summary.
    let fill_s = Arc::new(Mutex::new(Vec::<f64>::new()));
    // When the first and the latest frame were filled: the rate while a client acquires (the
    // camera fills nothing before its AcquisitionStart).
    let span = Arc::new(Mutex::new(None::<(Instant, Instant)>));
    let (turn_frames, fill_log, fill_span) = (frames.clone(), fill_s.clone(), span.clone());
    let fill = move |f: &FillInfo, px: &mut [u8]| {
        let c0 = thread_cpu_s();
        if let Ok(mut s) = fill_span.lock() {
            let now = Instant::now();
            *s = Some(s.map_or((now, now), |(first, _)| (first, now)));
        }
        let frame = &turn_frames[(f.index % turn_frames.len() as u64) as usize];
        let (cw, ch) = (f.width as usize, f.height as usize);
        if cw == w && ch == h {
            px[..w * h].copy_from_slice(frame);
        } else {
            // Another window: the rendered one from its top-left corner, mid-grey elsewhere.
            px.fill(128);
            for (y, row) in px.chunks_mut(cw).take(ch.min(h)).enumerate() {
                let n = cw.min(w);
                row[..n].copy_from_slice(&frame[y * w..y * w + n]);
            }
        }
        if let Ok(mut l) = fill_log.lock()
            && l.len() < 1_000_000
        {
            l.push(thread_cpu_s() - c0);
        }
    };
    let config = FakeConfig {
        address: a.addr.clone(),
        serial: a.serial.clone(),
        fps: a.fps,
        sensor: (optics.sensor_width_px, optics.sensor_height_px),
        lost_ratio: a.lost_ratio,
    };
    let cam = FakeGvCamera::start(&config, fill)?;
    gonio_cli::note!(
        "serving {} on {} port 3956: one turn of {per_turn} frames of {w}×{h} ({:?} scene, \
         e = {} µm) rendered in {rendered_s:.1} s; {} frames/s at {} °/s; Ctrl-C stops",
        cam.id(),
        a.addr,
        a.scene,
        a.eccentricity_um,
        a.fps,
        a.speed_deg_s
    );
    let stop = Arc::new(AtomicBool::new(false));
    #[cfg(unix)]
    for sig in [signal_hook::consts::SIGINT, signal_hook::consts::SIGTERM] {
        signal_hook::flag::register(sig, stop.clone())?;
    }
    let started = Instant::now();
    let cpu0 = process_cpu_s();
    let served0 = cam.frames_served();
    while !stop.load(Ordering::Relaxed)
        && a.duration_s
            .is_none_or(|d| started.elapsed().as_secs_f64() < d)
    {
        std::thread::sleep(Duration::from_millis(50));
    }
    let dt = started.elapsed().as_secs_f64();
    let cpu = process_cpu_s() - cpu0;
    let served = cam.frames_served() - served0;
    let wakeups = cam.wakeups();
    drop(cam);
    let mut fills = fill_s.lock().map(|l| l.clone()).unwrap_or_default();
    fills.sort_by(f64::total_cmp);
    let q = |p: f64| gonio_core::quantile::quantile_sorted(&fills, p).map_or(0.0, |x| x * 1e3);
    // Frames per second from the first filled frame to the last (the frame rate a client sees).
    let acquiring = span
        .lock()
        .ok()
        .and_then(|s| *s)
        .map(|(first, last)| (last - first).as_secs_f64())
        .filter(|&t| t > 0.0 && served > 1)
        .map_or_else(String::new, |t| {
            format!(
                ", {:.2} frames/s from the first frame filled to the last ({t:.1} s)",
                (served - 1) as f64 / t
            )
        });
    gonio_cli::note!(
        "served {served} frames in {dt:.1} s ({:.1} frames/s{acquiring}); fill {:.3} ms median, \
         {:.3} ms 99th percentile; CPU of the whole process {:.3} ms per frame served; \
         {wakeups} GVCP reads sent to wake a stalled camera thread",
        served as f64 / dt.max(1e-9),
        q(0.5),
        q(0.99),
        if served > 0 {
            cpu * 1e3 / served as f64
        } else {
            0.0
        }
    );
    Ok(())
}

/// The calling thread's CPU time, s.
#[cfg(feature = "genicam")]
fn thread_cpu_s() -> f64 {
    let t = rustix::time::clock_gettime(rustix::time::ClockId::ThreadCPUTime);
    t.tv_sec as f64 + t.tv_nsec as f64 * 1e-9
}

/// The process's CPU time (every thread), s.
#[cfg(feature = "genicam")]
fn process_cpu_s() -> f64 {
    let t = rustix::time::clock_gettime(rustix::time::ClockId::ProcessCPUTime);
    t.tv_sec as f64 + t.tv_nsec as f64 * 1e-9
}
