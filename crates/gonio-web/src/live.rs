//! The live view's feed: a [`Hub`] that the station's thread publishes to through a
//! [`LiveObserver`] (a `gonio_station::observe::Observer`: the controller knows nothing of the
//! web), holding the current state for a page that connects mid-part and broadcasting every
//! event to the connected pages. Publishing never blocks the station: a page that falls behind
//! loses events and is told to reload the state.

use base64::Engine as _;
use gonio_station::fit::EccentricityFit;
use gonio_station::observe::{LiveFrame, Observer, Phase};
use gonio_station::record::{PartRecord, PushRecord, TurnRecord};
use image::ImageEncoder as _;
use serde::Serialize;
use serde_json::{Value, json};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};
use tokio::sync::broadcast;

/// One event for the pages: its SSE name and its JSON data.
#[derive(Debug, Clone)]
pub struct Event {
    /// SSE event name (`part`, `phase`, `frames`, `turn`, `push`, `finished`, `stored`, `image`).
    pub name: &'static str,
    /// The data, JSON.
    pub data: String,
}

/// What a page needs to draw the live view when it connects.
#[derive(Debug, Clone, Default, Serialize)]
pub struct LiveState {
    /// Whether a station is attached to this dashboard.
    pub station: bool,
    /// The part being mounted.
    pub serial: Option<String>,
    /// What the station is doing (`focus`, `measure`, `push`, `idle`).
    pub phase: String,
    /// Index of the turn in progress within the part.
    pub turn: usize,
    /// The live points of the turn in progress: (angle turned since its first frame °, c px).
    pub points: Vec<[f64; 2]>,
    /// Frames of the turn so far and in all.
    pub frames: [usize; 2],
    /// The last evaluated turn: its samples and fitted curve.
    pub last_turn: Option<Value>,
    /// The pushes of the part so far.
    pub pushes: Vec<Value>,
    /// The last frame's ring column, px (the thumbnail).
    pub c_px: Option<f64>,
    /// The last frame image with its detected edges (rendered or camera frames; none at the
    /// simulation's fast fidelity).
    pub image: Option<Value>,
    /// The phase times of the last finished part ([`phase_times_json`]).
    pub last_phase_times: Option<Value>,
    /// Events published so far.
    pub events: u64,
}

/// A camera frame for the live view: the whole frame reduced, and a strip around the ring at
/// full column resolution, with the columns of the edges the detector found.
#[derive(Debug, Clone, Serialize)]
pub struct FrameImage {
    /// The whole frame, reduced (a PNG data URL).
    pub src: String,
    /// The frame's width, px (the edges' columns are in the frame's pixels).
    pub width: u32,
    /// The frame's height, px.
    pub height: u32,
    /// The detected edges' columns, px.
    pub edges_px: Vec<f64>,
    /// A strip of full-resolution columns around the ring (a PNG data URL), if the ring was
    /// found.
    pub zoom_src: Option<String>,
    /// The strip's first column in the frame, px.
    pub zoom_x0_px: u32,
    /// The strip's width, px (frame columns).
    pub zoom_width_px: u32,
}

/// Where the station's events meet the pages.
pub struct Hub {
    tx: broadcast::Sender<Arc<Event>>,
    state: Mutex<LiveState>,
    status: Mutex<Option<StatusSource>>,
    plc: Mutex<Option<StatusSource>>,
}

/// What `/api/status` reports about the station itself (called for each request: it should
/// read a snapshot, not the station).
pub type StatusSource = Box<dyn Fn() -> Value + Send>;

impl std::fmt::Debug for Hub {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Hub").finish_non_exhaustive()
    }
}

impl Hub {
    /// A hub; `station`: whether a station will publish to it.
    pub fn new(station: bool) -> Arc<Hub> {
        let (tx, _) = broadcast::channel(1024);
        Arc::new(Hub {
            tx,
            state: Mutex::new(LiveState {
                station,
                phase: "idle".into(),
                ..LiveState::default()
            }),
            status: Mutex::new(None),
            plc: Mutex::new(None),
        })
    }

    /// Subscribes to the events from now on.
    pub fn subscribe(&self) -> broadcast::Receiver<Arc<Event>> {
        self.tx.subscribe()
    }

    /// The current state.
    pub fn state(&self) -> LiveState {
        self.state.lock().map(|s| s.clone()).unwrap_or_default()
    }

    /// Sets where `/api/status` reads the station's own figures (its frame timing).
    pub fn set_status_source(&self, f: StatusSource) {
        Self::put(&self.status, f);
    }

    /// The station's own figures (`null` without a source).
    pub fn station_status(&self) -> Value {
        Self::read(&self.status)
    }

    /// Sets where `/api/status` reads the figures of the station's PLC link (`plc`: requests,
    /// round trips, frames paired and stale) when the station runs through a PLC.
    pub fn set_plc_source(&self, f: StatusSource) {
        Self::put(&self.plc, f);
    }

    /// The PLC link's figures (`null` without a source: no station through a PLC).
    pub fn plc_status(&self) -> Value {
        Self::read(&self.plc)
    }

    fn put(source: &Mutex<Option<StatusSource>>, f: StatusSource) {
        if let Ok(mut s) = source.lock() {
            *s = Some(f);
        }
    }

    fn read(source: &Mutex<Option<StatusSource>>) -> Value {
        source
            .lock()
            .ok()
            .and_then(|s| s.as_ref().map(|f| f()))
            .unwrap_or(Value::Null)
    }

    /// Publishes an event after updating the state with `update`.
    pub fn publish(&self, name: &'static str, data: Value, update: impl FnOnce(&mut LiveState)) {
        if let Ok(mut s) = self.state.lock() {
            update(&mut s);
            s.events += 1;
        }
        // No receiver is not an error: nobody is watching.
        let _ = self.tx.send(Arc::new(Event {
            name,
            data: data.to_string(),
        }));
    }

    /// A part was committed to the store with id `part` (the history can show it).
    pub fn part_stored(&self, part: i64, serial: &str, result: &str) {
        self.publish(
            "stored",
            json!({"part": part, "serial": serial, "result": result}),
            |_| {},
        );
    }

    /// The station has finished its batch.
    pub fn batch_finished(&self, message: &str) {
        self.publish("batch", json!({"message": message}), |s| {
            s.phase = "idle".into();
            s.serial = None;
        });
    }

    /// A frame image (the simulation at full fidelity, or a real camera's frame) with the
    /// detector's edges, for the live thumbnail.
    pub fn image(&self, frame: &FrameImage) {
        let v = serde_json::to_value(frame).unwrap_or(Value::Null);
        self.publish("image", v.clone(), |s| s.image = Some(v));
    }
}

/// Publishes the station's events to a [`Hub`]. Frames are sent in small batches (at most
/// every 40 ms of wall time) so a fast simulation does not flood the pages.
#[derive(Debug)]
pub struct LiveObserver {
    hub: Arc<Hub>,
    pending: Vec<[f64; 2]>,
    first_deg: Option<f64>,
    last_flush: Instant,
    frame: (usize, usize, usize),
    last_c: Option<f64>,
}

impl LiveObserver {
    /// An observer publishing to `hub`.
    pub fn new(hub: Arc<Hub>) -> Self {
        LiveObserver {
            hub,
            pending: Vec::new(),
            first_deg: None,
            last_flush: Instant::now(),
            frame: (0, 0, 0),
            last_c: None,
        }
    }

    fn flush(&mut self) {
        let (turn, index, frames) = self.frame;
        let pts = std::mem::take(&mut self.pending);
        let c = self.last_c;
        self.last_flush = Instant::now();
        self.hub.publish(
            "frames",
            json!({"turn": turn, "index": index, "frames": frames, "points": pts, "c_px": c}),
            |s| {
                if s.turn != turn {
                    s.turn = turn;
                    s.points.clear();
                }
                s.points.extend_from_slice(&pts);
                s.frames = [index + 1, frames];
                s.c_px = c;
            },
        );
    }
}

/// A number, or `null` when it is not defined (`None`) or not finite.
fn num(x: impl Into<Option<f64>>) -> Value {
    match x.into() {
        Some(x) if x.is_finite() => json!(x),
        _ => Value::Null,
    }
}

/// A turn for the live view: samples and the fitted curve, in the angle turned since the
/// turn's first sample (so the live trace and the evaluated turn share one axis).
pub fn turn_json(index: usize, t: &TurnRecord, fit: Option<&EccentricityFit>) -> Value {
    let theta0 = t.samples.first().map_or(0.0, |s| s.theta_deg);
    let samples: Vec<[f64; 2]> = t
        .samples
        .iter()
        .map(|s| [s.theta_deg - theta0, s.c_px])
        .collect();
    let curve: Vec<[f64; 2]> = fit
        .map(|f| {
            (0..=120)
                .map(|i| {
                    let x = 3.0 * i as f64;
                    [x, f.model_px(theta0 + x)]
                })
                .collect()
        })
        .unwrap_or_default();
    json!({
        "turn": index,
        "kind": t.kind,
        "frames_taken": t.frames_taken,
        "valid_frames": t.samples.len(),
        "e_um": num(t.e_um),
        "theta_max_deg": num(t.theta_max_deg),
        "residual_rms_px": num(t.residual_rms_px),
        "trusted": t.quality.as_ref().map(|q| q.ok),
        "reasons": t.quality.as_ref().map(|q| q.reasons()).unwrap_or_default(),
        "samples": samples,
        "curve": curve,
    })
}

/// A finished part's time by phase, s: focus (how many checks of the carried focus, how many
/// sweeps), measure, push, and the push's align (with the servo's brake), approach, stroke and
/// retract (`null`: not recorded).
pub fn phase_times_json(r: &PartRecord) -> Value {
    let t = &r.phase_times;
    json!({
        "serial": r.serial,
        "time_s": num(r.time_s),
        "pushes": r.pushes,
        "focus_s": num(t.focus_s),
        "focus_checks": r.focus_checks,
        "focus_sweeps": r.focus_sweeps,
        "measure_s": num(t.measure_s),
        "turns": r.turns.len(),
        "push_s": num(t.push_s),
        "align_s": num(t.align_s),
        "approach_s": num(t.approach_s),
        "stroke_s": num(t.stroke_s),
        "retract_s": num(t.retract_s),
    })
}

fn push_json(p: &PushRecord) -> Value {
    json!({
        "e_before_um": num(p.e_before_um),
        "commanded_um": num(p.commanded_um),
        "angle_deg": num(p.angle_deg),
        "approach": p.approach,
        "steps": p.steps,
        "predicted_e_after_um": num(p.predicted_e_after_um),
        "duration_s": num(p.duration_s),
    })
}

impl Observer for LiveObserver {
    fn part_started(&mut self, serial: &str) {
        let serial = serial.to_string();
        self.hub.publish("part", json!({"serial": serial}), |s| {
            s.serial = Some(serial.clone());
            s.points.clear();
            s.pushes.clear();
            s.last_turn = None;
            s.turn = 0;
            s.frames = [0, 0];
        });
    }

    fn phase(&mut self, phase: Phase) {
        let name = match phase {
            Phase::Focus => "focus",
            Phase::Measure(_) => "measure",
            Phase::Push => "push",
        };
        self.hub
            .publish("phase", json!({"phase": name}), |s| s.phase = name.into());
    }

    fn frame(&mut self, f: &LiveFrame) {
        if f.index == 0 {
            self.first_deg = Some(f.turn_deg);
            self.pending.clear();
        }
        let x = f.turn_deg - self.first_deg.unwrap_or(f.turn_deg);
        if let Some(c) = f.c_px {
            self.pending.push([x, c]);
        }
        self.last_c = f.c_px;
        self.frame = (f.turn, f.index, f.frames);
        if f.index + 1 == f.frames || self.last_flush.elapsed() >= Duration::from_millis(40) {
            self.flush();
        }
    }

    fn turn(&mut self, turn: &TurnRecord, fit: Option<&EccentricityFit>) {
        let index = self.frame.0;
        let v = turn_json(index, turn, fit);
        self.hub
            .publish("turn", v.clone(), |s| s.last_turn = Some(v.clone()));
    }

    fn push(&mut self, push: &PushRecord) {
        let v = push_json(push);
        self.hub.publish("push", v.clone(), |s| s.pushes.push(v));
    }

    fn part_finished(&mut self, r: &PartRecord) {
        let times = phase_times_json(r);
        self.hub.publish(
            "finished",
            json!({
                "serial": r.serial,
                "result": r.result.name(),
                "final_e_um": num(r.final_e_um),
                "pushes": r.pushes,
                "time_s": num(r.time_s),
                "reject_reason": r.reject_reason,
                "phase_times": times,
            }),
            |s| {
                s.phase = "idle".into();
                s.last_phase_times = Some(times.clone());
            },
        );
    }
}

/// An 8-bit grey image as a PNG data URL.
fn png_url(px: &[u8], w: usize, h: usize) -> Option<String> {
    let mut png = Vec::new();
    image::codecs::png::PngEncoder::new(&mut png)
        .write_image(px, w as u32, h as u32, image::ExtendedColorType::L8)
        .ok()?;
    Some(format!(
        "data:image/png;base64,{}",
        base64::engine::general_purpose::STANDARD.encode(&png)
    ))
}

/// Columns of the full-resolution strip around the ring.
const ZOOM_COLUMNS: usize = 360;

/// The live view's picture of a frame: the whole frame at a quarter (4 × 4 pixel means), and
/// the 360 columns around the ring's column at full resolution (every 4th row), with the
/// detected edges.
///
/// `pixels` are the frame's 8-bit grey pixels, row-major, `width` × `height`; `edges_px` the
/// columns of the edges the detector found and `c_px` the ring's column it found (if none, the
/// middle of two edges). `None` for a frame too small or short of pixels.
pub fn thumbnail(
    width: usize,
    height: usize,
    pixels: &[u8],
    edges_px: Vec<f64>,
    c_px: Option<f64>,
) -> Option<FrameImage> {
    let (w, h) = (width / 4, height / 4);
    if w == 0 || h == 0 || pixels.len() < width * height {
        return None;
    }
    let mut small = vec![0u8; w * h];
    for (y, row) in small.chunks_exact_mut(w).enumerate() {
        for (x, px) in row.iter_mut().enumerate() {
            let mut sum = 0u32;
            for dy in 0..4 {
                let line = &pixels[(4 * y + dy) * width + 4 * x..][..4];
                sum += line.iter().map(|&v| u32::from(v)).sum::<u32>();
            }
            *px = (sum / 16) as u8;
        }
    }
    let centre = c_px.or_else(|| (edges_px.len() == 2).then(|| 0.5 * (edges_px[0] + edges_px[1])));
    let zw = ZOOM_COLUMNS.min(width);
    let x0 = centre.map_or(0, |c| {
        (c.round() as i64 - zw as i64 / 2).clamp(0, (width - zw) as i64) as usize
    });
    let zoom_src = centre.and_then(|_| {
        let strip: Vec<u8> = (0..h)
            .flat_map(|y| pixels[4 * y * width + x0..][..zw].iter().copied())
            .collect();
        png_url(&strip, zw, h)
    });
    Some(FrameImage {
        src: png_url(&small, w, h)?,
        width: width as u32,
        height: height as u32,
        edges_px,
        zoom_src,
        zoom_x0_px: x0 as u32,
        zoom_width_px: zw as u32,
    })
}

#[cfg(test)]
mod tests {
    use super::{Hub, thumbnail};

    #[test]
    fn the_status_sources_are_read_when_asked_and_null_without_one() {
        let hub = Hub::new(true);
        assert!(hub.station_status().is_null() && hub.plc_status().is_null());
        let n = std::sync::Arc::new(std::sync::atomic::AtomicU64::new(3));
        let m = n.clone();
        hub.set_plc_source(Box::new(
            move || serde_json::json!({"requests": m.load(std::sync::atomic::Ordering::Relaxed)}),
        ));
        assert_eq!(hub.plc_status()["requests"], 3);
        n.store(5, std::sync::atomic::Ordering::Relaxed);
        assert_eq!(hub.plc_status()["requests"], 5);
        assert!(hub.station_status().is_null());
    }

    #[test]
    fn thumbnail_reduces_the_frame_and_clamps_the_strip_to_it() {
        let (w, h) = (400, 8);
        let pixels: Vec<u8> = (0..w * h).map(|i| (i % 251) as u8).collect();
        // The ring near the right edge: the 360-column strip ends at the frame's edge.
        let img = thumbnail(w, h, &pixels, vec![390.0, 398.0], None).expect("an image");
        assert!(img.src.starts_with("data:image/png;base64,"));
        assert_eq!((img.width, img.height), (400, 8));
        assert_eq!(img.edges_px, vec![390.0, 398.0]);
        assert_eq!((img.zoom_x0_px, img.zoom_width_px), (40, 360));
        assert!(img.zoom_src.is_some());
        // No ring found: no strip.
        let img = thumbnail(w, h, &pixels, vec![], None).expect("an image");
        assert!(img.zoom_src.is_none());
        assert_eq!(img.zoom_x0_px, 0);
        // Too small, or short of pixels.
        assert!(thumbnail(3, 8, &pixels, vec![], None).is_none());
        assert!(thumbnail(w, h, &pixels[..10], vec![], Some(5.0)).is_none());
    }
}
