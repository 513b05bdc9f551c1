//! `gonio detect`: run the streaming ring detector on image files or raw frames from standard
//! input, one JSON line per frame.

use crate::formats::frames::{FileFrames, list_frames, load_optics};
use crate::io;
use anyhow::{Context, Result, anyhow, bail};
use gonio_vision::reference::{Image, label};
use gonio_vision::{
    DetectInOrderError, Detection, Detector, FrameResult, FrameSource, Optics, RawFrames,
    SourceDetector, SourceError, detect_in_order,
};
use serde::Serialize;
use std::io::{BufWriter, Write};
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

Frames are detected on --threads worker threads (default: all cores) while the main thread
reads the next ones; the lines come out in frame order, the same bytes whatever the thread
count. --dump-stages runs on one thread.")]
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
    /// Worker threads detecting frames in parallel (default: all cores); the output stays in
    /// frame order.
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u16).range(1..))]
    pub threads: Option<u16>,
}

/// One output line.
#[derive(Debug, Serialize)]
struct Line<'a> {
    frame: usize,
    #[serde(skip_serializing_if = "Option::is_none")]
    file: Option<String>,
    theta_deg: Option<f64>,
    time_s: Option<f64>,
    c_um: Option<f64>,
    #[serde(flatten)]
    result: &'a FrameResult,
}

enum Angles {
    None,
    Table(String, Vec<Option<(f64, Option<f64>)>>),
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
            Angles::Table(name, v) => match v.get(k).copied().flatten() {
                Some((th, t)) => Ok((Some(th), t)),
                None => bail!(
                    "{name}: no angle for frame {k}: the angle file covers {} frames",
                    v.iter().filter(|x| x.is_some()).count()
                ),
            },
        }
    }
}

fn load_angles(a: &Args) -> Result<Angles> {
    if let Some(p) = &a.angles {
        let t = io::CsvTable::read(p)?;
        let expected = "frame,theta_deg[,time_s]";
        let fc = t.require("frame", expected)?;
        let tc = t.require("theta_deg", expected)?;
        let sc = t.column("time_s");
        let mut v: Vec<Option<(f64, Option<f64>)>> = Vec::new();
        for (line, f) in &t.rows {
            let k = t.int_at(*line, f, fc)?;
            if !(0..=100_000_000).contains(&k) {
                return Err(t.error_at(
                    *line,
                    fc,
                    format!("expected a frame index ≥ 0, found {k}"),
                ));
            }
            let th = t.f64_at(*line, f, tc)?;
            let ts = sc.map(|c| t.f64_at(*line, f, c)).transpose()?;
            let k = k as usize;
            if v.len() <= k {
                v.resize(k + 1, None);
            }
            if v[k].is_some() {
                return Err(t.error_at(*line, fc, format!("frame {k} appears twice")));
            }
            v[k] = Some((th, ts));
        }
        return Ok(Angles::Table(p.display().to_string(), v));
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

fn parse_size(s: &str) -> Result<(usize, usize)> {
    let err = || anyhow!("--raw {s:?}: expected WIDTHxHEIGHT, e.g. 1440x540");
    let (a, b) = s.split_once(['x', 'X', '×']).ok_or_else(err)?;
    let w: usize = a.trim().parse().map_err(|_| err())?;
    let h: usize = b.trim().parse().map_err(|_| err())?;
    if w == 0 || h == 0 {
        return Err(err());
    }
    Ok((w, h))
}

struct Sink {
    out: Box<dyn Write>,
    to_file: Option<(PathBuf, tempfile::NamedTempFile)>,
}

impl Sink {
    fn new(path: Option<&Path>) -> Result<Sink> {
        match path {
            None => Ok(Sink {
                out: Box::new(BufWriter::new(std::io::stdout())),
                to_file: None,
            }),
            Some(p) if p.as_os_str() == "-" => Ok(Sink {
                out: Box::new(BufWriter::new(std::io::stdout())),
                to_file: None,
            }),
            Some(p) => {
                let dir = match p.parent() {
                    Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
                    _ => PathBuf::from("."),
                };
                let tmp = tempfile::Builder::new()
                    .prefix(".gonio-")
                    .suffix(".tmp")
                    .tempfile_in(&dir)
                    .with_context(|| {
                        format!("cannot create a temporary file in {}", dir.display())
                    })?;
                let f = tmp
                    .reopen()
                    .with_context(|| format!("cannot write {}", p.display()))?;
                Ok(Sink {
                    out: Box::new(BufWriter::new(f)),
                    to_file: Some((p.to_path_buf(), tmp)),
                })
            }
        }
    }
    fn line(&mut self, l: &Line) -> Result<()> {
        serde_json::to_writer(&mut self.out, l)?;
        self.out
            .write_all(b"\n")
            .context("cannot write the JSON lines")?;
        Ok(())
    }
    /// Finishes the output (the file appears atomically, whole).
    fn close(mut self) -> Result<()> {
        self.out.flush().context("cannot write the JSON lines")?;
        drop(self.out);
        if let Some((p, tmp)) = self.to_file {
            tmp.persist(&p)
                .map_err(|e| anyhow!("cannot write {}: {}", p.display(), e.error))?;
        }
        Ok(())
    }
}

/// Runs `gonio detect`.
pub fn run(a: Args) -> Result<()> {
    let optics = load_optics(a.optics.as_deref())?;
    let angles = load_angles(&a)?;
    let mut sink = Sink::new(a.json_lines.as_deref())?;
    let started = std::time::Instant::now();
    let done = if let Some(size) = &a.raw {
        let (w, h) = parse_size(size)?;
        let (ww, wh) = (
            optics.window_width_px as usize,
            optics.window_height_px as usize,
        );
        let (sw, sh) = (
            optics.sensor_width_px as usize,
            optics.sensor_height_px as usize,
        );
        if (w, h) != (ww, wh) && (w, h) != (sw, sh) {
            bail!(
                "--raw {w}x{h}: expected the window {ww}x{wh} or the sensor {sw}x{sh} (see --optics)"
            );
        }
        // A pipe's default 64 kB buffer costs a dozen reader/writer wake-ups per frame; ask for
        // room for a whole frame (best effort: not a pipe, or over the system's limit, is fine).
        #[cfg(target_os = "linux")]
        let _ = rustix::pipe::fcntl_setpipe_size(std::io::stdin(), (w * h).next_power_of_two());
        let src = RawFrames::new(std::io::stdin().lock(), w, h);
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
        if let Angles::Table(name, v) = &angles {
            let covered = v.iter().filter(|x| x.is_some()).count();
            if let Some(k) = (0..files.len()).find(|&k| v.get(k).copied().flatten().is_none()) {
                bail!(
                    "{name}: no angle for frame {k}: {} frames given, the angle file covers {covered}",
                    files.len()
                );
            }
        }
        detect_all(
            &a,
            &angles,
            FileFrames::new(files),
            &optics,
            &mut sink,
            |s: &FileFrames, k| s.path(k).map(|p| p.display().to_string()),
            "frame",
        )?
    };
    sink.close()?;
    if let Some(e) = done.stream_error {
        return Err(e);
    }
    let (n, valid) = (done.frames, done.valid);
    let dt = started.elapsed().as_secs_f64();
    eprintln!(
        "{n} frames, {valid} valid, {:.0} frames/s",
        if dt > 0.0 { n as f64 / dt } else { 0.0 }
    );
    Ok(())
}

/// Every frame of the source through the detector, one JSON line each: on worker threads in
/// frame order ([`detect_in_order`]), or one at a time when a frame's stages are dumped.
#[allow(clippy::too_many_arguments)]
fn detect_all<S: FrameSource>(
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
    let mut line = |src: &S, d: &Detection, done: &mut Detected| -> Result<()> {
        let k = d.stamp.index;
        let (theta, time) = angles.at(k as usize)?;
        done.valid += d.result.valid as usize;
        done.frames += 1;
        sink.line(&Line {
            frame: k as usize,
            file: file_of(src, k),
            theta_deg: theta,
            time_s: time,
            c_um: d.result.c_px.map(|c| c * um_per_px),
            result: &d.result,
        })
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
    let Some(dir) = a.dump_stages.as_deref() else {
        let threads = a.threads.map_or_else(
            || std::thread::available_parallelism().map_or(1, |n| n.get()),
            usize::from,
        );
        detect_in_order(source, optics, threads, |src, item| match item {
            Ok(d) => line(src, &d, &mut done),
            Err(e) => failed(src, e, &mut done),
        })
        .map_err(|e| match e {
            DetectInOrderError::Sink(e) => e,
            e => anyhow!(e.to_string()),
        })?;
        return Ok(done);
    };
    let mut det = SourceDetector::new(source, optics)?;
    let mut dumped = false;
    loop {
        let want_dump = done.frames == a.frame;
        det.detector_mut().set_dump(want_dump);
        let d = match det.detect_next() {
            Ok(Some(d)) => d,
            Ok(None) => break,
            Err(e) => {
                failed(det.source(), e, &mut done)?;
                break;
            }
        };
        if want_dump {
            write_dump(dir, det.detector(), &d.result)?;
            dumped = true;
        }
        line(det.source(), &d, &mut done)?;
    }
    if done.stream_error.is_none() && !dumped {
        bail!("--frame {}: only {} frames were read", a.frame, done.frames);
    }
    Ok(done)
}

/// What [`detect_all`] did.
struct Detected {
    frames: usize,
    valid: usize,
    /// The source failed after `frames` whole frames (reported after the output is closed).
    stream_error: Option<anyhow::Error>,
}

fn save_png(dir: &Path, name: &str, w: usize, h: usize, data: Vec<u8>) -> Result<()> {
    let img = image::GrayImage::from_raw(w as u32, h as u32, data)
        .ok_or_else(|| anyhow!("{name}: image size"))?;
    let mut bytes = Vec::new();
    img.write_to(
        &mut std::io::Cursor::new(&mut bytes),
        image::ImageFormat::Png,
    )?;
    io::write_atomic(&dir.join(name), &bytes)
}

fn save_png16(dir: &Path, name: &str, w: usize, h: usize, data: Vec<u16>) -> Result<()> {
    let img = image::ImageBuffer::<image::Luma<u16>, Vec<u16>>::from_raw(w as u32, h as u32, data)
        .ok_or_else(|| anyhow!("{name}: image size"))?;
    let mut bytes = Vec::new();
    img.write_to(
        &mut std::io::Cursor::new(&mut bytes),
        image::ImageFormat::Png,
    )?;
    io::write_atomic(&dir.join(name), &bytes)
}

/// Writes the stage images of the detector's last frame.
fn write_dump(dir: &Path, det: &Detector, res: &FrameResult) -> Result<()> {
    let d = det
        .dump()
        .ok_or_else(|| anyhow!("no stage images recorded"))?;
    io::ensure_dir(dir)?;
    let (w, h) = (d.width, d.height);
    let off = |v: &[i16]| {
        v.iter()
            .map(|&x| (x as i32 + 32768) as u16)
            .collect::<Vec<u16>>()
    };
    save_png(dir, "00_input.png", w, h, d.input.clone())?;
    save_png(dir, "01_tophat.png", w, h, d.tophat.clone())?;
    save_png(dir, "02_opened.png", w, h, d.opened.clone())?;
    save_png(dir, "03_blurred.png", w, h, d.blurred.clone())?;
    save_png16(dir, "04_gx_plus32768.png", w, h, off(&d.gx))?;
    save_png16(dir, "05_gy_plus32768.png", w, h, off(&d.gy))?;
    save_png16(dir, "06_magnitude.png", w, h, d.mag.clone())?;
    save_png(dir, "07_edges_class.png", w, h, d.edges.class.clone())?;
    save_png(dir, "08_edges_dir256.png", w, h, d.edges.dir.clone())?;
    save_png(
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
    save_png(dir, "10_filled_class.png", w, h, d.filled.class.clone())?;
    save_png(dir, "11_filled_dir256.png", w, h, d.filled.dir.clone())?;
    let edges = (
        Image::from_vec(w, h, d.filled.class.clone()),
        Image::from_vec(w, h, d.filled.dir.clone()),
        Image::from_vec(w, h, d.filled.sub.clone()),
    );
    let (_, labels) = label(&edges, &Image::from_vec(w, h, d.filled.mag.clone()));
    save_png16(
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
    io::write_json(
        &dir.join("13_components_and_result.json"),
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
