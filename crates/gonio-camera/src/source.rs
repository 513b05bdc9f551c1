//! [`AravisSource`]: a GenICam camera opened through Aravis, set up for the detector, as a
//! [`FrameSource`].
//!
//! Set-up, in this order: the pixel format (`Mono8`; else `Mono16`, `Mono12`, `Mono10`, scaled to
//! 8 bits by dropping the low bits: a 12-bit grey g becomes g >> 4), the window (`Width`,
//! `Height`, `OffsetX`, `OffsetY`; centred on the sensor unless an offset is given), exposure
//! (`ExposureTime`, µs, checked against the camera's bounds), gain (`Gain`, dB, checked), the
//! trigger (free running, `TriggerSoftware`, or `Line1`), the GigE Vision packet size and the
//! stream ([`StreamOptions`](crate::StreamOptions)). Each frame's pixels are copied into the
//! caller's buffer; its [`FrameMeta`] (the camera's `frame_id`, counted across the 16-bit wrap,
//! its `timestamp_ns`, whether it is complete, how many frames are missing before it) is kept
//! until [`AravisSource::take_meta`] takes it by the stamp's index (the frame's slot).
//!
//! # Timestamps and the station clock
//! `FrameStamp::start_s` is the camera's timestamp mapped to the host's monotonic clock, s since
//! [`AravisSource::epoch`]: `start_s = o + (t − t₀)·10⁻⁹`, with t the frame's timestamp (ns,
//! camera clock), t₀ the first complete frame's, and the offset o the smallest `a − (t − t₀)·10⁻⁹`
//! over the complete frames so far (a: a frame's arrival on the host). Every frame arrives some
//! time after its exposure (its transfer, the receiving thread's wake-up, on a loaded machine a
//! wait for a core); the least delayed frame seen is the best estimate of the offset between the
//! two clocks, and with it no frame is ever stamped after it arrived. The offset settles within
//! the first frames of a run (it moves only when a frame arrives sooner after its exposure than
//! every one before, by the difference); between such moves the intervals are the camera's own
//! (no host jitter). What remains is the least transfer time (a constant lag, which cancels in an
//! eccentricity fit's amplitude) and the two clocks' rate difference (tens of ppm: microseconds
//! over a 2 s turn). Incomplete frames (they arrive late, after the stream has waited for their
//! missing packets) do not move the offset; frames before the first complete one are mapped
//! provisionally on themselves. `exposure_s` is the camera's `ExposureTime` read after set-up.
//!
//! # Teardown
//! Dropping the source stops acquisition and releases the camera, unless the camera is gone or
//! silent: no frame within the frame timeout, or (a GigE Vision camera) no answer to a register
//! read within 2 × 0.25 s when it is dropped ([`crate::gvcp::answers`]). Its objects are then
//! left to the process's end, as Aravis would wait seconds for each of their control requests.
//! A camera that answered and falls silent during the teardown holds the drop at most 1 s: the
//! teardown runs in a thread of its own, which finishes after the drop has returned.
//!
//! # Errors
//! Every error names the camera: not found, refused settings, values out of range, a link
//! failure, and no frame within [`CameraConfig::frame_timeout_ms`] (the camera gone).

use crate::config::{CameraConfig, FrameMeta, StreamStats, Trigger, Window};
use crate::ids::FrameIds;
use crate::{CameraError, ffi};
use aravis::glib::prelude::Cast;
use aravis::prelude::*;
use aravis::{BufferStatus, PixelFormat};
use gonio_vision::{FrameHeader, FrameSource, FrameStamp};
use std::collections::BTreeMap;
use std::net::{IpAddr, SocketAddr};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

/// Most [`FrameMeta`] kept for [`AravisSource::take_meta`] (the oldest go first).
const MAX_META: usize = 4096;

/// A camera streaming into the detector (see the module docs).
pub struct AravisSource {
    name: String,
    camera: aravis::Camera,
    stream: aravis::Stream,
    config: CameraConfig,
    window: Window,
    /// Bits per pixel of the camera's format (8, 10, 12 or 16).
    bits: u32,
    exposure_s: Option<f64>,
    ids: FrameIds,
    epoch: Instant,
    /// The clock mapping: the first complete frame's timestamp (ns) and the offset (s, host
    /// clock at that timestamp; module docs).
    first: Option<(u64, f64)>,
    /// The last slot received.
    last_slot: Option<u64>,
    meta: Mutex<BTreeMap<u64, FrameMeta>>,
    stats: StreamStats,
    /// Missing slots at the end of a run of `frames` (after the last frame delivered).
    trailing_missing: u64,
    ended: bool,
    stop: Option<Arc<AtomicBool>>,
    acquiring: bool,
    /// The camera stopped answering: its objects are not torn down on drop (that would wait for
    /// the control channel's retries).
    gone: bool,
    /// A GigE Vision camera's control port, asked before the teardown whether it still answers.
    gvcp: Option<SocketAddr>,
}

impl std::fmt::Debug for AravisSource {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("AravisSource")
            .field("name", &self.name)
            .field("window", &self.window)
            .field("stats", &self.stats)
            .finish_non_exhaustive()
    }
}

fn comm(camera: &str, action: &str, e: impl std::fmt::Display) -> CameraError {
    CameraError::Communication {
        camera: camera.to_string(),
        action: action.to_string(),
        message: e.to_string(),
    }
}

impl AravisSource {
    /// Opens the camera `id` (as [`list_cameras`](crate::list_cameras) gives it), sets it up and
    /// starts acquisition.
    ///
    /// # Errors
    /// [`CameraError::NotFound`] when no camera has that id; [`CameraError::Refused`] and
    /// [`CameraError::OutOfRange`] for settings the camera does not take;
    /// [`CameraError::Communication`] when it cannot be reached.
    pub fn open(id: &str, config: &CameraConfig) -> Result<Self, CameraError> {
        let found = crate::list_cameras();
        let Some(info) = found.iter().find(|c| c.id == id) else {
            let ids: Vec<_> = found.iter().map(|c| c.id.as_str()).collect();
            return Err(CameraError::NotFound {
                camera: id.to_string(),
                found: if ids.is_empty() {
                    "none".into()
                } else {
                    ids.join(", ")
                },
            });
        };
        let gvcp = (info.protocol == "GigEVision")
            .then(|| info.address.parse::<IpAddr>().ok())
            .flatten()
            .map(|ip| SocketAddr::new(ip, crate::gvcp::GVCP_PORT));
        let camera = aravis::Camera::new(Some(id)).map_err(|e| comm(id, "open", e))?;
        let name = id.to_string();
        let mut src = AravisSource {
            name,
            stream: Self::setup(id, &camera, config)?,
            camera,
            config: config.clone(),
            window: Window {
                offset_x: 0,
                offset_y: 0,
                width: 0,
                height: 0,
            },
            bits: 8,
            exposure_s: None,
            ids: FrameIds::new(),
            epoch: Instant::now(),
            first: None,
            last_slot: None,
            meta: Mutex::new(BTreeMap::new()),
            stats: StreamStats::default(),
            trailing_missing: 0,
            ended: false,
            stop: None,
            acquiring: false,
            gone: false,
            gvcp,
        };
        let (x, y, w, h) = src
            .camera
            .region()
            .map_err(|e| comm(id, "read the window", e))?;
        src.window = Window {
            offset_x: x.max(0) as u32,
            offset_y: y.max(0) as u32,
            width: w.max(0) as u32,
            height: h.max(0) as u32,
        };
        let fmt = src
            .camera
            .pixel_format()
            .map_err(|e| comm(id, "read PixelFormat", e))?;
        src.bits = aravis::bits_per_pixel(fmt) as u32;
        src.exposure_s = src.camera.exposure_time().ok().map(|us| us * 1e-6);
        let payload = src
            .camera
            .payload()
            .map_err(|e| comm(id, "read PayloadSize", e))?;
        for _ in 0..config.stream.buffers.max(2) {
            src.stream
                .push_buffer(aravis::Buffer::new_allocate(payload as usize));
        }
        src.camera
            .start_acquisition()
            .map_err(|e| comm(id, "start acquisition", e))?;
        src.acquiring = true;
        src.epoch = Instant::now();
        Ok(src)
    }

    /// Applies the configuration and creates the stream.
    fn setup(
        id: &str,
        cam: &aravis::Camera,
        c: &CameraConfig,
    ) -> Result<aravis::Stream, CameraError> {
        // Pixel format: Mono8 first, else the widest mono format the camera has.
        let formats = cam
            .dup_available_pixel_formats_as_strings()
            .map_err(|e| comm(id, "read the pixel formats", e))?;
        let names: Vec<String> = formats.iter().map(|s| s.to_string()).collect();
        let choice = ["Mono8", "Mono16", "Mono12", "Mono10"]
            .into_iter()
            .find(|f| names.iter().any(|n| n == f));
        let Some(choice) = choice else {
            return Err(CameraError::Refused {
                camera: id.into(),
                feature: "PixelFormat".into(),
                value: "Mono8/Mono10/Mono12/Mono16".into(),
                message: format!("the camera offers {}", names.join(", ")),
            });
        };
        cam.set_pixel_format_from_string(choice)
            .map_err(|e| CameraError::Refused {
                camera: id.into(),
                feature: "PixelFormat".into(),
                value: choice.into(),
                message: e.to_string(),
            })?;
        let now = cam
            .pixel_format()
            .map_err(|e| comm(id, "read PixelFormat", e))?;
        let want = match choice {
            "Mono8" => PixelFormat::MONO_8,
            "Mono10" => PixelFormat::MONO_10,
            "Mono12" => PixelFormat::MONO_12,
            _ => PixelFormat::MONO_16,
        };
        if now != want {
            return Err(CameraError::Refused {
                camera: id.into(),
                feature: "PixelFormat".into(),
                value: choice.into(),
                message: "the camera kept its format".into(),
            });
        }
        // The window, centred on the sensor unless placed, within the sensor and the camera's
        // bounds of Width and Height.
        let (w, h) = c.window_size;
        let (sw, sh) = cam
            .sensor_size()
            .map_err(|e| comm(id, "read the sensor size", e))?;
        let (sw, sh) = (sw.max(0) as u32, sh.max(0) as u32);
        let (ox, oy) = match c.window_offset {
            Some(o) => o,
            None => {
                let xi = cam.x_offset_increment().unwrap_or(1).max(1) as u32;
                let yi = cam.y_offset_increment().unwrap_or(1).max(1) as u32;
                (
                    sw.saturating_sub(w) / 2 / xi * xi,
                    sh.saturating_sub(h) / 2 / yi * yi,
                )
            }
        };
        let refused = |e: &dyn std::fmt::Display| CameraError::Refused {
            camera: id.into(),
            feature: "Width/Height/OffsetX/OffsetY".into(),
            value: format!("{w}x{h}+{ox}+{oy}"),
            message: e.to_string(),
        };
        let (wb, hb) = (
            cam.width_bounds().unwrap_or((1, i32::MAX)),
            cam.height_bounds().unwrap_or((1, i32::MAX)),
        );
        let inside = |v: u32, b: (i32, i32)| {
            i64::from(v) >= i64::from(b.0) && i64::from(v) <= i64::from(b.1)
        };
        if w == 0 || h == 0 || ox + w > sw || oy + h > sh || !inside(w, wb) || !inside(h, hb) {
            return Err(refused(&format!(
                "outside the sensor ({sw}x{sh}) or the camera's Width {}…{}, Height {}…{}",
                wb.0, wb.1, hb.0, hb.1
            )));
        }
        cam.set_region(ox as i32, oy as i32, w as i32, h as i32)
            .map_err(|e| refused(&e))?;
        let got = cam.region().map_err(|e| comm(id, "read the window", e))?;
        if got != (ox as i32, oy as i32, w as i32, h as i32) {
            return Err(refused(&format!(
                "the camera set {}x{}+{}+{} instead",
                got.2, got.3, got.0, got.1
            )));
        }
        if let Some(us) = c.exposure_us {
            let (min, max) = cam
                .exposure_time_bounds()
                .map_err(|e| comm(id, "read the exposure bounds", e))?;
            if !(us >= min && us <= max) {
                return Err(CameraError::OutOfRange {
                    camera: id.into(),
                    feature: "ExposureTime (µs)".into(),
                    value: us,
                    min,
                    max,
                });
            }
            cam.set_exposure_time(us)
                .map_err(|e| CameraError::Refused {
                    camera: id.into(),
                    feature: "ExposureTime".into(),
                    value: format!("{us} µs"),
                    message: e.to_string(),
                })?;
        }
        if let Some(db) = c.gain_db {
            let (min, max) = cam
                .gain_bounds()
                .map_err(|e| comm(id, "read the gain bounds", e))?;
            if !(db >= min && db <= max) {
                return Err(CameraError::OutOfRange {
                    camera: id.into(),
                    feature: "Gain (dB)".into(),
                    value: db,
                    min,
                    max,
                });
            }
            cam.set_gain(db).map_err(|e| CameraError::Refused {
                camera: id.into(),
                feature: "Gain".into(),
                value: format!("{db} dB"),
                message: e.to_string(),
            })?;
        }
        let trig = |source: &str, e: aravis::glib::Error| CameraError::Refused {
            camera: id.into(),
            feature: "TriggerSource".into(),
            value: source.into(),
            message: e.to_string(),
        };
        match c.trigger {
            Trigger::Free => {
                // A camera without triggers is free running already.
                let _ = cam.clear_triggers();
            }
            Trigger::Software => cam
                .set_trigger("Software")
                .map_err(|e| trig("Software", e))?,
            Trigger::Line1 => cam.set_trigger("Line1").map_err(|e| trig("Line1", e))?,
        }
        if cam.is_gv_device() {
            if let Some(n) = c.packet_size {
                cam.gv_set_packet_size(n as i32)
                    .map_err(|e| CameraError::Refused {
                        camera: id.into(),
                        feature: "GevSCPSPacketSize".into(),
                        value: n.to_string(),
                        message: e.to_string(),
                    })?;
            }
            cam.gv_set_stream_options(if c.stream.packet_socket_disabled {
                aravis::GvStreamOption::PACKET_SOCKET_DISABLED
            } else {
                aravis::GvStreamOption::NONE
            });
        }
        let stream = cam
            .create_stream()
            .map_err(|e| comm(id, "create the stream", e))?;
        if let Some(gv) = stream.downcast_ref::<aravis::GvStream>() {
            if let Some(bytes) = c.stream.socket_buffer_bytes {
                gv.set_socket_buffer(aravis::GvStreamSocketBuffer::Fixed);
                gv.set_socket_buffer_size(bytes.min(i32::MAX as u32) as i32);
            }
            gv.set_packet_resend(if c.stream.packet_resend {
                aravis::GvStreamPacketResend::Always
            } else {
                aravis::GvStreamPacketResend::Never
            });
        }
        Ok(stream)
    }

    /// The camera's id.
    pub fn name(&self) -> &str {
        &self.name
    }

    /// The window the camera streams.
    pub fn window(&self) -> Window {
        self.window
    }

    /// The origin of `FrameStamp::start_s` on the host's monotonic clock.
    pub fn epoch(&self) -> Instant {
        self.epoch
    }

    /// What the stream did so far.
    pub fn stats(&self) -> StreamStats {
        let mut s = self.stats;
        if let Some(gv) = self.stream.downcast_ref::<aravis::GvStream>() {
            let (resent, missing) = gv.statistics();
            s.resent_packets = resent;
            s.missing_packets = missing;
        }
        s
    }

    /// Takes the [`FrameMeta`] of the frame whose stamp has this index (its slot); the last 4096
    /// frames' are kept.
    pub fn take_meta(&self, index: u64) -> Option<FrameMeta> {
        self.meta
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .remove(&index)
    }

    /// Frame slots missing after the last frame delivered, up to the configured frame count.
    pub fn trailing_missing(&self) -> u64 {
        self.trailing_missing
    }

    /// Stops the stream at the next frame once `flag` is set (Ctrl-C): the source then ends as if
    /// the frames were all read.
    pub fn stop_on(&mut self, flag: Arc<AtomicBool>) {
        self.stop = Some(flag);
    }

    /// Stops acquisition (also done on drop).
    pub fn stop(&mut self) {
        if self.acquiring {
            let _ = self.camera.stop_acquisition();
            self.acquiring = false;
        }
    }

    /// Copies a buffer's pixels into `pixels` as 8-bit grey.
    fn copy_pixels(&self, bytes: &[u8], pixels: &mut Vec<u8>) {
        let n = self.window.width as usize * self.window.height as usize;
        pixels.clear();
        if self.bits <= 8 {
            pixels.extend_from_slice(&bytes[..n.min(bytes.len())]);
        } else {
            let shift = self.bits - 8;
            pixels.extend(
                bytes
                    .chunks_exact(2)
                    .take(n)
                    .map(|p| (u16::from_le_bytes([p[0], p[1]]) >> shift).min(255) as u8),
            );
        }
        pixels.resize(n, 0);
    }
}

/// How long the teardown waits for a GigE Vision camera to answer one register read, each of
/// two tries: a camera on a working link answers in milliseconds.
const TEARDOWN_PROBE: Duration = Duration::from_millis(250);

/// How long the drop waits for the camera's teardown (stop acquisition, release the camera):
/// milliseconds on a camera that answers; past it the teardown goes on in its own thread.
const TEARDOWN_WAIT: Duration = Duration::from_secs(1);

impl Drop for AravisSource {
    fn drop(&mut self) {
        // A camera that is gone (its host killed, its cable pulled) or silent is not stopped
        // and torn down: Aravis would wait for its control channel's retries, seconds each.
        if self.acquiring
            && !self.gone
            && let Some(at) = self.gvcp
            && !(0..2).any(|_| crate::gvcp::answers(at, TEARDOWN_PROBE))
        {
            self.acquiring = false;
            self.gone = true;
        }
        if self.gone {
            // Tearing a lost camera's device down waits for its control channel to time out
            // (seconds): leave the objects to the process's end instead (one lost camera each).
            std::mem::forget(self.stream.clone());
            std::mem::forget(self.camera.clone());
            return;
        }
        // A camera can fall silent after it answered (a simulated camera waiting for a trigger
        // that no longer comes, a link lost now): the teardown runs in its own thread, which
        // holds the last references, and the drop waits for it at most TEARDOWN_WAIT.
        let (camera, stream) = (self.camera.clone(), self.stream.clone());
        let acquiring = std::mem::take(&mut self.acquiring);
        let (done, finished) = std::sync::mpsc::channel();
        let teardown = move || {
            if acquiring {
                let _ = camera.stop_acquisition();
            }
            drop(stream);
            drop(camera);
            let _ = done.send(());
        };
        match std::thread::Builder::new()
            .name("gonio-camera-teardown".into())
            .spawn(teardown)
        {
            Ok(_) => {
                let _ = finished.recv_timeout(TEARDOWN_WAIT);
            }
            // No thread to be had: torn down here, however long that takes.
            Err(_) => {
                self.acquiring = acquiring;
                self.stop();
            }
        }
    }
}

impl FrameSource for AravisSource {
    type Error = CameraError;

    fn next_frame(&mut self, pixels: &mut Vec<u8>) -> Result<Option<FrameHeader>, CameraError> {
        let slice_ms = 100u64;
        loop {
            if self.ended {
                return Ok(None);
            }
            if let Some(n) = self.config.frames
                && self.last_slot.map_or(0, |s| s + 1) >= n
            {
                self.ended = true;
                self.stop();
                return Ok(None);
            }
            if self.config.trigger == Trigger::Software {
                self.camera
                    .software_trigger()
                    .map_err(|e| comm(&self.name, "software trigger", e))?;
            }
            // Wait in slices so that a stop request is seen within 0.1 s.
            let mut waited = 0u64;
            let buffer = loop {
                if self
                    .stop
                    .as_ref()
                    .is_some_and(|f| f.load(Ordering::Relaxed))
                {
                    self.ended = true;
                    self.stop();
                    return Ok(None);
                }
                if let Some(b) = self.stream.timeout_pop_buffer(slice_ms * 1000) {
                    break b;
                }
                waited += slice_ms;
                if waited >= self.config.frame_timeout_ms {
                    self.ended = true;
                    // The camera is likely gone: no stop command (its heartbeat lapses instead),
                    // which would wait for the control channel's retries.
                    self.acquiring = false;
                    self.gone = true;
                    return Err(CameraError::Timeout {
                        camera: self.name.clone(),
                        waited_ms: waited,
                        frames: self.stats.frames,
                    });
                }
            };
            let arrival = Instant::now();
            let arrival_s = arrival.duration_since(self.epoch).as_secs_f64();
            let status = buffer.status();
            let complete = status == BufferStatus::Success;
            let wire = buffer.frame_id();
            let ts = buffer.timestamp();
            let step = self.ids.next(wire);
            if step.repeated {
                // Repeated, or late after a newer frame (already counted as missing).
                self.stream.push_buffer(buffer);
                continue;
            }
            if let Some(n) = self.config.frames
                && step.slot >= n
            {
                // Beyond the run: the slots up to its end were missing.
                self.trailing_missing = n.saturating_sub(self.last_slot.map_or(0, |s| s + 1));
                self.stats.missing += self.trailing_missing;
                self.stream.push_buffer(buffer);
                self.ended = true;
                self.stop();
                return Ok(None);
            }
            self.stats.frames += 1;
            self.stats.missing += step.missing;
            if complete {
                self.stats.complete += 1;
            } else {
                self.stats.incomplete += 1;
            }
            // The offset: the least delayed complete frame so far (module docs). An incomplete
            // one arrives late (the stream waits for its missing packets) and is not used.
            let (t0, a0) = match (self.first, complete) {
                (None, false) => (ts, arrival_s),
                (None, true) => *self.first.insert((ts, arrival_s)),
                (Some((t0, o)), false) => (t0, o),
                (Some((t0, o)), true) => {
                    let here = arrival_s - (ts as f64 - t0 as f64) * 1e-9;
                    *self.first.insert((t0, o.min(here)))
                }
            };
            let meta = FrameMeta {
                slot: step.slot,
                frame_id: step.frame_id,
                timestamp_ns: ts,
                complete,
                arrival,
                missing_before: step.missing,
            };
            self.last_slot = Some(step.slot);
            if !complete && !self.config.deliver_incomplete {
                self.stream.push_buffer(buffer);
                continue;
            }
            self.copy_pixels(ffi::buffer_bytes(&buffer), pixels);
            self.stream.push_buffer(buffer);
            {
                let mut m = self.meta.lock().unwrap_or_else(|e| e.into_inner());
                m.insert(step.slot, meta);
                // Nobody takes them (the station's camera): keep the last ones only.
                while m.len() > MAX_META {
                    m.pop_first();
                }
            }
            let start_s = a0 + (ts as f64 - t0 as f64) * 1e-9;
            return Ok(Some(FrameHeader {
                width: self.window.width as usize,
                height: self.window.height as usize,
                stamp: FrameStamp {
                    index: step.slot,
                    start_s: Some(start_s),
                    exposure_s: self.exposure_s,
                    theta_deg: None,
                },
            }));
        }
    }
}
