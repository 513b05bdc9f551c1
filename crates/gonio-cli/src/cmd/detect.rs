//! `gonio detect`: run the streaming ring detector on image files or raw frames from standard
//! input, one JSON line per frame.

use anyhow::{Result, anyhow, bail};
use gonio_cli::flag;
use gonio_cli::output::{OutId, Outputs};
use gonio_core::bound::Bound;
use gonio_core::quantile::Spread;
use gonio_io::formats::angles::{self, FrameAngles as Angles};
use gonio_io::formats::csv::CsvTable;
use gonio_io::formats::frames::{FileFrames, list_frames, load_optics, parse_raw_size};
use gonio_io::input::Inputs;
use gonio_io::memory;
use gonio_io::results::detect::Line;
use gonio_vision::{
    DetectInOrderError, Detection, Detector, FrameResult, FrameSource, Optics, RawFrames,
    SourceDetector, SourceError, detect_in_order,
};
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
edges [{column_px, slope, pixels, strong, …}], tracked (true: measured in a band of columns around
the ring's predicted column; false: over the whole frame).

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
  gonio detect --raw 1440x540 --timing --frame-threads 2 < frames.raw > /dev/null
  gonio detect --camera Aravis-Fake-GONIO01 --frames 200 --speed-deg-s 180 --fps 100
  gonio detect --raw 1440x540 --no-track --timing < frames.raw > /dev/null
  gonio detect frames --track --json-lines c.jsonl

Frames that come in order (--camera, --raw) are tracked by default (--track): after a frame
measured whole, the next ones are measured in a band of columns around the ring's predicted
column (the detector's own stages and ring model on those columns; about a tenth of the frame),
and whole again whenever the band cannot vouch for the result: no ring or an invalid one, an edge
at the band's border, a second candidate, a jump, a weaker or blurred ring, saturation, or every
256 frames (docs/detector.md, § Tracked frames). A frame the band calls valid is valid for the
whole-frame detector too, and its c agrees within 0.02 px. --no-track measures every frame whole.
Image files are measured whole unless --track says they are one sequence in name order.

With --camera ID (a build with --features genicam; docs/camera.md) the frames stream from a
GenICam camera set up from the optics (the window as Width/Height/OffsetX/OffsetY centred on the
sensor; Mono8, or Mono10/12/16 with the low bits dropped). Each line also has frame_id (the
camera's, counted on across GigE Vision's 16-bit wrap) and timestamp_ns (the camera's); frame is
the frame's slot since the first (received or missing). A frame that arrived with packets
missing is reported with reason incomplete_frame, a frame missing from the id sequence with a
missing_frame line: never valid. The summary on standard error: frames, complete, incomplete,
missing, resent packets, the latency from a buffer's arrival to its result (p50, p99) and the
CPU time per frame. A live camera is detected one frame at a time as it comes in (the lowest
latency; the detector needs 1–2 ms of the 10 ms between frames at 100 frames/s; with
--frame-threads 2 each frame is split across two threads); --threads N (N ≥ 2) uses the
in-order workers of --raw instead, where a result can wait up to a frame period to be handed
on. Ctrl-C stops acquisition: the lines so far are kept on standard output (a
--json-lines file is a set written whole, so it is discarded).

Frames are detected on --threads worker threads (default: all cores) while the main thread
reads the next ones; the lines come out in frame order, the same bytes whatever the thread
count (whole frames only: --threads does not track). --dump-stages and --timing run one frame at a
time (--timing with --frame-threads 2 splits each frame across two threads and also reports the
wall time; with tracking, the times of the frames measured in the band and of those measured
whole are reported apart).")]
pub struct Args {
    /// Image files (PNG, TIFF) or directories of them (read in name order).
    #[arg(
        value_name = "FRAMES",
        required_unless_present_any = ["raw", "camera"],
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
    #[arg(long, requires = "fps", allow_hyphen_values = true, value_parser = flag::real(flag::SPEED_DEG_S))]
    pub speed_deg_s: Option<f64>,
    /// Frame rate, frames per second (with --speed-deg-s).
    #[arg(long, requires = "speed_deg_s", value_parser = flag::real(flag::FPS))]
    pub fps: Option<f64>,
    /// θ of frame 0 with --speed-deg-s, degrees.
    #[arg(long, default_value_t = 0.0, allow_hyphen_values = true, value_parser = flag::real(flag::ANGLE_DEG))]
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
    #[arg(long, default_value_t = 0, requires = "dump_stages", value_parser = flag::whole::<usize>(FRAME_INDEX))]
    pub frame: usize,
    /// Worker threads detecting frames in parallel (default: all cores; 1 to 256); the output
    /// stays in frame order.
    #[arg(long, value_name = "N", value_parser = flag::whole::<u16>(THREADS))]
    pub threads: Option<u16>,
    /// Also time the detector alone: its CPU time per frame (median, 99th percentile, maximum;
    /// reading the frames and writing the lines not counted) on standard error. The frames are
    /// then detected one at a time on the main thread.
    #[arg(long, conflicts_with = "threads")]
    pub timing: bool,
    /// Threads detecting each frame, 1 (the default) or 2: with 2, a second thread runs the
    /// row-local stages over the lower part of each frame while this one runs the rest — the
    /// same results bit for bit, in about three quarters of the time when the second thread
    /// wakes at once (BENCHMARKS.md: a lower median latency, a longer tail where waking a
    /// thread is slow). For --camera and --timing (the frames one at a time); --threads runs
    /// whole frames in parallel instead.
    #[arg(
        long,
        value_name = "N",
        conflicts_with = "threads",
        value_parser = flag::whole::<u8>(FRAME_THREADS)
    )]
    pub frame_threads: Option<u8>,
    /// Stream from this GenICam camera (an id of `gonio camera list`; needs a build with
    /// `--features genicam`).
    #[arg(long, value_name = "ID", conflicts_with_all = ["raw", "frames", "dump_stages", "timing"])]
    pub camera: Option<String>,
    /// With --camera: stop after N frames, received or missing (default: until Ctrl-C).
    #[arg(
        long = "frames",
        id = "frame_count",
        value_name = "N",
        requires = "camera",
        value_parser = flag::whole::<u64>(FRAME_COUNT)
    )]
    pub frame_count: Option<u64>,
    /// With --camera: exposure time, µs (default: the camera's).
    #[arg(long, requires = "camera", value_parser = flag::real(EXPOSURE_US))]
    pub exposure_us: Option<f64>,
    /// With --camera: gain, dB (default: the camera's).
    #[arg(long, requires = "camera", allow_hyphen_values = true, value_parser = flag::real(GAIN_DB))]
    pub gain_db: Option<f64>,
    /// With --camera: the trigger (free running, one software trigger per frame, or hardware
    /// line 1 from the PLC).
    #[arg(long, value_enum, default_value = "free")]
    pub trigger: TriggerArg,
    /// With --camera: GigE Vision packet size, bytes (default: the camera's; jumbo frames
    /// e.g. 8192 need the network card's MTU raised).
    #[arg(long, requires = "camera", value_parser = flag::whole::<u32>(PACKET_BYTES))]
    pub packet_size: Option<u32>,
    /// With --camera: the stream socket's receive buffer, bytes (0: Aravis's, one frame).
    #[arg(long, default_value_t = 4 << 20, value_parser = flag::whole::<u32>(SOCKET_BUFFER_BYTES))]
    pub socket_buffer_bytes: u32,
    /// With --camera: use Aravis's packet socket (faster on a network card; sees nothing on
    /// loopback, hence off by default).
    #[arg(long)]
    pub packet_socket: bool,
    /// With --camera: no packet resend requests.
    #[arg(long)]
    pub no_packet_resend: bool,
    /// With --camera: give up when no frame comes for this long, ms (the camera gone).
    #[arg(long, default_value_t = 3000, value_parser = flag::whole::<u64>(FRAME_TIMEOUT_MS))]
    pub frame_timeout_ms: u64,
    /// Measure frames in a band of columns around the ring's predicted column when the band can
    /// vouch for the result, whole otherwise, one frame at a time (default with --camera and
    /// --raw; for image files, their name order is taken as the frames' order).
    #[arg(long, conflicts_with_all = ["no_track", "threads", "dump_stages"])]
    pub track: bool,
    /// Measure every frame whole (to compare with --track).
    #[arg(long)]
    pub no_track: bool,
}

impl Args {
    /// Whether frames are tracked: `--track`, or by default when they come in order (a camera,
    /// raw standard input) and are detected one at a time (no `--threads`, no `--dump-stages`).
    fn tracks(&self) -> bool {
        self.track
            || (!self.no_track
                && (self.raw.is_some() || self.camera.is_some())
                && self.threads.is_none()
                && self.dump_stages.is_none())
    }
}

/// `--threads`: worker threads (each holds a detector, ≈ 20 bytes a window pixel).
const THREADS: Bound = Bound::new(1.0, 256.0, "");
/// `--frame-threads`: one, or the frame split across two.
const FRAME_THREADS: Bound = Bound::new(1.0, 2.0, "");
/// `--frame`: the frame dumped (0-based).
const FRAME_INDEX: Bound = Bound::new(0.0, 1e9, "");
/// `--frames`: frames from the camera.
const FRAME_COUNT: Bound = Bound::new(1.0, 1e12, "frames");
/// `--exposure-us`: up to 100 s.
const EXPOSURE_US: Bound = Bound::new(0.0, 1e8, "µs").lo_excluded();
/// `--gain-db`.
const GAIN_DB: Bound = Bound::new(-100.0, 100.0, "dB");
/// `--packet-size`: from the smallest IP datagram every host takes to the largest jumbo frame.
const PACKET_BYTES: Bound = Bound::new(576.0, 65_535.0, "bytes");
/// `--socket-buffer-bytes` (0: Aravis's own).
const SOCKET_BUFFER_BYTES: Bound = Bound::new(0.0, (1u32 << 30) as f64, "bytes");
/// `--frame-timeout-ms`: up to an hour.
const FRAME_TIMEOUT_MS: Bound = Bound::new(1.0, 3_600_000.0, "ms");

/// Refuses a thread count whose detectors (one a worker, sized by the optics) the address space
/// cannot hold, before any is made: one is made and measured, and the whole set reserved.
fn check_threads_fit(optics: &Optics, threads: usize) -> Result<()> {
    if threads <= 1 {
        return Ok(());
    }
    let (det, grew) = memory::measured(|| gonio_vision::Detector::new(optics));
    drop(det?);
    let Some(detector) = grew else {
        return Ok(());
    };
    let p = optics.params()?;
    // A worker: its detector, its frame and the one being read for it, its stack; and the
    // allocator's arenas of the worker threads.
    let per = detector + 2 * (p.width * p.height) as u64 + (2 << 20);
    let need = |k: usize| per * k as u64 + memory::thread_arenas(k);
    if memory::available(need(threads)) {
        return Ok(());
    }
    let fit = (1..threads)
        .rev()
        .find(|&k| memory::available(need(k)))
        .unwrap_or(0);
    bail!(
        "--threads {threads}: {threads} workers need ≈{} MiB for these optics ({} MiB each), more memory than this process may have (an address-space limit, ulimit -v?): at most {fit} fit",
        memory::mib(need(threads)),
        memory::mib(per)
    )
}

/// The trigger on the command line.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum TriggerArg {
    /// Free running at the camera's frame rate.
    Free,
    /// One software trigger per frame.
    Software,
    /// Hardware line 1 (the PLC's trigger output).
    Line1,
}

fn load_angles(inputs: &Inputs, a: &Args) -> Result<Angles> {
    if let Some(p) = &a.angles {
        let table = CsvTable::read(inputs, p)?;
        return Ok(Angles::Table(angles::from_table(&table)?));
    }
    if let (Some(speed), Some(fps)) = (a.speed_deg_s, a.fps) {
        return Ok(Angles::Speed {
            start_deg: a.start_deg,
            speed_deg_s: speed,
            fps,
        });
    }
    Ok(Angles::None)
}

/// The JSON lines output: a file (whole, renamed into place at the end) or standard output.
pub(crate) struct Sink {
    out: Outputs,
    id: OutId,
}

impl Sink {
    /// Writes one line (a frame's [`Line`] or a camera's missing frame) as JSON.
    pub(crate) fn line<L: serde::Serialize>(&mut self, frame: u64, l: &L) -> Result<()> {
        gonio_io::json::check_finite(l).map_err(|e| anyhow!("frame {frame}: {e}"))?;
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
    let optics = load_optics(sink.out.inputs(), a.optics.as_deref())?;
    let angles = load_angles(sink.out.inputs(), &a)?;
    let started = std::time::Instant::now();
    let done = if let Some(id) = &a.camera {
        camera_run::detect_camera(&a, id, &angles, &optics, &mut sink)?
    } else if let Some(size) = &a.raw {
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
            sink.out.inputs().record(f);
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
        sink.line(
            k,
            &Line::new(
                k as usize,
                file_of(src, k),
                theta,
                time,
                &d.result,
                um_per_px,
            ),
        )
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
    let track = a.tracks();
    if a.dump_stages.is_none() && !a.timing && !track {
        if a.frame_threads.is_some() {
            bail!(
                "--frame-threads: only with --timing, --track or --camera, where frames are \
                 detected one at a time (--threads detects whole frames in parallel)"
            );
        }
        let threads = a.threads.map_or_else(
            || std::thread::available_parallelism().map_or(1, |n| n.get()),
            usize::from,
        );
        check_threads_fit(optics, threads)?;
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
    // One frame at a time: tracked, a frame's stages dumped, or the detector timed.
    let dump = a.dump_stages.as_deref();
    let mut det = SourceDetector::new(source, optics)?;
    let mut dumped = false;
    let mut cpu_s = Vec::new();
    let mut wall_s = Vec::new();
    let mut tracked = Vec::new();
    det.split_frames(a.frame_threads == Some(2));
    det.track_frames(track);
    loop {
        let want_dump = dump.is_some() && done.frames == a.frame;
        det.detector_mut().set_dump(want_dump);
        let detected = match det.read_next() {
            Ok(Some(hdr)) => {
                let (t0, w0) = (thread_cpu_s(), std::time::Instant::now());
                let d = det.detect_read(&hdr);
                cpu_s.push(thread_cpu_s() - t0);
                wall_s.push(w0.elapsed().as_secs_f64());
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
        tracked.push(d.result.tracked);
        line(det.source(), &d, &mut done, sink)?;
    }
    if dump.is_some() && done.stream_error.is_none() && !dumped {
        bail!("--frame {}: only {} frames were read", a.frame, done.frames);
    }
    if a.timing {
        // Frame by frame, before the quantiles sort them.
        let per_frame = cpu_s.clone();
        report_timing(&mut cpu_s, &mut wall_s, det.splits_frames());
        if let Some(t) = det.tracker() {
            report_modes(&per_frame, &tracked, t);
        }
    }
    Ok(done)
}

/// The calling thread's CPU time, s.
fn thread_cpu_s() -> f64 {
    let t = rustix::time::clock_gettime(rustix::time::ClockId::ThreadCPUTime);
    t.tv_sec as f64 + t.tv_nsec as f64 * 1e-9
}

/// `--timing`: the detector's CPU time per frame (of the calling thread) and, for frames split
/// across two threads, its wall time, on standard error.
fn report_timing(cpu_s: &mut [f64], wall_s: &mut [f64], split: bool) {
    let (Some(cpu), Some(wall)) = (Spread::of(cpu_s), Spread::of(wall_s)) else {
        gonio_cli::note!("detector timing: no frames");
        return;
    };
    gonio_cli::note!(
        "detector alone (crop + detect, CPU time of the thread): {}",
        ms(&cpu)
    );
    gonio_cli::note!(
        "detector alone, each frame on {} (crop + detect, wall time): {}",
        if split { "two threads" } else { "one thread" },
        ms(&wall)
    );
}

/// A timing spread in seconds as the report's milliseconds.
fn ms(s: &Spread) -> String {
    format!(
        "median {:.3} ms/frame, 99th percentile {:.3} ms, max {:.3} ms over {} frames",
        s.median * 1e3,
        s.p99 * 1e3,
        s.max * 1e3,
        s.n
    )
}

/// `--timing` with tracking: the detector's CPU time per frame for the frames measured in the
/// band and for those measured whole, apart, and why frames were measured whole.
fn report_modes(cpu_s: &[f64], tracked: &[bool], t: &gonio_vision::track::Tracker) {
    for (mode, in_band) in [("tracked (measured in the band)", true), ("whole", false)] {
        let mut v: Vec<f64> = (cpu_s.iter().zip(tracked))
            .filter(|&(_, &b)| b == in_band)
            .map(|(&x, _)| x)
            .collect();
        match Spread::of(&mut v) {
            Some(s) => gonio_cli::note!("{mode} frames (CPU time of the thread): {}", ms(&s)),
            None => gonio_cli::note!("{mode} frames: none"),
        }
    }
    let why: Vec<String> = t
        .fallbacks()
        .filter(|&(_, n)| n > 0)
        .map(|(f, n)| format!("{} {n}", f.name()))
        .collect();
    gonio_cli::note!(
        "tracking: {} frames in the band, {} whole ({})",
        t.tracked_frames(),
        t.whole_frames(),
        why.join(", ")
    );
}

/// What [`detect_all`] did.
pub(crate) struct Detected {
    frames: usize,
    valid: usize,
    /// The source failed after `frames` whole frames (reported after the output is closed).
    stream_error: Option<anyhow::Error>,
}

/// Writes the stage images of the detector's last frame and their JSON document.
fn write_dump(out: &mut Outputs, dir: &Path, det: &Detector, res: &FrameResult) -> Result<()> {
    let dump = gonio_io::stage_dump::stage_dump(det, res)?;
    for f in &dump.images {
        out.put("--dump-stages", &dir.join(f.name), &f.png)?;
    }
    let id = out.file("--dump-stages", &dir.join(gonio_io::stage_dump::JSON_NAME))?;
    out.json(id, &dump.json)
}

#[cfg(not(feature = "genicam"))]
mod camera_run {
    use super::{Angles, Args, Detected, Sink};
    use anyhow::Result;
    use gonio_vision::Optics;

    /// Without the `genicam` feature: says how to build with cameras.
    pub(super) fn detect_camera(
        _: &Args,
        id: &str,
        _: &Angles,
        _: &Optics,
        _: &mut Sink,
    ) -> Result<Detected> {
        anyhow::bail!("--camera {id}: {}", gonio_camera::CameraError::NotBuilt)
    }
}

/// `--camera`: a GenICam camera through Aravis into the detector.
#[cfg(feature = "genicam")]
mod camera_run {
    use super::{Angles, Args, Detected, Line, Sink, TriggerArg};
    use anyhow::{Result, anyhow};
    use gonio_camera::{
        AravisSource, CameraConfig, CameraError, FrameMeta, StreamOptions, Trigger,
    };
    use gonio_core::quantile::quantile_sorted;
    use gonio_io::results::detect::MissingLine;
    use gonio_vision::{
        DetectInOrderError, Detection, InvalidReason, Optics, SourceDetector, SourceError,
        detect_in_order,
    };
    use std::sync::Arc;
    use std::sync::atomic::AtomicBool;
    use std::time::Instant;

    /// The process's CPU time (every thread), s.
    fn process_cpu_s() -> f64 {
        let t = rustix::time::clock_gettime(rustix::time::ClockId::ProcessCPUTime);
        t.tv_sec as f64 + t.tv_nsec as f64 * 1e-9
    }

    /// The line of slot `slot`, missing from the camera's id sequence.
    fn missing_line(angles: &Angles, slot: u64, frame_id: Option<u64>) -> Result<MissingLine> {
        let (theta, time) = angles.at(slot as usize)?;
        Ok(MissingLine::new(slot, frame_id, theta, time))
    }

    /// Streams the camera `id` through the detector (see `gonio detect --help`).
    pub(super) fn detect_camera(
        a: &Args,
        id: &str,
        angles: &Angles,
        optics: &Optics,
        sink: &mut Sink,
    ) -> Result<Detected> {
        let um_per_px = optics.params()?.um_per_px;
        let config = CameraConfig {
            window_size: (optics.window_width_px, optics.window_height_px),
            window_offset: None,
            exposure_us: a.exposure_us,
            gain_db: a.gain_db,
            trigger: match a.trigger {
                TriggerArg::Free => Trigger::Free,
                TriggerArg::Software => Trigger::Software,
                TriggerArg::Line1 => Trigger::Line1,
            },
            packet_size: a.packet_size,
            stream: StreamOptions {
                packet_socket_disabled: !a.packet_socket,
                socket_buffer_bytes: (a.socket_buffer_bytes > 0).then_some(a.socket_buffer_bytes),
                packet_resend: !a.no_packet_resend,
                ..StreamOptions::default()
            },
            frame_timeout_ms: a.frame_timeout_ms.max(100),
            deliver_incomplete: true,
            frames: a.frame_count,
        };
        let mut src = AravisSource::open(id, &config)?;
        let stop = Arc::new(AtomicBool::new(false));
        #[cfg(unix)]
        signal_hook::flag::register(signal_hook::consts::SIGINT, stop.clone())?;
        src.stop_on(stop);
        // A live camera: one frame in flight unless --threads asks for more.
        let threads = a.threads.map_or(1, usize::from);
        let mut done = Detected {
            frames: 0,
            valid: 0,
            stream_error: None,
        };
        let mut latency_s = Vec::new();
        let cpu0 = process_cpu_s();
        let t0 = Instant::now();
        let mut handle =
            |src: &AravisSource, item: Result<Detection, SourceError<CameraError>>| -> Result<()> {
                let d = match item {
                    Ok(d) => d,
                    Err(SourceError::Frame { index, error }) => {
                        return Err(anyhow!("camera {id}: frame {index}: {error}"));
                    }
                    Err(SourceError::Source(e)) => {
                        // The camera failed after the frames before: they stay in the output.
                        done.stream_error = Some(e.into());
                        return Ok(());
                    }
                };
                let k = d.stamp.index;
                let meta: FrameMeta = src
                    .take_meta(k)
                    .ok_or_else(|| anyhow!("camera {id}: frame {k} came without its id"))?;
                for (slot, fid) in meta.missing() {
                    sink.line(slot, &missing_line(angles, slot, Some(fid))?)?;
                    done.frames += 1;
                }
                let (theta, time) = angles.at(k as usize)?;
                let mut result = d.result;
                if !meta.complete {
                    result.invalidate(InvalidReason::IncompleteFrame);
                }
                let line = Line::new(k as usize, None, theta, time, &result, um_per_px)
                    .with_camera(meta.frame_id, meta.timestamp_ns);
                done.valid += result.valid as usize;
                done.frames += 1;
                sink.line(k, &line)?;
                latency_s.push(meta.arrival.elapsed().as_secs_f64());
                Ok(())
            };
        if threads > 1 {
            // The raw path's in-order workers: more frames per second on a slow core, but a
            // result waits up to a frame period for the reader (which holds the source while
            // it waits for the next frame) before it is handed on.
            let run = detect_in_order(&mut src, optics, threads, |src, item| handle(src, item));
            match run {
                Ok(()) => {}
                Err(DetectInOrderError::Sink(e)) => return Err(e),
                Err(e) => return Err(anyhow!(e.to_string())),
            }
        } else {
            // One frame in flight: each result as soon as its frame is in (on two threads with
            // --frame-threads 2).
            let mut det = SourceDetector::new(&mut src, optics)?;
            det.split_frames(a.frame_threads == Some(2));
            det.track_frames(a.tracks());
            loop {
                match det.detect_next() {
                    Ok(Some(d)) => handle(det.source(), Ok(d))?,
                    Ok(None) => break,
                    Err(e) => {
                        let stop = matches!(e, SourceError::Source(_));
                        handle(det.source(), Err(e))?;
                        if stop {
                            break;
                        }
                    }
                }
            }
        }
        let dt = t0.elapsed().as_secs_f64();
        let cpu = process_cpu_s() - cpu0;
        // Slots missing after the last frame, up to --frames.
        let trailing = src.trailing_missing();
        if trailing > 0 {
            let n = a.frame_count.unwrap_or(0);
            for slot in n - trailing..n {
                // Their ids are not known (no later frame came): null.
                sink.line(slot, &missing_line(angles, slot, None)?)?;
                done.frames += 1;
            }
        }
        let s = src.stats();
        drop(src);
        latency_s.sort_by(f64::total_cmp);
        let q = |p: f64| quantile_sorted(&latency_s, p).map_or(f64::NAN, |x| x * 1e3);
        gonio_cli::note!(
            "camera {id}: {} frames ({} complete, {} incomplete), {} missing, {} packets resent, \
             {} lost; latency buffer arrival → result p50 {:.2} ms, p99 {:.2} ms; CPU {:.3} ms \
             per frame ({:.1} s)",
            s.frames,
            s.complete,
            s.incomplete,
            s.missing,
            s.resent_packets,
            s.missing_packets,
            q(0.5),
            q(0.99),
            if s.frames > 0 {
                cpu * 1e3 / s.frames as f64
            } else {
                0.0
            },
            dt
        );
        Ok(done)
    }
}
