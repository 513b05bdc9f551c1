//! Running the simulated station in real time (or a multiple of it), for a live view: after
//! every device action the simulation waits until the wall clock has caught up with the
//! simulated clock, and every camera frame's lateness against its schedule is recorded, so the
//! frame loop's timing can be checked while other work (a web server, a database) runs.
//!
//! ```
//! use gonio_sim::station::{FrameTiming, Pace};
//! let timing = FrameTiming::shared();
//! let mut pace = Pace::new(1000.0, timing.clone()); // 1000× real time
//! pace.rebase(0.0);
//! for k in 1..=10 {
//!     pace.frame_at(k as f64 * 0.01, 0.01); // a frame every 10 ms of simulated time
//! }
//! let s = timing.lock().unwrap().summary();
//! assert_eq!(s.frames, 10);
//! ```

use serde::Serialize;
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

/// Lateness samples kept for the percentiles (the most recent ones).
const KEEP: usize = 20_000;

/// The frame loop's timing: how late each frame was against its schedule.
#[derive(Debug, Clone, Default)]
pub struct FrameTiming {
    frames: u64,
    late_sum_s: f64,
    late_max_s: f64,
    /// Frames later than one frame period.
    late_frames: u64,
    period_s: f64,
    recent: Vec<f64>,
    next: usize,
}

/// A summary of [`FrameTiming`], ms.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct TimingSummary {
    /// Frames timed.
    pub frames: u64,
    /// Mean lateness of a frame against its schedule, ms (`null`: no frame timed).
    pub mean_late_ms: Option<f64>,
    /// Median lateness over the recent frames, ms (nearest rank, `gonio_core::quantile`).
    pub p50_late_ms: Option<f64>,
    /// 99th percentile of lateness over the recent frames, ms.
    pub p99_late_ms: Option<f64>,
    /// Largest lateness, ms.
    pub max_late_ms: Option<f64>,
    /// Frames later than one frame period (a missed frame slot).
    pub late_frames: u64,
    /// The frame period on the wall clock, ms.
    pub period_ms: Option<f64>,
}

impl FrameTiming {
    /// A timing record shared between the station's thread and its readers.
    pub fn shared() -> Arc<Mutex<FrameTiming>> {
        Arc::new(Mutex::new(FrameTiming::default()))
    }

    /// Records one frame `late_s` seconds behind its schedule, with the frame period on the wall
    /// clock.
    pub fn record(&mut self, late_s: f64, period_s: f64) {
        self.frames += 1;
        self.late_sum_s += late_s;
        self.late_max_s = self.late_max_s.max(late_s);
        self.period_s = period_s;
        if late_s > period_s {
            self.late_frames += 1;
        }
        if self.recent.len() < KEEP {
            self.recent.push(late_s);
        } else {
            self.recent[self.next] = late_s;
        }
        self.next = (self.next + 1) % KEEP;
    }

    /// Clears the record (e.g. at the start of a measurement window).
    pub fn reset(&mut self) {
        *self = FrameTiming::default();
    }

    /// The summary so far.
    pub fn summary(&self) -> TimingSummary {
        let mut v = self.recent.clone();
        v.sort_by(f64::total_cmp);
        let q = |p: f64| gonio_core::quantile::quantile_sorted(&v, p).map(|x| x * 1e3);
        let timed = self.frames > 0;
        TimingSummary {
            frames: self.frames,
            mean_late_ms: timed.then(|| self.late_sum_s / self.frames as f64 * 1e3),
            p50_late_ms: q(0.5),
            p99_late_ms: q(0.99),
            max_late_ms: timed.then_some(self.late_max_s * 1e3),
            late_frames: self.late_frames,
            period_ms: timed.then_some(self.period_s * 1e3),
        }
    }
}

/// Keeps the simulation in step with the wall clock, `speed_up` simulated seconds per second.
#[derive(Debug, Clone)]
pub struct Pace {
    speed_up: f64,
    anchor: Option<(Instant, f64)>,
    timing: Arc<Mutex<FrameTiming>>,
}

impl Pace {
    /// Real time times `speed_up` (1: real time), recording frame timing into `timing`.
    pub fn new(speed_up: f64, timing: Arc<Mutex<FrameTiming>>) -> Self {
        Pace {
            speed_up: if speed_up.is_finite() && speed_up > 0.0 {
                speed_up
            } else {
                1.0
            },
            anchor: None,
            timing,
        }
    }

    /// Ties simulated time `sim_s` to now (at a new part, whose clock starts afresh).
    pub fn rebase(&mut self, sim_s: f64) {
        self.anchor = Some((Instant::now(), sim_s));
    }

    fn due(&mut self, sim_s: f64) -> Instant {
        let (t0, s0) = *self.anchor.get_or_insert((Instant::now(), sim_s));
        let wait = gonio_core::bound::saturating_duration_s((sim_s - s0) / self.speed_up);
        // Beyond what an Instant holds (a speed-up near 0): a year, as good as never.
        t0.checked_add(wait)
            .unwrap_or_else(|| t0 + Duration::from_secs(365 * 86_400))
    }

    /// Waits until the wall clock reaches simulated time `sim_s`.
    pub fn wait_until(&mut self, sim_s: f64) {
        let due = self.due(sim_s);
        let now = Instant::now();
        if due > now {
            std::thread::sleep(due - now);
        }
    }

    /// A frame ends at simulated time `sim_s`, one frame period `period_sim_s` (simulated) after
    /// its slot opened: waits for it and records how late it came. A frame later than one period
    /// on the wall clock has missed its slot.
    pub fn frame_at(&mut self, sim_s: f64, period_sim_s: f64) {
        let due = self.due(sim_s);
        let now = Instant::now();
        if due > now {
            std::thread::sleep(due - now);
        }
        let late = Instant::now().saturating_duration_since(due).as_secs_f64();
        let period = (period_sim_s / self.speed_up).max(0.0);
        if let Ok(mut t) = self.timing.lock() {
            t.record(late, period);
        }
    }
}
