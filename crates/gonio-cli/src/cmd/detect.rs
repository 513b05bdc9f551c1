//! `gonio detect`: run the streaming ring detector on image files or raw frames from standard
//! input, one JSON line per frame.

use anyhow::{Result, anyhow, bail};
use gonio_cli::formats::angles::{self, AngleLog};
use gonio_cli::formats::csv::CsvTable;
use gonio_cli::formats::frames::{FileFrames, list_frames, load_optics, parse_raw_size};
use gonio_cli::output::{OutId, Outputs};
use gonio_cli::results::detect::Line;
use gonio_vision::reference::{Image, label};
use gonio_vision::{
    DetectInOrderError, Detection, Detector, FrameResult, FrameSource, Optics, RawFrames,
    SourceDetector, SourceError, detect_in_order,
};
use serde::Serialize;
use std::path::{Path, PathBuf};

/// Arguments of `gonio detect`.
#[derive(Debug, clap::Args)]
#[command(after_help = "\
Frames are 8-bit grey, of the optics' window size (default 1440×540) or its sensor size (then the
centred window is cut out). Each output line: frame, file, theta_deg, time_s, c_px (the ring's
column, px; null when invalid), c_um, valid, reason (no_ring, one_edge, ring_outside_window,
saturated, out_of_focus, inconsistent_edges, ambiguous), score (0–1, the best ring candidate's),
margin (0–1, how far it is ahead of the runner-up; below the optics' min_margin the frame is
ambiguous), c_sigma_px, width_change_px, focus (mean gradient energy, grey²/px²), mean_gradient,
edges [{column_px, slope, pixels, strong, …}].

The ring is chosen by its model (docs/detector.md): a rising and a falling edge a ring width
apart, parallel, over shared rows, with nothing as strong between them; the frame is ambiguous
rather than guessed when two such candidates score alike.

Examples:
  gonio simulate frames --count 200 --eccentricity-um 120 --seed 1 --out frames
  gonio detect frames --angles frames/angles.csv --json-lines c.jsonl
  ffmpeg -i run.avi -f rawvideo -pix_fmt gray - | gonio detect --raw 1440x540 --speed-deg-s 180 --fps 100
  gonio detect --raw 1440x540 --threads 2 < frames.raw > c.jsonl
  gonio detect frames --dump-stages vectors --frame 17
  gonio detect --raw 1440x540 --timing < frames.raw > /dev/null

Frames are detected on --threads worker threads (default: all cores) while the main thread
reads the next ones; the lines come out in frame order, the same bytes whatever the thread
count. --dump-stages and --timing run on one thread.")]
pub struct Args {
    /// Image files (PNG, TIFF) or directories of them (read in name order).
    #[arg(
        value_name = "FRAMES",
        required_unless_present = "raw",
        conflicts_with = "raw"
    )]
    pub frames: Vec<PathBuf>,
    /// Read raw 8-bit frames of WIDTHxHEIGHT from standard input.
    #[arg(long, value_name = "WxH")]
    pub raw: Option<String>,
    /// Angle log: CSV `frame,theta_deg[,time_s]`.
    #[arg(long, value_name = "ANGLES.csv", conflicts_with_all = ["speed_deg_s", "fps"])]
    pub angles: Option<PathBuf>,
    /// Constant table speed, degrees per second (with --fps): θ = start + frame·speed/fps.
    #[arg(long, requires = "fps")]
    pub speed_deg_s: Option<f64>,
    /// Frame rate, frames per second (with --speed-deg-s).
    #[arg(long, requires = "speed_deg_s")]
    pub fps: Option<f64>,
    /// θ of frame 0 with --speed-deg-s, degrees.
    #[arg(long, default_value_t = 0.0)]
    pub start_deg: f64,
    /// Optics TOML (sensor, window, pixel pitch, magnification, ring width and radius, polarity,
    /// thresholds…); default: the station of Yu et al., 2024.
    #[arg(long, value_name = "OPTICS.toml")]
    pub optics: Option<PathBuf>,
    /// Write the JSON lines here (default: standard output).
    #[arg(long, value_name = "OUT")]
    pub json_lines: Option<PathBuf>,
    /// Write every stage's output for one frame as PNGs (test vectors) into this directory.
    #[arg(long, value_name = "DIR")]
    pub dump_stages: Option<PathBuf>,
    /// The frame to dump (0-based).
    #[arg(long, default_value_t = 0, requires = "dump_stages")]
    pub frame: usize,
    /// Worker threads detecting frames in parallel (default: all cores; 1 to 256); the output
    /// stays in frame order.
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u16).range(1..=256))]
    pub threads: Option<u16>,
    /// Also time the detector alone: its CPU time per frame (median, 99th percentile, maximum;
    /// reading the frames and writing the lines not counted) on standard error. The frames are
    /// then detected one at a time on the main thread.
    #[arg(long, conflicts_with = "threads")]
    pub timing: bool,
}

enum Angles {
    None,
    Table(AngleLog),
    Speed { start: f64, speed: f64, fps: f64 },
}

impl Angles {
    fn at(&self, k: usize) -> Result<(Option<f64>, Option<f64>)> {
        match self {
            Angles::None => Ok((None, None)),
            Angles::Speed { start, speed, fps } => {
                let t = k as f64 / fps;
                Ok((Some(start + speed * t), Some(t)))
            }
            Angles::Table(log) => match log.at(k) {
                Some((th, t)) => Ok((Some(th), t)),
                None => bail!(
                    "{}: no angle for frame {k}: the angle file covers {} frames",
                    log.name,
                    log.len()
                ),
            },
        }
    }
}

fn load_angles(a: &Args) -> Result<Angles> {
    if let Some(p) = &a.angles {
        return Ok(Angles::Table(angles::from_table(&CsvTable::read(p)?)?));
    }
    if let (Some(speed), Some(fps)) = (a.speed_deg_s, a.fps) {
        if !speed.is_finite() || !fps.is_finite() || fps <= 0.0 {
            bail!("--speed-deg-s {speed} --fps {fps}: expected a finite speed and fps > 0");
        }
        return Ok(Angles::Speed {
            start: a.start_deg,
            speed,
            fps,
        });
    }
    Ok(Angles::None)
}

/// The JSON lines output: a file (whole, renamed into place at the end) or standard output.
struct Sink {
    out: Outputs,
    id: OutId,
}

impl Sink {
    fn line(&mut self, l: &Line) -> Result<()> {
        gonio_cli::output::json::check_finite(l).map_err(|e| anyhow!("frame {}: {e}", l.frame))?;
        let mut v = serde_json::to_vec(l)?;
        v.push(b'\n');
        self.out.write(self.id, &v)
    }
}

/// Runs `gonio detect`.
pub fn run(a: Args) -> Result<()> {
    let mut out = Outputs::new();
    let id = out.file(
        "--json-lines",
        a.json_lines.as_deref().unwrap_or(Path::new("-")),
    )?;
    if let Some(dir) = &a.dump_stages {
        // Stage images of one frame: the directory's files are replaced on every dump.
        out.dir("--dump-stages", dir, true)?;
    }
    let mut sink = Sink { out, id };
    let optics = load_optics(a.optics.as_deref())?;
    let angles = load_angles(&a)?;
    let started = std::time::Instant::now();
    let done = if let Some(size) = &a.raw {
        let (w, h) = parse_raw_size(size, &optics)?;
        // A pipe's default 64 kB buffer costs a dozen reader/writer wake-ups per frame; ask for
        // room for a whole frame (best effort: not a pipe, or over the system's limit, is fine).
        #[cfg(target_os = "linux")]
        let _ = rustix::pipe::fcntl_setpipe_size(std::io::stdin(), (w * h).next_power_of_two());
        let src = RawFrames::new(std::io::stdin(), w, h);
        detect_all(
            &a,
            &angles,
            src,
            &optics,
            &mut sink,
            |_, _| None,
            "standard input",
        )?
    } else {
        let files = list_frames(&a.frames)?;
        if let Angles::Table(log) = &angles
            && let Some(k) = log.first_missing(files.len())
        {
            bail!(
                "{}: no angle for frame {k}: {} frames given, the angle file covers {}",
                log.name,
                files.len(),
                log.len()
            );
        }
        for f in &files {
            gonio_cli::input::record(f);
        }
        detect_all(
            &a,
            &angles,
            FileFrames::new(files, &optics),
            &optics,
            &mut sink,
            |s: &FileFrames, k| s.path(k).map(|p| p.display().to_string()),
            "frame",
        )?
    };
    // The whole frames detected are kept, even when the source failed after them.
    sink.out.commit()?;
    if let Some(e) = done.stream_error {
        return Err(e);
    }
    let (n, valid) = (done.frames, done.valid);
    let dt = started.elapsed().as_secs_f64();
    gonio_cli::note!(
        "{n} frames, {valid} valid, {:.0} frames/s",
        if dt > 0.0 { n as f64 / dt } else { 0.0 }
    );
    Ok(())
}

/// Every frame of the source through the detector, one JSON line each: on worker threads in
/// frame order ([`detect_in_order`]), or one at a time when a frame's stages are dumped.
#[allow(clippy::too_many_arguments)]
fn detect_all<S: FrameSource + Send>(
    a: &Args,
    angles: &Angles,
    source: S,
    optics: &Optics,
    sink: &mut Sink,
    file_of: impl Fn(&S, u64) -> Option<String>,
    what: &str,
) -> Result<Detected>
where
    S::Error: Send,
{
    let um_per_px = optics.params()?.um_per_px;
    let mut done = Detected {
        frames: 0,
        valid: 0,
        stream_error: None,
    };
    let line = |src: &S, d: &Detection, done: &mut Detected, sink: &mut Sink| -> Result<()> {
        let k = d.stamp.index;
        let (theta, time) = angles.at(k as usize)?;
        done.valid += d.result.valid as usize;
        done.frames += 1;
        sink.line(&Line::new(
            k as usize,
            file_of(src, k),
            theta,
            time,
            &d.result,
            um_per_px,
        ))
    };
    // What a failed frame or source means for the run.
    let failed = |src: &S, e: SourceError<S::Error>, done: &mut Detected| -> Result<()> {
        match e {
            SourceError::Frame { index, error } => {
                let name = file_of(src, index).unwrap_or_else(|| what.to_string());
                Err(anyhow!("{name}: {error}"))
            }
            e => {
                // The whole frames already detected stay in the output.
                done.stream_error = Some(anyhow!("{what}: {e}"));
                Ok(())
            }
        }
    };
    if a.dump_stages.is_none() && !a.timing {
        let threads = a.threads.map_or_else(
            || std::thread::available_parallelism().map_or(1, |n| n.get()),
            usize::from,
        );
        detect_in_order(source, optics, threads, |src, item| match item {
            Ok(d) => line(src, &d, &mut done, sink),
            Err(e) => failed(src, e, &mut done),
        })
        .map_err(|e| match e {
            DetectInOrderError::Sink(e) => e,
            e => anyhow!(e.to_string()),
        })?;
        return Ok(done);
    }
    // One frame at a time: a frame's stages dumped, or the detector timed.
    let dump = a.dump_stages.as_deref();
    let mut det = SourceDetector::new(source, optics)?;
    let mut dumped = false;
    let mut cpu_s = Vec::new();
    loop {
        let want_dump = dump.is_some() && done.frames == a.frame;
        det.detector_mut().set_dump(want_dump);
        let detected = match det.read_next() {
            Ok(Some(hdr)) => {
                let t0 = thread_cpu_s();
                let d = det.detect_read(&hdr);
                cpu_s.push(thread_cpu_s() - t0);
                d
            }
            Ok(None) => break,
            Err(e) => Err(e),
        };
        let d = match detected {
            Ok(d) => d,
            Err(e) => {
                failed(det.source(), e, &mut done)?;
                break;
            }
        };
        if let Some(dir) = dump.filter(|_| want_dump) {
            write_dump(&mut sink.out, dir, det.detector(), &d.result)?;
            dumped = true;
        }
        line(det.source(), &d, &mut done, sink)?;
    }
    if dump.is_some() && done.stream_error.is_none() && !dumped {
        bail!("--frame {}: only {} frames were read", a.frame, done.frames);
    }
    if a.timing {
        report_timing(&mut cpu_s);
    }
    Ok(done)
}

/// The calling thread's CPU time, s.
fn thread_cpu_s() -> f64 {
    let t = rustix::time::clock_gettime(rustix::time::ClockId::ThreadCPUTime);
    t.tv_sec as f64 + t.tv_nsec as f64 * 1e-9
}

/// `--timing`: the detector's CPU time per frame, on standard error.
fn report_timing(cpu_s: &mut [f64]) {
    if cpu_s.is_empty() {
        gonio_cli::note!("detector timing: no frames");
        return;
    }
    cpu_s.sort_by(f64::total_cmp);
    let n = cpu_s.len();
    // Nearest-rank quantiles (the median of an even count is the mean of the middle two).
    let median = (cpu_s[(n - 1) / 2] + cpu_s[n / 2]) / 2.0;
    let p99 = cpu_s[((0.99 * n as f64).ceil() as usize).clamp(1, n) - 1];
    gonio_cli::note!(
        "detector alone (crop + detect, CPU time of the thread): median {:.3} ms/frame, \
         99th percentile {:.3} ms, max {:.3} ms over {n} frames",
        median * 1e3,
        p99 * 1e3,
        cpu_s[n - 1] * 1e3
    );
}

/// What [`detect_all`] did.
struct Detected {
    frames: usize,
    valid: usize,
    /// The source failed after `frames` whole frames (reported after the output is closed).
    stream_error: Option<anyhow::Error>,
}

/// Writes one stage image (8- or 16-bit grey) as a PNG into the dump directory.
fn save_png<P: image::Primitive>(
    out: &mut Outputs,
    dir: &Path,
    name: &str,
    w: usize,
    h: usize,
    data: Vec<P>,
) -> Result<()>
where
    [P]: image::EncodableLayout,
    image::Luma<P>: image::Pixel<Subpixel = P> + image::PixelWithColorType,
{
    let img = image::ImageBuffer::<image::Luma<P>, Vec<P>>::from_raw(w as u32, h as u32, data)
        .ok_or_else(|| anyhow!("{name}: image size"))?;
    let mut bytes = Vec::new();
    img.write_to(
        &mut std::io::Cursor::new(&mut bytes),
        image::ImageFormat::Png,
    )?;
    out.put("--dump-stages", &dir.join(name), &bytes)?;
    Ok(())
}

/// Writes the stage images of the detector's last frame.
fn write_dump(out: &mut Outputs, dir: &Path, det: &Detector, res: &FrameResult) -> Result<()> {
    let d = det
        .dump()
        .ok_or_else(|| anyhow!("no stage images recorded"))?;
    let (w, h) = (d.width, d.height);
    let off = |v: &[i16]| {
        v.iter()
            .map(|&x| (x as i32 + 32768) as u16)
            .collect::<Vec<u16>>()
    };
    save_png(out, dir, "00_input.png", w, h, d.input.clone())?;
    save_png(out, dir, "01_tophat.png", w, h, d.tophat.clone())?;
    save_png(out, dir, "02_opened.png", w, h, d.opened.clone())?;
    save_png(out, dir, "03_blurred.png", w, h, d.blurred.clone())?;
    save_png(out, dir, "04_gx_plus32768.png", w, h, off(&d.gx))?;
    save_png(out, dir, "05_gy_plus32768.png", w, h, off(&d.gy))?;
    save_png(out, dir, "06_magnitude.png", w, h, d.mag.clone())?;
    save_png(out, dir, "07_edges_class.png", w, h, d.edges.class.clone())?;
    save_png(out, dir, "08_edges_dir256.png", w, h, d.edges.dir.clone())?;
    save_png(
        out,
        dir,
        "09_edges_sub32_plus128.png",
        w,
        h,
        d.edges
            .sub
            .iter()
            .map(|&s| (s as i16 + 128) as u8)
            .collect(),
    )?;
    save_png(
        out,
        dir,
        "10_filled_class.png",
        w,
        h,
        d.filled.class.clone(),
    )?;
    save_png(out, dir, "11_filled_dir256.png", w, h, d.filled.dir.clone())?;
    let edges = (
        Image::from_vec(w, h, d.filled.class.clone()),
        Image::from_vec(w, h, d.filled.dir.clone()),
        Image::from_vec(w, h, d.filled.sub.clone()),
    );
    let (_, labels) = label(&edges, &Image::from_vec(w, h, d.filled.mag.clone()));
    save_png(
        out,
        dir,
        "12_labels.png",
        w,
        h,
        labels.data.iter().map(|&l| l.min(65535) as u16).collect(),
    )?;
    #[derive(Serialize)]
    struct Comp {
        pixels: u64,
        strong: u64,
        weak: u64,
        first_index: u64,
        rows: (u32, u32),
        cols: (u32, u32),
        sum_row: i64,
        sum_col32: i64,
        sum_dev: i64,
    }
    let comps: Vec<Comp> = d
        .components
        .iter()
        .map(|c| Comp {
            pixels: c.pixels,
            strong: c.strong,
            weak: c.weak,
            first_index: c.first_index,
            rows: (c.min_row, c.max_row),
            cols: (c.min_col, c.max_col),
            sum_row: c.sum_row,
            sum_col32: c.sum_col32,
            sum_dev: c.sum_dev,
        })
        .collect();
    let id = out.file("--dump-stages", &dir.join("13_components_and_result.json"))?;
    out.json(
        id,
        &serde_json::json!({
            "params": det.params(),
            "components": comps,
            "result": res,
            "files": {
                "00_input.png": "input (inverted for a bright ring), u8",
                "01_tophat.png": "black top-hat, u8",
                "02_opened.png": "opening, u8",
                "03_blurred.png": "5x5 binomial blur, u8",
                "04_gx_plus32768.png": "Sobel Gx + 32768, u16",
                "05_gy_plus32768.png": "Sobel Gy + 32768, u16",
                "06_magnitude.png": "|Gx| + |Gy|, u16",
                "07_edges_class.png": "0 none, 1 weak, 2 strong (after NMS, thresholds, baseline filter)",
                "08_edges_dir256.png": "gradient direction, 256 per turn",
                "09_edges_sub32_plus128.png": "sub-pixel x offset in 1/32 px + 128 (0 = filled)",
                "10_filled_class.png": "classes after edge filling",
                "11_filled_dir256.png": "directions after edge filling",
                "12_labels.png": "component id (raster order of first pixel), u16"
            }
        }),
    )
}
