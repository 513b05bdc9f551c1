//! The station's camera as the PLC triggers it: [`TriggeredCamera`] (frames in order, each with
//! the camera's frame number, = the PLC's trigger count) and [`DetectorTriggered`], any
//! `FrameSource` (a GigE Vision camera) through the streaming detector, optionally showing every
//! frame to a [`FrameTap`]. Times in s; errors: [`DetectorTriggeredError`].

use gonio_station::hal::{CameraFrame, DeviceError, DeviceErrorKind};
use gonio_vision::{FrameResult, FrameSource, Optics, SourceDetector, SourceError, VisionError};
use std::time::Duration;

/// One frame of a triggered camera, through the detector.
#[derive(Debug, Clone, PartialEq)]
pub struct TriggeredFrame {
    /// The camera's frame number (= the PLC's trigger count).
    pub frame_id: u64,
    /// The camera's timestamp of the exposure start, s, on the PLC's clock when the clocks are
    /// synchronised (`None`: unknown).
    pub timestamp_s: Option<f64>,
    /// The detector's result; `start_s` is replaced by the paired PLC time.
    pub frame: CameraFrame,
}

/// A camera triggered by the PLC: frames in order, each with its number.
pub trait TriggeredCamera {
    /// The camera's error.
    type Error: DeviceError + std::fmt::Display;
    /// The next frame, waiting at most `timeout`; `Ok(None)` when none came in time.
    ///
    /// # Errors
    /// The camera failed.
    fn next_frame(&mut self, timeout: Duration) -> Result<Option<TriggeredFrame>, Self::Error>;
}

/// A `FrameSource` (e.g. a GigE Vision camera) through the streaming detector: frame numbers
/// from the source's stamps; optionally every frame shown to a [`FrameTap`].
pub struct DetectorTriggered<S> {
    det: SourceDetector<S>,
    tap: Option<FrameTap>,
}

impl<S: std::fmt::Debug> std::fmt::Debug for DetectorTriggered<S> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("DetectorTriggered")
            .field("det", &self.det)
            .field("tap", &self.tap.is_some())
            .finish()
    }
}

/// One frame as a [`FrameTap`] sees it: the camera window's pixels as the detector saw them
/// (borrowed from its buffers, no copy) and what it found.
#[derive(Debug, Clone, Copy)]
pub struct TappedFrame<'a> {
    /// The camera's frame number (= the PLC's trigger count).
    pub frame_id: u64,
    /// Width, px (the optics' window).
    pub width: usize,
    /// Height, px.
    pub height: usize,
    /// 8-bit grey pixels, row-major, `width` × `height`.
    pub pixels: &'a [u8],
    /// The detector's result (edge columns and `c_px` in the window's pixels).
    pub result: &'a FrameResult,
}

/// Told every frame a [`DetectorTriggered`] detects, paired or not, as it is detected (e.g. the
/// live view's thumbnail). It runs on the camera's thread between frames: it should return at
/// once for most frames (rate-limit before any work).
pub type FrameTap = Box<dyn FnMut(&TappedFrame<'_>) + Send>;

impl<S: FrameSource> DetectorTriggered<S> {
    /// The source through the detector for `optics`.
    ///
    /// # Errors
    /// Invalid optics.
    pub fn new(source: S, optics: &Optics) -> Result<Self, VisionError> {
        Ok(DetectorTriggered {
            det: SourceDetector::new(source, optics)?,
            tap: None,
        })
    }

    /// Shows every frame detected from now on to `tap` (replacing any tap before).
    #[must_use]
    pub fn with_tap(mut self, tap: FrameTap) -> Self {
        self.tap = Some(tap);
        self
    }

    /// The source.
    pub fn source_mut(&mut self) -> &mut S {
        self.det.source_mut()
    }
}

/// An error of [`DetectorTriggered`].
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum DetectorTriggeredError<E: std::error::Error + 'static> {
    /// The source failed.
    #[error(transparent)]
    Source(E),
    /// A frame could not be run through the detector.
    #[error("frame {index}: {error}")]
    Frame {
        /// The frame.
        index: u64,
        /// Why.
        error: VisionError,
    },
}

impl<E: std::error::Error + DeviceError + 'static> DeviceError for DetectorTriggeredError<E> {
    fn kind(&self) -> DeviceErrorKind {
        match self {
            DetectorTriggeredError::Source(e) => e.kind(),
            DetectorTriggeredError::Frame { .. } => DeviceErrorKind::Fault,
        }
    }
}

impl<S> TriggeredCamera for DetectorTriggered<S>
where
    S: FrameSource,
    S::Error: DeviceError,
{
    type Error = DetectorTriggeredError<S::Error>;

    fn next_frame(&mut self, _timeout: Duration) -> Result<Option<TriggeredFrame>, Self::Error> {
        // The source's own timeout bounds the wait (a GigE source ends with an error).
        let d = match self.det.detect_next() {
            Ok(Some(d)) => d,
            Ok(None) => return Ok(None),
            Err(SourceError::Source(e)) => return Err(DetectorTriggeredError::Source(e)),
            Err(SourceError::Frame { index, error }) => {
                return Err(DetectorTriggeredError::Frame { index, error });
            }
        };
        if let (Some(tap), Some(pixels)) = (self.tap.as_mut(), self.det.window()) {
            let optics = self.det.optics();
            tap(&TappedFrame {
                frame_id: d.stamp.index,
                width: optics.window_width_px as usize,
                height: optics.window_height_px as usize,
                pixels,
                result: &d.result,
            });
        }
        let r = d.result;
        Ok(Some(TriggeredFrame {
            frame_id: d.stamp.index,
            timestamp_s: d.stamp.start_s,
            frame: CameraFrame {
                start_s: d.stamp.start_s.unwrap_or(f64::NAN),
                exposure_s: d.stamp.exposure_s.unwrap_or(0.0),
                c_px: r.c_px.filter(|_| r.valid),
                invalid_reason: if r.valid { None } else { r.reason },
                focus_measure: r.focus,
            },
        }))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use gonio_vision::{FrameHeader, FrameStamp};
    use std::sync::{Arc, Mutex};

    /// Three 96 × 48 frames of a dark ring around column 40, numbered 10, 11, 12.
    #[derive(Debug)]
    struct Ring(u64);

    #[derive(Debug, thiserror::Error)]
    #[error("never")]
    struct Never;

    impl DeviceError for Never {
        fn kind(&self) -> DeviceErrorKind {
            DeviceErrorKind::Other
        }
    }

    impl FrameSource for Ring {
        type Error = Never;
        fn next_frame(&mut self, px: &mut Vec<u8>) -> Result<Option<FrameHeader>, Never> {
            if self.0 == 3 {
                return Ok(None);
            }
            px.clear();
            for _ in 0..48 {
                px.extend((0..96usize).map(|x| if x.abs_diff(40) <= 5 { 60 } else { 200 }));
            }
            self.0 += 1;
            Ok(Some(FrameHeader {
                width: 96,
                height: 48,
                stamp: FrameStamp {
                    index: 9 + self.0,
                    ..FrameStamp::default()
                },
            }))
        }
    }

    #[test]
    fn a_tap_sees_every_frame_with_its_window_and_the_detectors_result() {
        let optics = Optics {
            window_width_px: 96,
            window_height_px: 48,
            ..Optics::default()
        };
        let seen = Arc::new(Mutex::new(Vec::new()));
        let s = seen.clone();
        let mut cam = DetectorTriggered::new(Ring(0), &optics)
            .unwrap()
            .with_tap(Box::new(move |f: &TappedFrame<'_>| {
                let c = f.result.c_px.filter(|_| f.result.valid);
                s.lock().unwrap().push((
                    f.frame_id,
                    f.width,
                    f.height,
                    f.pixels[40],
                    f.pixels.len(),
                    c,
                ));
            }));
        let mut frames = Vec::new();
        while let Some(f) = cam.next_frame(Duration::from_secs(1)).unwrap() {
            frames.push((f.frame_id, f.frame.c_px));
        }
        let seen = seen.lock().unwrap();
        assert_eq!(seen.len(), 3);
        for ((id, w, h, px, n, c), (fid, fc)) in seen.iter().zip(&frames) {
            assert_eq!((*id, *w, *h, *px, *n), (*fid, 96, 48, 60, 96 * 48));
            assert_eq!(c, fc);
        }
        assert_eq!(frames.iter().map(|f| f.0).collect::<Vec<_>>(), [10, 11, 12]);
        assert!(format!("{cam:?}").contains("tap: true"));
    }
}
