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
        })
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
            hdr,
            &self.raw,
            &mut self.scratch,
        )?;
        Ok(Detection {
            stamp: hdr.stamp,
            result,
        })
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
    hdr: &FrameHeader,
    raw: &[u8],
    scratch: &mut Vec<u8>,
) -> Result<FrameResult, SourceError<E>> {
    let index = hdr.stamp.index;
    let frame = optics
        .crop_window(hdr.width, hdr.height, raw, scratch)
        .map_err(|error| SourceError::Frame { index, error })?;
    detector
        .detect(frame)
        .map_err(|error| SourceError::Frame { index, error })
}

/// A frame read and waiting for a worker, or a worker's answer.
struct Job {
    seq: u64,
    hdr: FrameHeader,
    raw: Vec<u8>,
}

struct Done<E: std::error::Error + 'static> {
    seq: u64,
    stamp: FrameStamp,
    result: Result<FrameResult, SourceError<E>>,
    raw: Vec<u8>,
}

/// Detects every frame of `source` on `threads` worker threads (each with its own detector) and
/// hands each frame's outcome to `sink` in the source's order, with the source (to name a frame's
/// file, say). The calling thread reads the frames, so reading overlaps detecting; at most two
/// frames per worker are in flight. A frame the detector refuses (wrong size) reaches `sink` as
/// [`SourceError::Frame`] in its place; a failing source as [`SourceError::Source`] after every
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
    mut source: S,
    optics: &Optics,
    threads: usize,
    mut sink: F,
) -> Result<(), DetectInOrderError<E>>
where
    S: FrameSource,
    S::Error: Send,
    F: FnMut(&S, Result<Detection, SourceError<S::Error>>) -> Result<(), E>,
{
    use std::collections::BTreeMap;
    use std::sync::{Mutex, mpsc};
    let threads = threads.max(1);
    let mut detectors = (0..threads)
        .map(|_| Detector::new(optics))
        .collect::<Result<Vec<_>, _>>()
        .map_err(DetectInOrderError::Vision)?;
    let (job_tx, job_rx) = mpsc::channel::<Job>();
    let job_rx = Mutex::new(job_rx);
    let (done_tx, done_rx) = mpsc::channel::<Done<S::Error>>();
    std::thread::scope(|scope| {
        for det in detectors.iter_mut() {
            let (job_rx, done_tx) = (&job_rx, done_tx.clone());
            scope.spawn(move || {
                let mut scratch = Vec::new();
                loop {
                    // The lock is held only while taking a job.
                    let job = match job_rx.lock() {
                        Ok(rx) => rx.recv(),
                        Err(_) => return,
                    };
                    let Ok(job) = job else { return };
                    let result = detect_frame(optics, det, &job.hdr, &job.raw, &mut scratch);
                    let done = Done {
                        seq: job.seq,
                        stamp: job.hdr.stamp,
                        result,
                        raw: job.raw,
                    };
                    if done_tx.send(done).is_err() {
                        return;
                    }
                }
            });
        }
        drop(done_tx);
        let ahead = 2 * threads;
        let (mut read, mut emitted, mut in_flight) = (0u64, 0u64, 0usize);
        let mut free: Vec<Vec<u8>> = Vec::new();
        let mut waiting: BTreeMap<u64, Done<S::Error>> = BTreeMap::new();
        let mut source_error = None;
        let mut eof = false;
        let outcome = loop {
            while !eof && in_flight < ahead {
                let mut raw = free.pop().unwrap_or_default();
                match source.next_frame(&mut raw) {
                    Ok(Some(hdr)) => {
                        let job = Job {
                            seq: read,
                            hdr,
                            raw,
                        };
                        if job_tx.send(job).is_err() {
                            eof = true;
                            break;
                        }
                        read += 1;
                        in_flight += 1;
                    }
                    Ok(None) => eof = true,
                    Err(e) => {
                        eof = true;
                        source_error = Some(e);
                    }
                }
            }
            if in_flight == 0 {
                break match source_error.take() {
                    Some(e) => sink(&source, Err(SourceError::Source(e))),
                    None => Ok(()),
                };
            }
            let Ok(done) = done_rx.recv() else {
                break Ok(());
            };
            in_flight -= 1;
            waiting.insert(done.seq, done);
            let mut failed = None;
            while let Some(done) = waiting.remove(&emitted) {
                emitted += 1;
                let item = done.result.map(|result| Detection {
                    stamp: done.stamp,
                    result,
                });
                free.push(done.raw);
                if let Err(e) = sink(&source, item) {
                    failed = Some(e);
                    break;
                }
            }
            if let Some(e) = failed {
                break Err(e);
            }
        };
        // Closing the job channel ends the workers.
        drop(job_tx);
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
