//! The station's camera as the PLC triggers it: [`TriggeredCamera`] (frames in order, each with
//! the camera's frame number, = the PLC's trigger count, and what the detector read in it) and
//! [`DetectorTriggered`], any `FrameSource` (a GigE Vision camera) through the streaming
//! detector, which also shows the station the last frame as it saw it (for a
//! `gonio_station::tap::FrameTap`). Times in s; errors: the detector path's
//! [`SourceError`].

use gonio_station::RingReading;
use gonio_station::hal::DeviceError;
use gonio_station::tap::SeenFrame;
use gonio_vision::{
    FrameResult, FrameSource, FrameStamp, Optics, SourceDetector, SourceError, VisionError,
};
use std::time::Duration;

/// One frame of a triggered camera, through the detector.
#[derive(Debug, Clone, PartialEq)]
pub struct TriggeredFrame {
    /// The camera's frame number (= the PLC's trigger count).
    pub frame_id: u64,
    /// The camera's timestamp of the exposure start, s (`None`: unknown). The station stamps
    /// the frame with the PLC's time of its trigger instead.
    pub timestamp_s: Option<f64>,
    /// What the detector read in it.
    pub reading: RingReading,
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

    /// The frame [`TriggeredCamera::next_frame`] gave last, as its detector saw it (pixels,
    /// stamp, the whole result); `None` for a camera that keeps no pixels.
    fn seen(&self) -> Option<SeenFrame<'_>> {
        None
    }

    /// The frames that follow start anew (a turn begins, or the last frame was discarded): a
    /// camera that tracks the ring from frame to frame forgets it, so that a turn's results
    /// depend on the turn's own frames, as `gonio replay` reproduces them.
    fn restart_tracking(&mut self) {}
}

/// A `FrameSource` (e.g. a GigE Vision camera) through the streaming detector: frame numbers
/// from the source's stamps.
#[derive(Debug)]
pub struct DetectorTriggered<S> {
    det: SourceDetector<S>,
    last: Option<(FrameStamp, FrameResult)>,
}

impl<S: FrameSource> DetectorTriggered<S> {
    /// The source through the detector for `optics`.
    ///
    /// # Errors
    /// Invalid optics.
    pub fn new(source: S, optics: &Optics) -> Result<Self, VisionError> {
        let mut det = SourceDetector::new(source, optics)?;
        // Triggered frames come in order: tracked (gonio_vision::track).
        det.track_frames(true);
        Ok(DetectorTriggered { det, last: None })
    }

    /// The source.
    pub fn source_mut(&mut self) -> &mut S {
        self.det.source_mut()
    }
}

impl<S> TriggeredCamera for DetectorTriggered<S>
where
    S: FrameSource,
    S::Error: DeviceError,
{
    type Error = SourceError<S::Error>;

    fn next_frame(&mut self, _timeout: Duration) -> Result<Option<TriggeredFrame>, Self::Error> {
        // The source's own timeout bounds the wait (a GigE source ends with an error).
        self.last = None;
        let Some(d) = self.det.detect_next()? else {
            return Ok(None);
        };
        let frame = TriggeredFrame {
            frame_id: d.stamp.index,
            timestamp_s: d.stamp.start_s,
            reading: RingReading::of(&d.result),
        };
        self.last = Some((d.stamp, d.result));
        Ok(Some(frame))
    }

    fn restart_tracking(&mut self) {
        self.det.restart_tracking();
    }

    fn seen(&self) -> Option<SeenFrame<'_>> {
        let (stamp, result) = self.last.as_ref()?;
        let o = self.det.optics();
        Some(SeenFrame {
            width: o.window_width_px as usize,
            height: o.window_height_px as usize,
            pixels: self.det.window()?,
            stamp: *stamp,
            result,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use gonio_station::hal::DeviceErrorKind;
    use gonio_vision::FrameHeader;

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
    fn every_frame_is_seen_with_its_window_and_the_detectors_result() {
        let optics = Optics {
            window_width_px: 96,
            window_height_px: 48,
            ..Optics::default()
        };
        let mut cam = DetectorTriggered::new(Ring(0), &optics).unwrap();
        assert!(cam.seen().is_none(), "nothing taken yet");
        let mut frames = 0;
        while let Some(f) = cam.next_frame(Duration::from_secs(1)).unwrap() {
            let s = cam.seen().expect("the frame just taken");
            assert_eq!(s.stamp.index, f.frame_id);
            assert_eq!((s.width, s.height, s.pixels.len()), (96, 48, 96 * 48));
            // The ring's dark columns, as the detector saw them.
            assert_eq!((s.pixels[40], s.pixels[20]), (60, 200));
            assert_eq!(RingReading::of(s.result), f.reading);
            assert!((f.reading.c_px.unwrap() - 40.0).abs() < 0.05, "{f:?}");
            assert_eq!(f.frame_id, 10 + frames);
            frames += 1;
        }
        assert_eq!(frames, 3);
        assert!(cam.seen().is_none(), "the source ended: no frame");
    }
}
