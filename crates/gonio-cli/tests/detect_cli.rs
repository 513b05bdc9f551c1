//! `gonio detect`: bad input is a one-line error with exit code 2, never a panic.

use std::io::Write;
use std::path::Path;
use std::process::{Command, Output, Stdio};

fn gonio(args: &[&str], stdin: Option<&[u8]>) -> Output {
    let mut child = Command::new(env!("CARGO_BIN_EXE_gonio"))
        .args(args)
        .stdin(if stdin.is_some() {
            Stdio::piped()
        } else {
            Stdio::null()
        })
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("gonio runs");
    if let Some(data) = stdin {
        let mut s = child.stdin.take().unwrap();
        // The reader may stop early on an error: a broken pipe here is fine.
        let _ = s.write_all(data);
    }
    child.wait_with_output().unwrap()
}

fn assert_error(o: &Output, expected: &str) {
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(err.contains(expected), "expected {expected:?} in {err:?}");
    assert_eq!(err.trim_end().lines().count(), 1, "one line: {err:?}");
    assert!(!err.contains("panicked"));
}

fn grey_png(path: &Path, w: u32, h: u32) {
    image::GrayImage::from_pixel(w, h, image::Luma([128u8]))
        .save(path)
        .unwrap();
}

#[test]
fn sixteen_bit_png_is_refused() {
    let d = tempfile::tempdir().unwrap();
    let p = d.path().join("f.png");
    image::ImageBuffer::<image::Luma<u16>, Vec<u16>>::from_pixel(1440, 540, image::Luma([1000u16]))
        .save(&p)
        .unwrap();
    let o = gonio(&["detect", p.to_str().unwrap()], None);
    assert_error(&o, "expected 8-bit grey");
}

#[test]
fn wrong_frame_size_is_refused() {
    let d = tempfile::tempdir().unwrap();
    let p = d.path().join("small.png");
    grey_png(&p, 100, 50);
    let o = gonio(&["detect", p.to_str().unwrap()], None);
    assert_error(
        &o,
        "small.png: frame is 100×50: expected the window 1440×540",
    );
    let o = gonio(&["detect", "--raw", "100x50"], Some(&[0u8; 5000]));
    assert_error(&o, "--raw 100x50: expected the window 1440x540");
}

#[test]
fn corrupt_png_is_refused() {
    let d = tempfile::tempdir().unwrap();
    let p = d.path().join("bad.png");
    let mut bytes = b"\x89PNG\r\n\x1a\n".to_vec();
    bytes.extend_from_slice(b"this is not a PNG stream at all");
    std::fs::write(&p, bytes).unwrap();
    let o = gonio(&["detect", p.to_str().unwrap()], None);
    assert_error(&o, "bad.png: not a readable PNG/TIFF image");
}

#[test]
fn truncated_raw_stream_reports_the_whole_frames_read() {
    let frame = 1440 * 540;
    let data = vec![100u8; frame + frame / 2];
    let o = gonio(
        &[
            "detect",
            "--raw",
            "1440x540",
            "--speed-deg-s",
            "180",
            "--fps",
            "100",
        ],
        Some(&data),
    );
    assert_error(
        &o,
        "truncated frame: 1 whole 1440x540 frames read, then 388800 of 777600 bytes",
    );
}

#[test]
fn short_angle_file_is_refused() {
    let d = tempfile::tempdir().unwrap();
    for k in 0..3 {
        grey_png(&d.path().join(format!("f{k}.png")), 1440, 540);
    }
    let angles = d.path().join("angles.csv");
    std::fs::write(&angles, "frame,theta_deg\n0,0.0\n1,1.8\n").unwrap();
    let frames: Vec<String> = (0..3)
        .map(|k| d.path().join(format!("f{k}.png")).display().to_string())
        .collect();
    let mut args = vec!["detect", "--angles", angles.to_str().unwrap()];
    args.extend(frames.iter().map(|s| s.as_str()));
    let o = gonio(&args, None);
    assert_error(
        &o,
        "no angle for frame 2: 3 frames given, the angle file covers 2",
    );
}
