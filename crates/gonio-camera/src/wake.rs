//! Waking Aravis's fake camera from its stalled sleep (the `fake` module, feature `fake`).
//!
//! Aravis 0.8's GigE Vision fake camera computes its poll timeout as an unsigned difference
//! (`next frame − now`, µs, then ms): when its thread gets there after the next frame's time (a
//! loaded machine, or sending a frame ending just before the next frame's time) the difference
//! wraps, the timeout is clamped to its 100 ms maximum and ten frames are not sent. Any control
//! packet ends that poll, and the thread then sends the late frame at once. The [`Watcher`]
//! here is a thread that sends the camera one GVCP register read (the version register, 0x0000:
//! read-only) when no frame was filled [`STALL_PERIODS`] frame periods after the last one, at
//! most once a period, and only while frames are being filled (a client acquiring). A read sent
//! when the camera was merely skipping a tick changes nothing: its thread polls on to its time.
//!
//! Written here (std's UDP socket, a thread; the read is [`crate::gvcp`]'s) because no crate
//! does this: it is a workaround of one library's bug. Times are ns since its [`Fills`] record was made. Errors: only starting the
//! thread and socket can fail (`std::io::Error`); a failed send is not counted and retried a
//! period later.

// Without `fake` nothing serves frames; the module stays compiled so its tests run in the
// default build.
#![cfg_attr(not(feature = "fake"), allow(dead_code))]

use crate::gvcp::read_version_packet;
use std::net::{SocketAddr, UdpSocket};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::time::{Duration, Instant};

/// A frame this many periods after the last one means the camera's thread sleeps past its
/// frame's time (a late frame is otherwise sent as soon as its thread runs).
pub(crate) const STALL_PERIODS: f64 = 1.5;
/// No frame filled for this long: no client acquires, nothing to wake, ns.
pub(crate) const IDLE_NS: u64 = 500_000_000;
/// The longest the watcher sleeps between looks (it stops this soon after it is told to), ns.
pub(crate) const LOOK_NS: u64 = 20_000_000;
/// The shortest sleep between looks, ns.
const MIN_SLEEP_NS: u64 = 100_000;

/// When frames were filled: written by the fill callback, read by the [`Watcher`].
#[derive(Debug)]
pub(crate) struct Fills {
    origin: Instant,
    /// When the last frame was filled (0: none yet).
    last_fill_ns: AtomicU64,
    /// The frame period (0: not known yet).
    period_ns: AtomicU64,
    /// Register reads sent to wake the camera.
    wakeups: AtomicU64,
    stop: AtomicBool,
}

impl Fills {
    /// No frame filled yet; its clock starts now.
    pub(crate) fn new() -> Self {
        Fills {
            origin: Instant::now(),
            last_fill_ns: AtomicU64::new(0),
            period_ns: AtomicU64::new(0),
            wakeups: AtomicU64::new(0),
            stop: AtomicBool::new(false),
        }
    }

    /// Now, ns since the record was made (never 0).
    pub(crate) fn now_ns(&self) -> u64 {
        (self.origin.elapsed().as_nanos() as u64).max(1)
    }

    /// Records a frame filled at `now_ns`; returns the interval since the previous one, ns.
    fn filled(&self, now_ns: u64) -> Option<u64> {
        let before = self.last_fill_ns.swap(now_ns, Ordering::AcqRel);
        (before > 0).then(|| now_ns.saturating_sub(before))
    }

    /// Sets the frame period the watcher expects, ns.
    pub(crate) fn set_period_ns(&self, period_ns: u64) {
        self.period_ns.store(period_ns, Ordering::Relaxed);
    }
}

/// The frame period as the fills show it, kept by the fill callback (its thread only): the
/// median of the last 15 intervals between fills (a late frame makes one interval longer and
/// the next shorter, a missed tick one a multiple; the median is neither).
#[derive(Debug, Default)]
pub(crate) struct Period {
    intervals: [u64; 15],
    seen: usize,
}

impl Period {
    /// A frame is being filled at `now_ns` ([`Fills::now_ns`]): records it in `fills`, with the
    /// period it shows.
    pub(crate) fn filled(&mut self, fills: &Fills, now_ns: u64) {
        let Some(interval) = fills.filled(now_ns) else {
            return;
        };
        let n = self.intervals.len();
        self.intervals[self.seen % n] = interval;
        self.seen += 1;
        let mut sorted = self.intervals;
        let known = &mut sorted[..self.seen.min(n)];
        known.sort_unstable();
        fills.set_period_ns(known[known.len() / 2]);
    }
}

/// What the watcher does next.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Step {
    /// Send one register read now, then look again after this many ns.
    Wake(u64),
    /// Look again after this many ns.
    Sleep(u64),
}

/// The watcher's decision at `now` (ns), the last frame filled at `last_fill` (0: none), the
/// frame period `period` (0: unknown), the last read sent at `last_wake` (0: none).
pub(crate) fn step(now: u64, last_fill: u64, period: u64, last_wake: u64) -> Step {
    if last_fill == 0 || period == 0 || now.saturating_sub(last_fill) >= IDLE_NS {
        return Step::Sleep(LOOK_NS);
    }
    let due = last_fill + (period as f64 * STALL_PERIODS) as u64;
    let since_wake = now.saturating_sub(last_wake);
    let sleep = if now < due {
        due - now
    } else if last_wake == 0 || since_wake >= period {
        return Step::Wake(period.clamp(MIN_SLEEP_NS, LOOK_NS));
    } else {
        period - since_wake
    };
    Step::Sleep(sleep.clamp(MIN_SLEEP_NS, LOOK_NS))
}

/// The thread that wakes a stalled fake camera (module docs); stopped and joined when dropped.
pub(crate) struct Watcher {
    fills: Arc<Fills>,
    thread: Option<std::thread::JoinHandle<()>>,
}

impl Watcher {
    /// Starts watching `fills`, sending reads to the camera's control port `camera` from a
    /// socket on the same address.
    pub(crate) fn start(fills: Arc<Fills>, camera: SocketAddr) -> std::io::Result<Watcher> {
        let socket = UdpSocket::bind((camera.ip(), 0))?;
        socket.connect(camera)?;
        socket.set_nonblocking(true)?;
        let p = fills.clone();
        let thread = std::thread::Builder::new()
            .name("gonio-fake-camera-watch".into())
            .spawn(move || watch(&p, &socket))?;
        Ok(Watcher {
            fills,
            thread: Some(thread),
        })
    }

    /// Register reads sent so far.
    pub(crate) fn wakeups(&self) -> u64 {
        self.fills.wakeups.load(Ordering::Relaxed)
    }
}

impl Drop for Watcher {
    fn drop(&mut self) {
        self.fills.stop.store(true, Ordering::Relaxed);
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

fn watch(fills: &Fills, socket: &UdpSocket) {
    let mut id: u16 = 0;
    let mut last_wake = 0u64;
    let mut reply = [0u8; 64];
    while !fills.stop.load(Ordering::Relaxed) {
        // The camera's acknowledgements: read and dropped.
        while socket.recv(&mut reply).is_ok() {}
        let now = fills.now_ns();
        let last_fill = fills.last_fill_ns.load(Ordering::Acquire);
        let period = fills.period_ns.load(Ordering::Relaxed);
        let sleep = match step(now, last_fill, period, last_wake) {
            Step::Wake(sleep) => {
                id = id.wrapping_add(1).max(1);
                if socket.send(&read_version_packet(id)).is_ok() {
                    fills.wakeups.fetch_add(1, Ordering::Relaxed);
                    last_wake = now;
                }
                sleep
            }
            Step::Sleep(sleep) => sleep,
        };
        std::thread::sleep(Duration::from_nanos(sleep));
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const MS: u64 = 1_000_000;

    #[test]
    fn the_watcher_wakes_only_a_stalled_camera_at_most_once_a_period() {
        // Nothing filled, or the period unknown: nothing to wake.
        assert_eq!(step(50 * MS, 0, 10 * MS, 0), Step::Sleep(LOOK_NS));
        assert_eq!(step(50 * MS, 40 * MS, 0, 0), Step::Sleep(LOOK_NS));
        // A frame 10 ms ago at 10 ms a frame: sleep until 1.5 periods after it.
        assert_eq!(step(110 * MS, 100 * MS, 10 * MS, 0), Step::Sleep(5 * MS));
        // 15 ms after the last frame: wake, then look again a period later.
        assert_eq!(step(115 * MS, 100 * MS, 10 * MS, 0), Step::Wake(10 * MS));
        // Woken 3 ms ago and still no frame: wait out the period before the next read.
        assert_eq!(
            step(118 * MS, 100 * MS, 10 * MS, 115 * MS),
            Step::Sleep(7 * MS)
        );
        assert_eq!(
            step(125 * MS, 100 * MS, 10 * MS, 115 * MS),
            Step::Wake(10 * MS)
        );
        // No frame for 0.5 s: the client stopped acquiring.
        assert_eq!(
            step(100 * MS + IDLE_NS, 100 * MS, 10 * MS, 590 * MS),
            Step::Sleep(LOOK_NS)
        );
        // A slow camera (1 frame/s): looks are still at most LOOK_NS apart.
        assert_eq!(step(100 * MS, 100 * MS, 1000 * MS, 0), Step::Sleep(LOOK_NS));
    }

    #[test]
    fn the_period_is_the_median_interval_late_frames_and_missed_ticks_aside() {
        let fills = Fills::new();
        let mut period = Period::default();
        let mut at = MS;
        period.filled(&fills, at);
        // 10 ms a frame, one frame 4 ms late (14 then 6 ms), one tick missed (20 ms).
        for dt in [10, 10, 14, 6, 10, 20, 10, 10, 10] {
            at += dt * MS;
            period.filled(&fills, at);
        }
        assert_eq!(fills.period_ns.load(Ordering::Relaxed), 10 * MS);
        assert_eq!(fills.last_fill_ns.load(Ordering::Relaxed), at);
    }

    /// A camera that stops being filled gets reads on its port until it has been idle 0.5 s,
    /// no faster than one a period; the watcher stops when dropped.
    #[test]
    fn a_stalled_camera_gets_reads_until_idle_and_the_watcher_stops() {
        let camera = UdpSocket::bind("127.0.0.1:0").unwrap();
        camera
            .set_read_timeout(Some(Duration::from_millis(50)))
            .unwrap();
        let fills = Arc::new(Fills::new());
        fills.set_period_ns(10 * MS);
        let watcher = Watcher::start(fills.clone(), camera.local_addr().unwrap()).unwrap();
        let stalled_at = fills.now_ns();
        fills.filled(stalled_at);
        let mut reads = 0u64;
        let mut buf = [0u8; 64];
        let until = Instant::now() + Duration::from_millis(1500);
        while Instant::now() < until {
            if let Ok((n, _)) = camera.recv_from(&mut buf) {
                assert_eq!(&buf[..n][..4], &[0x42, 0x00, 0x00, 0x80]);
                reads += 1;
            }
        }
        // Between 15 ms and 500 ms after the last fill, at most one read a period (10 ms):
        // at most 49; at least one.
        assert!(reads >= 1, "no read sent to a stalled camera");
        assert!(
            reads <= 49,
            "{reads} reads in 485 ms at one a period at most"
        );
        assert_eq!(watcher.wakeups(), reads);
        let t = Instant::now();
        drop(watcher);
        assert!(
            t.elapsed() < Duration::from_millis(500),
            "the watcher did not stop"
        );
    }
}
