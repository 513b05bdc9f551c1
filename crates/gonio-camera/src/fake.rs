//! [`FakeGvCamera`]: a GigE Vision camera served in-process by Aravis's `GvFakeCamera` (the
//! protocol, discovery, GenICam features and packet pacing are Aravis's), whose pixels come from
//! the caller: a [`FrameFill`] is called once per frame, on Aravis's streaming thread, with the
//! frame's id and timestamp, to fill the frame's buffer (`Width` × `Height` bytes, Mono8, as the
//! client set the window).
//!
//! The first frame after each `AcquisitionStart` goes out without its pixels (Aravis's fake
//! camera sizes a frame's packets from the buffer's previous fill, and a fill callback can only
//! set that size during its own fill): a client sees it as an incomplete frame. Every later
//! frame is whole.
//!
//! **Aravis's stall, worked around.** Aravis 0.8's fake camera can sleep 100 ms past a frame
//! (its poll timeout wraps when its thread is late); a watcher thread wakes it with one GVCP
//! register read (the `wake` module says how and why). [`FakeGvCamera::wakeups`] counts the
//! reads. The watcher needs an IPv4 address in [`FakeConfig::address`]; a camera served on an
//! interface's name runs without it.
//!
//! One GigE Vision camera can listen on an address's port 3956 at a time: a camera that
//! answers there already (a GVCP discovery, [`crate::gvcp::discover`]) makes
//! [`FakeGvCamera::start`] refuse, naming it. Tests give each camera its own network namespace
//! (`unshare -n`, `ip link set lo up`).
//!
//! ```no_run
//! use gonio_camera::{FakeConfig, FakeGvCamera, FillInfo};
//! let cam = FakeGvCamera::start(&FakeConfig::default(), |f: &FillInfo, px: &mut [u8]| {
//!     // A dark 11 px ring moving one column per frame.
//!     let c = (f.frame_id % 500) as usize + 100;
//!     for row in px.chunks_mut(f.width as usize) {
//!         for (x, p) in row.iter_mut().enumerate() {
//!             *p = if x.abs_diff(c) <= 5 { 60 } else { 200 };
//!         }
//!     }
//! })
//! .unwrap();
//! println!("serving {} on {}", cam.id(), cam.address());
//! ```

use crate::CameraError;
use crate::ffi::{self, FillFn, RawFill};
use crate::wake::{Fills, Period, Watcher};
use std::net::{Ipv4Addr, SocketAddr};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex};

/// What a [`FrameFill`] is told about the frame it fills.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct FillInfo {
    /// The frame's GigE Vision block id as sent: 16 bits, 1 … 65 535, 0 skipped at the wrap (a
    /// client's [`FrameIds`](crate::FrameIds) counts it on across the wrap; its low 16 bits are
    /// this id).
    pub frame_id: u64,
    /// The frame's timestamp, ns (the camera's clock: the host's real-time clock for Aravis's
    /// fake camera), as the client will receive it.
    pub timestamp_ns: u64,
    /// 0 for the first frame this camera serves, then one more per frame served.
    pub index: u64,
    /// Width of the frame, px (the client's `Width`).
    pub width: u32,
    /// Height of the frame, px (the client's `Height`).
    pub height: u32,
    /// True when the client chose Mono8 (the only format the callback is asked to fill; for any
    /// other the buffer is left as it is).
    pub mono8: bool,
    /// The client's `ExposureTime`, µs.
    pub exposure_us: u32,
    /// The client's raw gain (`GainRaw`).
    pub gain_raw: u32,
}

/// Fills each frame a [`FakeGvCamera`] serves. Called on Aravis's streaming thread, one frame
/// at a time; `pixels` holds `width × height` bytes (row-major Mono8) or more.
pub trait FrameFill: Send + 'static {
    /// Draws the frame `info` into `pixels`.
    fn fill(&mut self, info: &FillInfo, pixels: &mut [u8]);
}

impl<F: FnMut(&FillInfo, &mut [u8]) + Send + 'static> FrameFill for F {
    fn fill(&mut self, info: &FillInfo, pixels: &mut [u8]) {
        self(info, pixels)
    }
}

/// The id and timestamp a served frame got.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ServedFrame {
    /// As in [`FillInfo::index`].
    pub index: u64,
    /// As in [`FillInfo::frame_id`].
    pub frame_id: u64,
    /// As in [`FillInfo::timestamp_ns`].
    pub timestamp_ns: u64,
}

/// How to start a [`FakeGvCamera`].
#[derive(Debug, Clone, PartialEq)]
pub struct FakeConfig {
    /// The interface's IPv4 address (or name) to serve on. Default: `127.0.0.1`.
    pub address: String,
    /// Serial number (at most 15 characters); the camera's id is `Aravis-Fake-SERIAL`.
    pub serial: String,
    /// Frames per second when free running. Default: 100.
    pub fps: f64,
    /// The sensor's size, px (`SensorWidth`, `SensorHeight`); default 1920 × 1080, the station's.
    pub sensor: (u32, u32),
    /// The fraction of stream packets the camera drops (0 … 1; Aravis's `gvsp-lost-ratio`).
    pub lost_ratio: f64,
}

impl Default for FakeConfig {
    fn default() -> Self {
        FakeConfig {
            address: "127.0.0.1".into(),
            serial: "GONIO01".into(),
            fps: 100.0,
            sensor: (1920, 1080),
            lost_ratio: 0.0,
        }
    }
}

const REG_SENSOR_WIDTH: u32 = 0x11c;
const REG_SENSOR_HEIGHT: u32 = 0x118;
const REG_FRAME_PERIOD_US: u32 = 0x138;
/// `ARV_PIXEL_FORMAT_MONO_8`.
const MONO8: u32 = 0x0108_0001;

/// A GigE Vision camera serving caller-drawn frames (see the module docs). Stops serving when
/// dropped.
pub struct FakeGvCamera {
    // Dropped in this order: the GigE Vision camera (its thread joined), then the fill pattern
    // (whose guard takes the pattern back from Aravis before it frees the closure).
    gv: Option<aravis::GvFakeCamera>,
    fake: Option<aravis::FakeCamera>,
    _fill: Option<ffi::FillGuard>,
    served: Arc<AtomicU64>,
    last: Arc<Mutex<Option<ServedFrame>>>,
    config: FakeConfig,
    watcher: Option<Watcher>,
}

impl std::fmt::Debug for FakeGvCamera {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("FakeGvCamera")
            .field("config", &self.config)
            .field("served", &self.frames_served())
            .field("wakeups", &self.wakeups())
            .finish_non_exhaustive()
    }
}

impl FakeGvCamera {
    /// Starts serving on `config.address` with `fill` drawing every frame.
    ///
    /// # Errors
    /// [`CameraError::FakeCamera`] when the serial or rate is invalid, another GigE Vision
    /// camera answers on port 3956 of the address (named), or the camera cannot listen (no such
    /// interface).
    pub fn start(config: &FakeConfig, fill: impl FrameFill) -> Result<Self, CameraError> {
        let bad = |message: String| CameraError::FakeCamera {
            serial: config.serial.clone(),
            address: config.address.clone(),
            message,
        };
        if config.serial.is_empty() || config.serial.len() > 15 || !config.serial.is_ascii() {
            return Err(bad("the serial must be 1 to 15 ASCII characters".into()));
        }
        if !(config.fps.is_finite() && config.fps > 0.0 && config.fps <= 10_000.0) {
            return Err(bad(format!(
                "{} frames/s: expected 0 < fps ≤ 10000",
                config.fps
            )));
        }
        if !(0.0..=1.0).contains(&config.lost_ratio) {
            return Err(bad(format!(
                "lost ratio {}: expected 0 … 1",
                config.lost_ratio
            )));
        }
        if !ffi::custom_fill_supported() {
            return Err(bad(
                "this libaravis keeps its buffers in an unexpected layout: frames cannot be drawn"
                    .into(),
            ));
        }
        // One GigE Vision camera per address and port: Aravis would start a second one beside
        // the first (its socket shares the port), which then serves nothing.
        if let Ok(ip) = config.address.parse::<std::net::IpAddr>() {
            let at = SocketAddr::new(ip, crate::gvcp::GVCP_PORT);
            let timeout = std::time::Duration::from_millis(300);
            let there = crate::gvcp::discover(at, timeout)
                .map(|c| c.id())
                .or_else(|| crate::gvcp::answers(at, timeout).then(|| "a device".into()));
            if let Some(other) = there {
                return Err(bad(format!(
                    "{other} already serves port {} of {}: one GigE Vision camera per address and port; stop it, or serve Aravis-Fake-{} on another address",
                    crate::gvcp::GVCP_PORT,
                    config.address,
                    config.serial
                )));
            }
        }
        let gv = aravis::GvFakeCamera::new(Some(&config.address), Some(&config.serial));
        if !gv.is_running() {
            return Err(bad(
                "cannot listen (is another GigE Vision camera on port 3956 of this address?)"
                    .into(),
            ));
        }
        let fake = gv
            .fake_camera()
            .ok_or_else(|| bad("Aravis gave no fake camera".into()))?;
        fake.write_register(REG_SENSOR_WIDTH, config.sensor.0);
        fake.write_register(REG_SENSOR_HEIGHT, config.sensor.1);
        fake.write_register(
            REG_FRAME_PERIOD_US,
            (1e6 / config.fps).round().max(1.0) as u32,
        );
        if config.lost_ratio > 0.0 {
            gv.set_gvsp_lost_ratio(config.lost_ratio);
        }
        let served = Arc::new(AtomicU64::new(0));
        let last = Arc::new(Mutex::new(None));
        let fills = Arc::new(Fills::new());
        let (served2, last2, fills2) = (served.clone(), last.clone(), fills.clone());
        let mut period = Period::default();
        let mut fill = fill;
        let f: Box<FillFn> = Box::new(move |raw: &RawFill, px: &mut [u8]| {
            period.filled(&fills2, fills2.now_ns());
            let index = served2.load(Ordering::Relaxed);
            let info = FillInfo {
                frame_id: raw.frame_id,
                timestamp_ns: raw.timestamp_ns,
                index,
                width: raw.width,
                height: raw.height,
                mono8: raw.pixel_format == MONO8,
                exposure_us: raw.exposure_us,
                gain_raw: raw.gain,
            };
            let n = (raw.width as usize * raw.height as usize).min(px.len());
            if info.mono8 {
                fill.fill(&info, &mut px[..n]);
            }
            *last2.lock().unwrap_or_else(|e| e.into_inner()) = Some(ServedFrame {
                index,
                frame_id: raw.frame_id,
                timestamp_ns: raw.timestamp_ns,
            });
            served2.store(index + 1, Ordering::Release);
        });
        let holder = ffi::set_fill(&fake, f);
        let watcher = match config.address.parse::<Ipv4Addr>() {
            Ok(ip) => Some(
                Watcher::start(fills, SocketAddr::from((ip, 3956)))
                    .map_err(|e| bad(format!("cannot start the stall watcher: {e}")))?,
            ),
            Err(_) => None,
        };
        Ok(FakeGvCamera {
            gv: Some(gv),
            fake: Some(fake),
            _fill: Some(holder),
            served,
            last,
            config: config.clone(),
            watcher,
        })
    }

    /// The camera's id as Aravis lists it (what `gonio detect --camera` takes).
    pub fn id(&self) -> String {
        format!("Aravis-Fake-{}", self.config.serial)
    }

    /// The address it serves on.
    pub fn address(&self) -> &str {
        &self.config.address
    }

    /// Frames served (filled) so far.
    pub fn frames_served(&self) -> u64 {
        self.served.load(Ordering::Acquire)
    }

    /// The id and timestamp of the last frame served.
    pub fn last_served(&self) -> Option<ServedFrame> {
        *self.last.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// GVCP reads sent so far to wake Aravis's thread from a stalled sleep (module docs).
    pub fn wakeups(&self) -> u64 {
        self.watcher.as_ref().map_or(0, Watcher::wakeups)
    }

    /// Drops this fraction of the stream's packets from now on (0 … 1).
    pub fn set_lost_ratio(&self, ratio: f64) {
        if let Some(gv) = &self.gv {
            gv.set_gvsp_lost_ratio(ratio.clamp(0.0, 1.0));
        }
    }

    /// True while the camera serves.
    pub fn is_running(&self) -> bool {
        self.gv.as_ref().is_some_and(|g| g.is_running())
    }
}

impl Drop for FakeGvCamera {
    fn drop(&mut self) {
        // The watcher first (it only sends to the camera); then the GigE Vision camera, which
        // joins its thread when finalized; only then may the closure go.
        self.watcher.take();
        self.fake.take();
        self.gv.take();
        self._fill.take();
    }
}
