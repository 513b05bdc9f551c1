//! `Detector::detect_split` (a frame on two threads) gives `Detector::detect`'s result bit for
//! bit: on the random scene family, the presets, a bright ring, windows of several heights
//! (some too short to split) and saturated rows on and around the seam.

use gonio_sim::frames::{GratingScene, RenderedFrames, SceneChoice, ScenePreset, Turn};
use gonio_vision::{Detector, FrameSource, Optics, Polarity};

fn render(optics: &Optics, choice: SceneChoice, n: u64, seed: u64) -> Vec<Vec<u8>> {
    let turn = Turn {
        drawn_pose: true,
        ..Turn::default()
    };
    let mut src = RenderedFrames::new(optics, choice, turn, n, seed).unwrap();
    let mut out = Vec::new();
    let mut buf = Vec::new();
    while src.next_frame(&mut buf).unwrap().is_some() {
        out.push(std::mem::take(&mut buf));
    }
    out
}

/// Every frame through both paths of one detector pair; returns how many were valid.
fn same(optics: &Optics, frames: &[Vec<u8>], what: &str) -> usize {
    let mut one = Detector::new(optics).unwrap();
    let mut two = Detector::new(optics).unwrap();
    let mut lower = two.lower_half();
    let mut valid = 0;
    for (k, f) in frames.iter().enumerate() {
        let a = one.detect(f).unwrap();
        let b = two.detect_split(f, &mut lower).unwrap();
        // Debug prints every float's shortest round-trip form: equal text, equal bits.
        assert_eq!(format!("{a:?}"), format!("{b:?}"), "{what}: frame {k}");
        valid += a.valid as usize;
    }
    valid
}

#[test]
fn split_frames_give_the_single_thread_result_bit_for_bit() {
    let optics = Optics::default();
    let det = Detector::new(&optics).unwrap();
    let seam = det.seam_row().expect("the station's window is split");
    assert!(seam > 100 && seam < 440, "seam at row {seam}");

    let random = render(&optics, SceneChoice::Random(Box::default()), 160, 7);
    let v = same(&optics, &random, "random scenes");
    assert!(
        v > 100,
        "only {v} of 160 random scenes valid: the comparison is weak"
    );
    for preset in [
        ScenePreset::Clean,
        ScenePreset::Realistic,
        ScenePreset::Dense,
    ] {
        let f = render(
            &optics,
            SceneChoice::Scene(Box::new(GratingScene::preset(preset))),
            20,
            3,
        );
        assert_eq!(same(&optics, &f, &format!("{preset:?}")), 20, "{preset:?}");
    }

    // A bright ring: the input is inverted on both threads.
    let bright = Optics {
        polarity: Polarity::Bright,
        ..Optics::default()
    };
    same(&bright, &random[..40], "bright polarity");

    // Saturated rows across the seam (the raw statistics' rows y − 2 … y on both sides, and
    // runs that must come out in row order) and a dark band the row-local stages reach over.
    let w = optics.window_width_px as usize;
    let mut marked = random[..20].to_vec();
    for (k, f) in marked.iter_mut().enumerate() {
        for dy in 0..6 {
            let y = seam - 3 + dy;
            let x0 = (k * 37 + dy * 11) % (w - 80);
            f[y * w + x0..y * w + x0 + 60 + k].fill(255);
        }
        let y = seam + 1 + k % 7;
        f[y * w..(y + 3) * w]
            .iter_mut()
            .step_by(3)
            .for_each(|p| *p /= 4);
    }
    same(&optics, &marked, "saturated seam");
}

#[test]
fn windows_of_every_height_split_or_not_give_the_same_result() {
    let mut split = 0;
    for height in [64u32, 301, 359, 360, 541, 720] {
        let optics = Optics {
            window_height_px: height,
            ..Optics::default()
        };
        let frames = render(
            &optics,
            SceneChoice::Random(Box::default()),
            12,
            u64::from(height),
        );
        same(&optics, &frames, &format!("height {height}"));
        let seam = Detector::new(&optics).unwrap().seam_row();
        split += seam.is_some() as usize;
    }
    // 60 rows of lag for this ring: windows from 360 rows on are split.
    assert_eq!(split, 3, "{split} of 6 heights split");
}
