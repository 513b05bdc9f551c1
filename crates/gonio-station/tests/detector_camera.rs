//! The station's camera path: frames from a source through the detector to `CameraFrame`s with
//! typed reasons; an ambiguous or invalid frame never carries a column.

use gonio_station::camera::{DetectorCamera, DetectorCameraError};
use gonio_station::hal::{Camera, DeviceError, DeviceErrorKind};
use gonio_vision::{FrameHeader, FrameSource, FrameStamp, InvalidReason, Optics};

#[derive(Debug)]
struct Glitch;
impl std::fmt::Display for Glitch {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("link down")
    }
}
impl std::error::Error for Glitch {}
impl DeviceError for Glitch {
    fn kind(&self) -> DeviceErrorKind {
        DeviceErrorKind::Communication
    }
}

/// What each frame of the test source shows.
#[derive(Clone, Copy)]
enum Shot {
    /// One dark ring centred on this column (window coordinates).
    Ring(f64),
    /// Two equal rings at these columns.
    Two(f64, f64),
    /// One ring, delivered as a whole sensor frame.
    SensorRing(f64),
    /// A frame without a start time.
    Unstamped,
    /// The link fails.
    Fail,
}

const W: usize = 200;
const H: usize = 64;
const SW: usize = 260;
const SH: usize = 80;

fn optics() -> Optics {
    Optics {
        window_width_px: W as u32,
        window_height_px: H as u32,
        sensor_width_px: SW as u32,
        sensor_height_px: SH as u32,
        ..Optics::default()
    }
}

struct Script(Vec<Shot>, usize);

fn draw(px: &mut Vec<u8>, w: usize, h: usize, rings: &[f64]) {
    px.clear();
    for _ in 0..h {
        for x in 0..w {
            let dark = rings.iter().any(|&c| (x as f64 - c).abs() <= 5.0);
            px.push(if dark { 70 } else { 190 });
        }
    }
}

impl FrameSource for Script {
    type Error = Glitch;
    fn next_frame(&mut self, px: &mut Vec<u8>) -> Result<Option<FrameHeader>, Glitch> {
        let Some(&shot) = self.0.get(self.1) else {
            return Ok(None);
        };
        let k = self.1 as u64;
        self.1 += 1;
        let mut stamp = FrameStamp {
            index: k,
            start_s: Some(k as f64 * 0.01),
            exposure_s: Some(0.5e-3),
            theta_deg: None,
        };
        let (w, h) = match shot {
            Shot::Ring(c) => {
                draw(px, W, H, &[c]);
                (W, H)
            }
            Shot::Two(a, b) => {
                draw(px, W, H, &[a, b]);
                (W, H)
            }
            Shot::SensorRing(c) => {
                // The window sits centred on the sensor: offset (30, 8).
                draw(px, SW, SH, &[c + ((SW - W) / 2) as f64]);
                (SW, SH)
            }
            Shot::Unstamped => {
                draw(px, W, H, &[100.0]);
                stamp.start_s = None;
                (W, H)
            }
            Shot::Fail => return Err(Glitch),
        };
        Ok(Some(FrameHeader {
            width: w,
            height: h,
            stamp,
        }))
    }
}

#[test]
fn frames_become_typed_camera_frames() {
    let shots = vec![
        Shot::Ring(90.0),
        Shot::Two(60.0, 140.0),
        Shot::SensorRing(110.0),
        Shot::Unstamped,
        Shot::Fail,
    ];
    let mut cam = DetectorCamera::new(Script(shots, 0), &optics()).unwrap();
    let f = cam.capture().unwrap();
    assert_eq!(f.invalid_reason, None);
    assert!((f.c_px.unwrap() - 90.0).abs() < 0.05, "{f:?}");
    assert_eq!((f.start_s, f.exposure_s), (0.0, 0.5e-3));
    // Two rings alike: ambiguous, and no column for the fit to use.
    let f = cam.capture().unwrap();
    assert_eq!(f.invalid_reason, Some(InvalidReason::Ambiguous), "{f:?}");
    assert_eq!(f.c_px, None);
    let r = cam.last_result().unwrap();
    assert!(r.margin.unwrap() < 0.3 && r.score.is_some());
    // A sensor-size frame: the optics cut the window out.
    let f = cam.capture().unwrap();
    assert!((f.c_px.unwrap() - 110.0).abs() < 0.05, "{f:?}");
    // A frame without a start time is an error, not a guess at θ.
    let e = cam.capture().unwrap_err();
    assert!(
        matches!(e, DetectorCameraError::Unstamped { index: 3 }),
        "{e}"
    );
    assert_eq!(e.kind(), DeviceErrorKind::Fault);
    // The source's own error keeps its kind.
    let e = cam.capture().unwrap_err();
    assert_eq!(e.kind(), DeviceErrorKind::Communication);
    assert_eq!(e.to_string(), "link down");
    // And a source that ends is a timeout for the station.
    let e = cam.capture().unwrap_err();
    assert!(matches!(e, DetectorCameraError::Ended { frames: 4 }), "{e}");
    assert_eq!(e.kind(), DeviceErrorKind::Timeout);
}

#[test]
fn a_frame_of_the_wrong_size_is_an_error() {
    struct Odd;
    impl FrameSource for Odd {
        type Error = Glitch;
        fn next_frame(&mut self, px: &mut Vec<u8>) -> Result<Option<FrameHeader>, Glitch> {
            px.clear();
            px.resize(10 * 10, 0);
            Ok(Some(FrameHeader {
                width: 10,
                height: 10,
                stamp: FrameStamp {
                    index: 0,
                    start_s: Some(0.0),
                    ..FrameStamp::default()
                },
            }))
        }
    }
    let mut cam = DetectorCamera::new(Odd, &optics()).unwrap();
    let e = cam.capture().unwrap_err();
    assert!(
        e.to_string()
            .contains("frame 0: frame is 10×10: expected the window 200×64 or the sensor 260×80"),
        "{e}"
    );
}
