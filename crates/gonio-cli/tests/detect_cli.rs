//! `gonio detect`: bad input is a one-line error with exit code 2, never a panic.

mod common;

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

fn json_lines(o: &Output) -> Vec<serde_json::Value> {
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    String::from_utf8_lossy(&o.stdout)
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect()
}

#[test]
fn scenes_render_and_detect_with_score_and_margin() {
    let d = tempfile::tempdir().unwrap();
    for scene in ["clean", "realistic", "dense", "random"] {
        let out = d.path().join(scene);
        let o = gonio(
            &[
                "simulate",
                "frames",
                "--scene",
                scene,
                "--count",
                "3",
                "--seed",
                "5",
                "--out",
                out.to_str().unwrap(),
            ],
            None,
        );
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let truth: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(out.join("truth.json")).unwrap())
                .unwrap();
        let frames = truth["frames"].as_array().unwrap();
        assert_eq!(frames.len(), 3);
        // `random` draws a scene per frame and records it with the frame's truth.
        assert_eq!(
            frames[0].get("scene").is_some(),
            scene == "random",
            "{scene}"
        );
        let o = gonio(&["detect", out.to_str().unwrap()], None);
        for (l, t) in json_lines(&o).iter().zip(frames) {
            for key in [
                "score", "margin", "reason", "valid", "c_px", "edges", "focus",
            ] {
                assert!(l.get(key).is_some(), "{scene}: no {key} in {l}");
            }
            // The named scenes hold a ring well inside the window: found, to 0.1 px.
            if scene != "random" {
                assert_eq!(l["valid"], true, "{scene}: {l}");
                let err = l["c_px"].as_f64().unwrap() - t["c_true_px"].as_f64().unwrap();
                assert!(err.abs() < 0.1, "{scene}: error {err}");
                assert!(l["margin"].as_f64().unwrap() >= 0.3);
            }
        }
    }
}

#[test]
fn two_rings_alike_are_ambiguous_not_a_guess() {
    // Two equal dark 11 px rings 200 px apart: either could be the ring.
    let d = tempfile::tempdir().unwrap();
    let p = d.path().join("two.png");
    let img = image::GrayImage::from_fn(1440, 540, |x, _| {
        let ring = |c: u32| x + 5 >= c && x <= c + 5;
        image::Luma([if ring(620) || ring(820) { 70 } else { 190 }])
    });
    img.save(&p).unwrap();
    let o = gonio(&["detect", p.to_str().unwrap()], None);
    let l = &json_lines(&o)[0];
    assert_eq!(l["valid"], false, "{l}");
    assert_eq!(l["reason"], "ambiguous", "{l}");
    assert!(l["c_px"].is_null());
    assert!(l["margin"].as_f64().unwrap() < 0.3, "{l}");
}

#[test]
fn a_bad_scene_file_names_its_line() {
    let d = tempfile::tempdir().unwrap();
    let p = d.path().join("scene.toml");
    let out = d.path().join("o");
    // `gonio simulate frames` of one frame from the scene file `text`.
    let frames = |text: &str| {
        std::fs::write(&p, text).unwrap();
        gonio(
            &[
                "simulate",
                "frames",
                "--scene-file",
                p.to_str().unwrap(),
                "--count",
                "1",
                "--seed",
                "1",
                "--out",
                out.to_str().unwrap(),
            ],
            None,
        )
    };
    let o = frames("ring_present = true\nring_widht_px = 11.0\n");
    assert_error(&o, "scene.toml:2:1");
    let o = frames(
        "[[scratches]]\nx_px = 1.0\ny_px = 2.0\nangle_deg = 3.0\nwidth_px = -1.0\ndepth_grey = 9.0\n",
    );
    assert_error(&o, "scratches.width_px = -1: expected a finite number > 0");
}

#[test]
fn json_lines_keep_every_field_and_add_score_and_margin() {
    // The contract: every key `gonio detect` wrote before (tests/data/json-keys-detect.txt, from
    // a valid and a ring-less frame) is still written, plus `score` and `margin`.
    let d = tempfile::tempdir().unwrap();
    let mut keys = std::collections::BTreeSet::new();
    for (name, extra) in [("ring", None), ("none", Some("--no-ring"))] {
        let out = d.path().join(name);
        let mut args = vec![
            "simulate",
            "frames",
            "--count",
            "1",
            "--seed",
            "3",
            "--out",
            out.to_str().unwrap(),
        ];
        args.extend(extra);
        let o = gonio(&args, None);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let o = gonio(&["detect", out.to_str().unwrap()], None);
        let lines = json_lines(&o);
        assert_eq!(lines[0]["valid"], extra.is_none(), "{}", lines[0]);
        for l in &lines {
            common::key_paths(l, "", &mut keys);
        }
    }
    let old = std::fs::read_to_string(
        Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/json-keys-detect.txt"),
    )
    .unwrap();
    for k in old.lines().filter(|l| !l.starts_with('#') && !l.is_empty()) {
        assert!(keys.contains(k), "`gonio detect` no longer writes {k}");
    }
    for k in ["score", "margin"] {
        assert!(keys.contains(k), "no {k}");
    }
}

#[test]
fn threads_keep_frame_order_and_the_same_bytes() {
    // Frames that differ (the `random` family: rings anywhere, some without one), from files
    // and as raw frames on standard input, on one, two and three worker threads.
    let d = tempfile::tempdir().unwrap();
    let out = d.path().join("frames");
    let o = gonio(
        &[
            "simulate",
            "frames",
            "--scene",
            "random",
            "--count",
            "12",
            "--seed",
            "3",
            "--raw",
            "--out",
            out.to_str().unwrap(),
        ],
        None,
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let mut pngs: Vec<_> = std::fs::read_dir(&out)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|x| x == "png"))
        .collect();
    pngs.sort();
    assert_eq!(pngs.len(), 12);
    let raw: Vec<u8> = pngs
        .iter()
        .flat_map(|p| image::open(p).unwrap().into_luma8().into_raw())
        .collect();
    // `--raw` wrote the same pixels back to back.
    assert!(std::fs::read(out.join("frames.raw")).unwrap() == raw);
    let dir = out.to_str().unwrap();
    let run = |threads: &str, from_files: bool| {
        let o = if from_files {
            gonio(&["detect", dir, "--threads", threads], None)
        } else {
            gonio(
                &["detect", "--raw", "1440x540", "--threads", threads],
                Some(&raw),
            )
        };
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        o.stdout
    };
    for from_files in [true, false] {
        let one = run("1", from_files);
        let lines = json_lines(&gonio(&["detect", dir, "--threads", "1"], None));
        let frames: Vec<u64> = lines.iter().map(|l| l["frame"].as_u64().unwrap()).collect();
        assert_eq!(frames, (0..12).collect::<Vec<_>>());
        // The frames give different results: the comparison below can see a reordering.
        let cs: std::collections::BTreeSet<String> =
            lines.iter().map(|l| l["c_px"].to_string()).collect();
        assert!(cs.len() >= 6, "{cs:?}");
        for threads in ["2", "3"] {
            assert!(
                run(threads, from_files) == one,
                "--threads {threads} (files: {from_files}) differs from --threads 1"
            );
        }
    }
    // `--timing` (one frame at a time on the main thread) writes the same bytes and reports the
    // detector's CPU time per frame: median ≤ 99th percentile ≤ max, all positive.
    let o = gonio(
        &["detect", "--raw", "1440x540", "--timing", "--no-track"],
        Some(&raw),
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(o.stdout == run("1", false), "--timing changed the output");
    let err = String::from_utf8_lossy(&o.stderr);
    let line = err
        .lines()
        .find(|l| l.starts_with("detector alone"))
        .unwrap_or_else(|| panic!("no timing line in {err:?}"));
    let ms: Vec<f64> = line
        .split_whitespace()
        .filter_map(|w| w.parse().ok())
        .collect();
    // median, 99th percentile, max (ms), frame count
    assert_eq!(ms.len(), 4, "{line}");
    assert!(ms[0] > 0.0 && ms[0] <= ms[1] && ms[1] <= ms[2], "{line}");
    assert_eq!(ms[3], 12.0, "{line}");
    // Each frame on two threads: the same bytes again, and the wall time reported as such.
    let o = gonio(&timing_with_frame_threads("2"), Some(&raw));
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(
        o.stdout == run("1", false),
        "--frame-threads 2 changed the output"
    );
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.lines()
            .any(|l| l.starts_with("detector alone, each frame on two threads")),
        "{err}"
    );
}

/// `gonio detect --raw 1440x540 --timing --frame-threads N`.
fn timing_with_frame_threads(n: &str) -> [&str; 7] {
    [
        "detect",
        "--raw",
        "1440x540",
        "--timing",
        "--no-track",
        "--frame-threads",
        n,
    ]
}

#[test]
fn frame_threads_are_one_or_two_and_only_where_frames_go_one_at_a_time() {
    for n in ["0", "3"] {
        let o = gonio(&timing_with_frame_threads(n), Some(&[]));
        assert_eq!(o.status.code(), Some(2), "--frame-threads {n}");
        assert!(String::from_utf8_lossy(&o.stderr).contains("--frame-threads"));
    }
    // Whole frames in parallel (--threads, the default for files and for --raw --no-track):
    // refused, not ignored.
    let o = gonio(
        &[
            "detect",
            "--raw",
            "1440x540",
            "--no-track",
            "--frame-threads",
            "2",
        ],
        Some(&[]),
    );
    assert_error(&o, "--frame-threads");
}

#[test]
fn zero_threads_are_refused() {
    let o = gonio(
        &["detect", "--raw", "1440x540", "--threads", "0"],
        Some(&[]),
    );
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("--threads"));
}

#[test]
fn frames_in_order_are_tracked_and_agree_with_whole_frames() {
    let d = tempfile::tempdir().unwrap();
    let out = d.path().join("turn");
    let o = gonio(
        &[
            "simulate",
            "frames",
            "--count",
            "30",
            "--eccentricity-um",
            "120",
            "--seed",
            "1",
            "--raw",
            "--out",
            out.to_str().unwrap(),
        ],
        None,
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let raw = std::fs::read(out.join("frames.raw")).unwrap();
    let tracked = json_lines(&gonio(&["detect", "--raw", "1440x540"], Some(&raw)));
    let whole = json_lines(&gonio(
        &["detect", "--raw", "1440x540", "--no-track"],
        Some(&raw),
    ));
    assert_eq!((tracked.len(), whole.len()), (30, 30));
    for (k, (t, w)) in tracked.iter().zip(&whole).enumerate() {
        assert_eq!(
            t["tracked"],
            k > 0,
            "frame {k}: the first frame is measured whole"
        );
        assert_eq!(w["tracked"], false);
        assert_eq!(
            (&t["valid"], &w["valid"]),
            (&true.into(), &true.into()),
            "frame {k}"
        );
        let dc = t["c_px"].as_f64().unwrap() - w["c_px"].as_f64().unwrap();
        assert!(dc.abs() <= 0.02, "frame {k}: Δc {dc}");
        assert_eq!(t["focus"], w["focus"], "frame {k}: the whole frame's focus");
    }
    // Image files are measured whole unless --track takes their name order as the frames'.
    let dir = out.to_str().unwrap();
    let files = json_lines(&gonio(&["detect", dir], None));
    assert!(files.iter().all(|l| l["tracked"] == false));
    let files = json_lines(&gonio(&["detect", dir, "--track"], None));
    assert_eq!(files.iter().filter(|l| l["tracked"] == true).count(), 29);
    // --timing reports the two modes apart, and why frames were measured whole.
    let o = gonio(&["detect", "--raw", "1440x540", "--timing"], Some(&raw));
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let err = String::from_utf8_lossy(&o.stderr);
    for want in [
        "tracked (measured in the band) frames",
        "whole frames",
        "tracking: 29 frames in the band, 1 whole (no_track 1)",
    ] {
        assert!(err.contains(want), "{want:?} not in {err}");
    }
    // The one whole frame's time is its own (the band's frames are a few times faster).
    let median = |mode: &str| -> f64 {
        let l = err.lines().find(|l| l.starts_with(mode)).unwrap();
        l.split_whitespace()
            .find_map(|w| w.parse::<f64>().ok())
            .unwrap()
    };
    assert!(
        median("whole frames") > median("tracked (measured in the band)"),
        "{err}"
    );
    // Whole frames in parallel cannot be tracked: refused, not ignored.
    let o = gonio(
        &["detect", "--raw", "1440x540", "--track", "--threads", "2"],
        Some(&[]),
    );
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("--track"));
}
