//! Frames in: the [`FrameSource`] trait that image files, raw standard input, the renderer and a
//! camera's SDK implement; [`RawFrames`], raw 8-bit frames from any reader; and
//! [`SourceDetector`], the one path from a source to the detector's results (each frame's
//! window cut out by [`Optics::crop_window`], then [`Detector::detect`]), one frame at a time;
//! [`detect_in_order`] runs the same path on several threads for a recorded stream and hands
//! the results on in the stream's order.
//!
//! ```
//! use gonio_vision::{Optics, RawFrames, SourceDetector};
//! let optics = Optics { window_width_px: 96, window_height_px: 48, ..Optics::default() };
//! // Two frames of a dark 11 px ring at column 30, as a camera would stream them.
//! let mut frame = vec![200u8; 96 * 48];
//! for row in frame.chunks_mut(96) {
//!     for x in 25..=35 { row[x] = 60; }
//! }
//! let bytes = [frame.clone(), frame].concat();
//! let mut src = SourceDetector::new(RawFrames::new(&bytes[..], 96, 48), &optics).unwrap();
//! let first = src.detect_next().unwrap().unwrap();
//! assert_eq!(first.stamp.index, 0);
//! assert!((first.result.c_px.unwrap() - 30.0).abs() < 0.05);
//! assert!(src.detect_next().unwrap().is_some());
//! assert!(src.detect_next().unwrap().is_none()); // end of the stream
//! ```

use crate::pipeline::LowerHalf;
use crate::track::Tracker;
use crate::{Detector, FrameResult, Optics, VisionError};
use std::io::Read;
use thiserror::Error;

/// When and how a frame was taken, as far as its source knows.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct FrameStamp {
    /// 0-based index of the frame in its source.
    pub index: u64,
    /// Start of the exposure, s (on the source's clock).
    pub start_s: Option<f64>,
    /// Exposure time, s.
    pub exposure_s: Option<f64>,
    /// Table angle at mid-exposure, degrees.
    pub theta_deg: Option<f64>,
}

/// A frame's size and stamp (its pixels are in the caller's buffer).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FrameHeader {
    /// Width, px.
    pub width: usize,
    /// Height, px.
    pub height: usize,
    /// The stamp.
    pub stamp: FrameStamp,
}

/// Something that delivers 8-bit grey frames one after another: image files, raw frames on
/// standard input, the renderer, a camera. Frames may be of the optics' window or its sensor;
/// [`Optics::crop_window`] cuts the window out.
pub trait FrameSource {
    /// The source's error.
    type Error: std::error::Error + 'static;
    /// Reads the next frame into `pixels` (resized to width × height, row-major) and returns its
    /// size and stamp; `Ok(None)` after the last frame.
    ///
    /// # Errors
    /// Whatever keeps the source from delivering a whole frame (unreadable file, truncated
    /// stream, camera fault).
    fn next_frame(&mut self, pixels: &mut Vec<u8>) -> Result<Option<FrameHeader>, Self::Error>;
}

impl<T: FrameSource + ?Sized> FrameSource for &mut T {
    type Error = T::Error;
    fn next_frame(&mut self, pixels: &mut Vec<u8>) -> Result<Option<FrameHeader>, Self::Error> {
        (**self).next_frame(pixels)
    }
}

impl<T: FrameSource + ?Sized> FrameSource for Box<T> {
    type Error = T::Error;
    fn next_frame(&mut self, pixels: &mut Vec<u8>) -> Result<Option<FrameHeader>, Self::Error> {
        (**self).next_frame(pixels)
    }
}

/// An error reading raw frames.
#[derive(Debug, Error)]
#[non_exhaustive]
pub enum RawFramesError {
    /// The reader failed.
    #[error("cannot read frame {frame}: {source}")]
    Io {
        /// 0-based index of the frame being read.
        frame: u64,
        /// The reader's error.
        source: std::io::Error,
    },
    /// The stream ended inside a frame.
    #[error(
        "truncated frame: {frames} whole {width}x{height} frames read, then {got} of {expected} bytes"
    )]
    Truncated {
        /// Whole frames read before.
        frames: u64,
        /// Frame width, px.
        width: usize,
        /// Frame height, px.
        height: usize,
        /// Bytes of the last, partial frame.
        got: usize,
        /// Bytes of a whole frame.
        expected: usize,
    },
}

/// Raw 8-bit frames of a fixed size, back to back, from any reader (standard input from
/// `ffmpeg … -f rawvideo -pix_fmt gray -` or a camera SDK's pipe). Stamps carry the index only.
#[derive(Debug)]
pub struct RawFrames<R> {
    reader: R,
    width: usize,
    height: usize,
    index: u64,
}

impl<R: Read> RawFrames<R> {
    /// Frames of `width` × `height` bytes from `reader`.
    pub fn new(reader: R, width: usize, height: usize) -> Self {
        RawFrames {
            reader,
            width,
            height,
            index: 0,
        }
    }
}

impl<R: Read> FrameSource for RawFrames<R> {
    type Error = RawFramesError;
    fn next_frame(&mut self, pixels: &mut Vec<u8>) -> Result<Option<FrameHeader>, RawFramesError> {
        let n = self.width * self.height;
        pixels.resize(n, 0);
        let mut got = 0;
        while got < n {
            match self.reader.read(&mut pixels[got..]) {
                Ok(0) => break,
                Ok(m) => got += m,
                Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
                Err(e) => {
                    return Err(RawFramesError::Io {
                        frame: self.index,
                        source: e,
                    });
                }
            }
        }
        if got == 0 {
            return Ok(None);
        }
        if got < n {
            return Err(RawFramesError::Truncated {
                frames: self.index,
                width: self.width,
                height: self.height,
                got,
                expected: n,
            });
        }
        let stamp = FrameStamp {
            index: self.index,
            ..FrameStamp::default()
        };
        self.index += 1;
        Ok(Some(FrameHeader {
            width: self.width,
            height: self.height,
            stamp,
        }))
    }
}

/// An error on the path from a source to a result: the source's, or the frame's (exactly these
/// two, so callers can take each apart).
#[derive(Debug, Error)]
pub enum SourceError<E: std::error::Error + 'static> {
    /// The source could not deliver a frame.
    #[error(transparent)]
    Source(E),
    /// A frame could not be detected on (wrong size).
    #[error("frame {index}: {error}")]
    Frame {
        /// 0-based index of the frame.
        index: u64,
        /// Why.
        error: VisionError,
    },
}

/// One frame's stamp and the detector's result for it.
#[derive(Debug, Clone, PartialEq)]
pub struct Detection {
    /// The frame's stamp, from its source.
    pub stamp: FrameStamp,
    /// The detector's result.
    pub result: FrameResult,
}

/// A source, the optics' window cut and the detector: every frame of the source, detected.
/// Buffers are allocated once and reused.
#[derive(Debug)]
pub struct SourceDetector<S> {
    source: S,
    optics: Optics,
    detector: Detector,
    raw: Vec<u8>,
    scratch: Vec<u8>,
    /// The second thread's share of each frame, when frames are split ([`Detector::detect_split`]).
    lower: Option<LowerHalf>,
    /// The tracked detector's state, when frames are tracked ([`SourceDetector::track_frames`]).
    tracker: Option<Tracker>,
    /// Where the window of the frame last detected is: `Some(true)` cut into `scratch`,
    /// `Some(false)` the whole of `raw`, `None` no frame detected since the last read.
    window_in_scratch: Option<bool>,
}

impl<S: FrameSource> SourceDetector<S> {
    /// A detector for the optics over `source`.
    ///
    /// # Errors
    /// [`VisionError::Optics`] if the optics are invalid.
    pub fn new(source: S, optics: &Optics) -> Result<Self, VisionError> {
        let detector = Detector::new(optics)?;
        let n = detector.params().width * detector.params().height;
        Ok(SourceDetector {
            source,
            optics: optics.clone(),
            detector,
            raw: Vec::with_capacity(n),
            scratch: Vec::with_capacity(n),
            lower: None,
            tracker: None,
            window_in_scratch: None,
        })
    }

    /// Measures each frame in a band of columns around the ring's predicted column when the
    /// band can vouch for it, else whole ([`Tracker`]: for frames that come in order, as from a
    /// camera), or, `false` (the default), every frame whole.
    pub fn track_frames(&mut self, on: bool) {
        self.tracker = on.then(|| Tracker::from_params(self.detector.params().clone()));
    }

    /// The tracked detector's state and counts, when frames are tracked.
    pub fn tracker(&self) -> Option<&Tracker> {
        self.tracker.as_ref()
    }

    /// Detects each frame on two threads ([`Detector::detect_split`]: the same results, in
    /// about three quarters of the time when the second thread wakes at once) or, `false`
    /// (the default), on the calling thread alone.
    pub fn split_frames(&mut self, on: bool) {
        self.lower = on.then(|| self.detector.lower_half());
    }

    /// Whether frames are detected on two threads ([`SourceDetector::split_frames`] on and
    /// the window tall enough: [`Detector::seam_row`]).
    pub fn splits_frames(&self) -> bool {
        self.lower.is_some() && self.detector.seam_row().is_some()
    }

    /// Reads, crops and detects the next frame; `Ok(None)` after the last.
    ///
    /// # Errors
    /// [`SourceError::Source`] from the source, [`SourceError::Frame`] for a frame that is
    /// neither the window nor the sensor in size.
    pub fn detect_next(&mut self) -> Result<Option<Detection>, SourceError<S::Error>> {
        match self.read_next()? {
            Some(hdr) => self.detect_read(&hdr).map(Some),
            None => Ok(None),
        }
    }

    /// The first half of [`SourceDetector::detect_next`]: reads the next frame into the
    /// detector's buffer and returns its header (`Ok(None)` after the last), so that a caller
    /// can time the detection alone.
    ///
    /// # Errors
    /// [`SourceError::Source`] from the source.
    pub fn read_next(&mut self) -> Result<Option<FrameHeader>, SourceError<S::Error>> {
        self.window_in_scratch = None;
        self.source
            .next_frame(&mut self.raw)
            .map_err(SourceError::Source)
    }

    /// The second half of [`SourceDetector::detect_next`]: crops and detects the frame last
    /// read by [`SourceDetector::read_next`] (`hdr` is what it returned).
    ///
    /// # Errors
    /// [`SourceError::Frame`] for a frame that is neither the window nor the sensor in size.
    pub fn detect_read(&mut self, hdr: &FrameHeader) -> Result<Detection, SourceError<S::Error>> {
        let result = detect_frame(
            &self.optics,
            &mut self.detector,
            self.lower.as_mut(),
            self.tracker.as_mut(),
            hdr,
            &self.raw,
            &mut self.scratch,
        )?;
        let window = (
            self.optics.window_width_px as usize,
            self.optics.window_height_px as usize,
        );
        self.window_in_scratch = Some((hdr.width, hdr.height) != window);
        Ok(Detection {
            stamp: hdr.stamp,
            result,
        })
    }

    /// The window of the frame last detected, as the detector saw it: 8-bit grey pixels,
    /// row-major, the optics' window in size (`window_width_px` × `window_height_px`), borrowed
    /// from the detector's buffers (no copy). `None` before the first detection, after a read
    /// that was not detected, or after a frame that could not be.
    pub fn window(&self) -> Option<&[u8]> {
        match self.window_in_scratch? {
            true => Some(&self.scratch),
            false => Some(&self.raw),
        }
    }

    /// The detector (parameters, stage dumps of the last frame).
    pub fn detector(&self) -> &Detector {
        &self.detector
    }

    /// The detector, to switch stage dumps on or off.
    pub fn detector_mut(&mut self) -> &mut Detector {
        &mut self.detector
    }

    /// The source.
    pub fn source(&self) -> &S {
        &self.source
    }

    /// The source, mutably.
    pub fn source_mut(&mut self) -> &mut S {
        &mut self.source
    }

    /// The optics.
    pub fn optics(&self) -> &Optics {
        &self.optics
    }
}

/// One frame through the path: its window cut out, then detected.
fn detect_frame<E: std::error::Error + 'static>(
    optics: &Optics,
    detector: &mut Detector,
    lower: Option<&mut LowerHalf>,
    tracker: Option<&mut Tracker>,
    hdr: &FrameHeader,
    raw: &[u8],
    scratch: &mut Vec<u8>,
) -> Result<FrameResult, SourceError<E>> {
    let index = hdr.stamp.index;
    let frame = optics
        .crop_window(hdr.width, hdr.height, raw, scratch)
        .map_err(|error| SourceError::Frame { index, error })?;
    match (tracker, lower) {
        (Some(tracker), lower) => tracker.detect(frame, index, detector, lower),
        (None, Some(lower)) => detector.detect_split(frame, lower),
        (None, None) => detector.detect(frame),
    }
    .map_err(|error| SourceError::Frame { index, error })
}

/// The source as the workers share it: who reads next, and whether reading has stopped.
struct Reader<S> {
    source: S,
    /// Frames read so far (the next frame's sequence number).
    read: u64,
    /// Frames handed to the sink so far.
    emitted: u64,
    /// No more reads: the source ended or failed, or the sink stopped the run.
    stopped: bool,
}

/// A worker's message to the calling thread (one per frame, moved once: the size difference of
/// the variants costs nothing worth a box).
#[allow(clippy::large_enum_variant)]
enum Done<E: std::error::Error + 'static> {
    /// Frame `seq` detected (or refused).
    Frame {
        seq: u64,
        stamp: FrameStamp,
        result: Result<FrameResult, SourceError<E>>,
    },
    /// The source ended after `seq` frames, or failed reading frame `seq`.
    End { seq: u64, error: Option<E> },
}

/// Detects every frame of `source` on `threads` worker threads (each with its own detector) and
/// hands each frame's outcome to `sink` in the source's order, with the source (to name a frame's
/// file, say). Each worker reads its next frame itself (the source behind a lock, frames numbered
/// in the order read) and detects it on the same core, so the frame is still in that core's cache
/// when the detector reads it and no buffer goes from thread to thread; at most one frame per
/// worker is being detected, and reading waits while two frames per worker are read and not yet
/// handed on (a slow sink holds the reading back). A frame the detector refuses (wrong size)
/// reaches `sink` as [`SourceError::Frame`] in its place; a failing source as [`SourceError::Source`] after every
/// frame before it, and nothing is read after it. Results equal [`SourceDetector`]'s bit for bit:
/// every frame goes through the same detector code from a fresh frame start.
///
/// For a live camera, where each result is wanted as soon as its frame is in, use
/// [`SourceDetector`] (one frame in flight).
///
/// # Errors
/// [`VisionError::Optics`] for invalid optics (nothing is read); the first error `sink` returns
/// (reading stops, the frames in flight are finished and dropped).
///
/// ```
/// use gonio_vision::{Optics, RawFrames, detect_in_order};
/// let optics = Optics { window_width_px: 96, window_height_px: 48, ..Optics::default() };
/// let mut frame = vec![200u8; 96 * 48];
/// for row in frame.chunks_mut(96) {
///     for x in 25..=35 { row[x] = 60; }
/// }
/// let bytes = [frame.clone(), frame.clone(), frame].concat();
/// let mut seen = Vec::new();
/// detect_in_order(RawFrames::new(&bytes[..], 96, 48), &optics, 2, |_, d| {
///     seen.push(d.unwrap().stamp.index);
///     Ok::<(), std::convert::Infallible>(())
/// })
/// .unwrap();
/// assert_eq!(seen, [0, 1, 2]); // in the stream's order
/// ```
pub fn detect_in_order<S, F, E>(
    source: S,
    optics: &Optics,
    threads: usize,
    mut sink: F,
) -> Result<(), DetectInOrderError<E>>
where
    S: FrameSource + Send,
    S::Error: Send,
    F: FnMut(&S, Result<Detection, SourceError<S::Error>>) -> Result<(), E>,
{
    use std::collections::BTreeMap;
    use std::sync::{Condvar, Mutex, PoisonError, mpsc};
    let threads = threads.max(1);
    let mut detectors = (0..threads)
        .map(|_| Detector::new(optics))
        .collect::<Result<Vec<_>, _>>()
        .map_err(DetectInOrderError::Vision)?;
    let n = detectors[0].params().width * detectors[0].params().height;
    let reader = Mutex::new(Reader {
        source,
        read: 0,
        emitted: 0,
        stopped: false,
    });
    // Signalled when frames are handed on or the run stops.
    let room = Condvar::new();
    let ahead = 2 * threads as u64;
    // A worker that panicked holding the lock leaves the source as it was: the panic itself
    // reaches the caller when the scope ends.
    let lock = || reader.lock().unwrap_or_else(PoisonError::into_inner);
    let (done_tx, done_rx) = mpsc::channel::<Done<S::Error>>();
    std::thread::scope(|scope| {
        for det in detectors.iter_mut() {
            let (lock, room, done_tx) = (&lock, &room, done_tx.clone());
            scope.spawn(move || {
                let (mut raw, mut scratch) = (Vec::with_capacity(n), Vec::new());
                loop {
                    let (seq, hdr) = {
                        let mut r = lock();
                        while !r.stopped && r.read >= r.emitted + ahead {
                            r = room.wait(r).unwrap_or_else(PoisonError::into_inner);
                        }
                        if r.stopped {
                            return;
                        }
                        let seq = r.read;
                        match r.source.next_frame(&mut raw) {
                            Ok(Some(hdr)) => {
                                r.read += 1;
                                (seq, hdr)
                            }
                            end => {
                                r.stopped = true;
                                let error = end.err();
                                let _ = done_tx.send(Done::End { seq, error });
                                return;
                            }
                        }
                    };
                    let result = detect_frame(optics, det, None, None, &hdr, &raw, &mut scratch);
                    let done = Done::Frame {
                        seq,
                        stamp: hdr.stamp,
                        result,
                    };
                    if done_tx.send(done).is_err() {
                        return;
                    }
                }
            });
        }
        drop(done_tx);
        let mut emitted = 0u64;
        let mut end: Option<(u64, Option<S::Error>)> = None;
        let mut waiting = BTreeMap::new();
        let outcome = loop {
            if let Some((seq, error)) = &mut end
                && *seq == emitted
            {
                break match error.take() {
                    Some(e) => sink(&lock().source, Err(SourceError::Source(e))),
                    None => Ok(()),
                };
            }
            // Every worker gone without an end: only after a panic, which the scope passes on.
            let Ok(done) = done_rx.recv() else {
                break Ok(());
            };
            match done {
                Done::Frame { seq, stamp, result } => {
                    waiting.insert(seq, (stamp, result));
                }
                Done::End { seq, error } => end = Some((seq, error)),
            }
            let mut failed = None;
            while let Some((stamp, result)) = waiting.remove(&emitted) {
                emitted += 1;
                let item = result.map(|result| Detection { stamp, result });
                let mut r = lock();
                let handed = sink(&r.source, item);
                r.emitted = emitted;
                drop(r);
                room.notify_all();
                if let Err(e) = handed {
                    failed = Some(e);
                    break;
                }
            }
            if let Some(e) = failed {
                break Err(e);
            }
        };
        // The workers stop at their next read.
        lock().stopped = true;
        room.notify_all();
        outcome.map_err(DetectInOrderError::Sink)
    })
}

/// An error of [`detect_in_order`].
#[derive(Debug, Error)]
#[non_exhaustive]
pub enum DetectInOrderError<E> {
    /// The optics are invalid.
    #[error(transparent)]
    Vision(VisionError),
    /// The sink stopped the run.
    #[error("{0}")]
    Sink(E),
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Frames of a dark ring whose column moves by one pixel a frame; fails reading frame
    /// `fail_at` (if any) and counts the reads it was asked for.
    struct Moving {
        next: u64,
        count: u64,
        fail_at: Option<u64>,
        asked: u64,
    }

    #[derive(Debug, Error)]
    #[error("camera fault at frame {0}")]
    struct Fault(u64);

    impl FrameSource for Moving {
        type Error = Fault;
        fn next_frame(&mut self, pixels: &mut Vec<u8>) -> Result<Option<FrameHeader>, Fault> {
            self.asked += 1;
            if Some(self.next) == self.fail_at {
                return Err(Fault(self.next));
            }
            if self.next == self.count {
                return Ok(None);
            }
            let c = 20 + (self.next % 50) as usize;
            pixels.clear();
            for _ in 0..48 {
                pixels.extend((0..96usize).map(|x| if x.abs_diff(c) <= 5 { 60 } else { 200 }));
            }
            let stamp = FrameStamp {
                index: self.next,
                ..FrameStamp::default()
            };
            self.next += 1;
            Ok(Some(FrameHeader {
                width: 96,
                height: 48,
                stamp,
            }))
        }
    }

    fn optics() -> Optics {
        Optics {
            window_width_px: 96,
            window_height_px: 48,
            ..Optics::default()
        }
    }

    fn source(count: u64, fail_at: Option<u64>) -> Moving {
        Moving {
            next: 0,
            count,
            fail_at,
            asked: 0,
        }
    }

    /// One frame of `w` × `h` pixels numbered by their position, then the end.
    struct Once(Option<(usize, usize)>);

    impl FrameSource for Once {
        type Error = Fault;
        fn next_frame(&mut self, pixels: &mut Vec<u8>) -> Result<Option<FrameHeader>, Fault> {
            let Some((w, h)) = self.0.take() else {
                return Ok(None);
            };
            pixels.clear();
            pixels.extend((0..w * h).map(|i| (i % 251) as u8));
            Ok(Some(FrameHeader {
                width: w,
                height: h,
                stamp: FrameStamp::default(),
            }))
        }
    }

    #[test]
    fn the_window_is_the_last_detected_frame_as_the_detector_saw_it() {
        // A frame the window's size: the window is the frame.
        let mut det = SourceDetector::new(source(2, None), &optics()).unwrap();
        assert!(det.window().is_none());
        det.detect_next().unwrap().unwrap();
        let w = det.window().expect("a window").to_vec();
        assert_eq!(w.len(), 96 * 48);
        // Frame 0: the ring's 11 dark columns around column 20.
        assert_eq!(
            w[14..27],
            [200, 60, 60, 60, 60, 60, 60, 60, 60, 60, 60, 60, 200]
        );
        det.read_next().unwrap().unwrap();
        assert!(det.window().is_none(), "read, not detected");
        // A sensor-sized frame: the window cut out of its middle.
        let o = Optics {
            sensor_width_px: 100,
            sensor_height_px: 52,
            ..optics()
        };
        let mut det = SourceDetector::new(Once(Some((100, 52))), &o).unwrap();
        det.detect_next().unwrap().unwrap();
        let w = det.window().expect("a window");
        assert_eq!(w.len(), 96 * 48);
        assert_eq!(w[0], 202, "row 2, column 2 of the sensor");
        assert!(det.detect_next().unwrap().is_none());
        assert!(det.window().is_none());
    }

    #[test]
    fn results_come_in_order_and_equal_one_frame_at_a_time() {
        let mut one = SourceDetector::new(source(40, None), &optics()).unwrap();
        let mut expected = Vec::new();
        while let Some(d) = one.detect_next().unwrap() {
            expected.push(d);
        }
        assert_eq!(expected.len(), 40);
        for threads in [1, 2, 3, 7] {
            let mut got = Vec::new();
            detect_in_order(source(40, None), &optics(), threads, |_, d| {
                got.push(d.unwrap());
                Ok::<(), Fault>(())
            })
            .unwrap();
            assert_eq!(got, expected, "{threads} threads");
        }
    }

    #[test]
    fn a_failing_source_ends_the_run_after_every_frame_before_it() {
        for threads in [1, 2, 3] {
            let mut seen = Vec::new();
            let mut error = None;
            detect_in_order(source(40, Some(13)), &optics(), threads, |s, d| {
                match d {
                    Ok(d) => seen.push(d.stamp.index),
                    Err(SourceError::Source(e)) => error = Some((e.0, s.asked)),
                    Err(e) => panic!("{e}"),
                }
                Ok::<(), Fault>(())
            })
            .unwrap();
            assert_eq!(seen, (0..13).collect::<Vec<_>>(), "{threads} threads");
            // The failed read is the last one: 13 frames and the fault.
            assert_eq!(error, Some((13, 14)), "{threads} threads");
        }
    }

    #[test]
    fn a_failing_sink_stops_the_reading() {
        for threads in [1, 2, 3] {
            let mut seen = 0;
            let mut src = source(1000, None);
            let err = detect_in_order(&mut src, &optics(), threads, |_, _| {
                seen += 1;
                if seen == 5 { Err(Fault(5)) } else { Ok(()) }
            })
            .unwrap_err();
            assert!(matches!(err, DetectInOrderError::Sink(Fault(5))));
            assert_eq!(seen, 5);
            // At most two frames per worker beyond the four handed on before the failure.
            assert!(src.asked <= 4 + 2 * threads as u64, "{} reads", src.asked);
        }
    }
}
