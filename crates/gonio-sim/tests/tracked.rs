//! The tracked detector (`gonio_vision::track`) against the whole-frame detector, frame by frame,
//! on rendered scenes: realistic turns, the dense and clean scenes, rings near the window's
//! side, a ring crossing the window fast, a ring lost and found again (each through
//! `SourceDetector` with tracking on, the station's path), and the `random` family (2,000
//! scenes as drawn, each measured after a frame of it moved sideways by up to 12 px, as the
//! eccentric motion moves a ring between frames).
//!
//! - no frame valid in the band that the whole-frame detector calls invalid;
//! - |Δc| ≤ 0.02 px on every frame both call valid;
//! - ≥ 99 % of a turn's frames measured in the band while the ring is in the window.
//!
//! A frame the tracker measures whole is the whole-frame detector's result (the same code on
//! the same frame): the turns check that too.

use gonio_sim::frames::{
    GratingRenderer, RenderedFrames, SceneChoice, SceneFamily, ScenePreset, Turn, frame_seed,
};
use gonio_vision::track::Tracker;
use gonio_vision::{Detector, FrameResult, Optics, SourceDetector};
use rayon::prelude::*;

/// The largest |Δc| allowed where both detectors call a frame valid, px.
const AGREE_PX: f64 = 0.02;

/// What the tracked detector did against the whole-frame one.
#[derive(Debug, Default)]
struct Tally {
    frames: usize,
    tracked: usize,
    /// Frames valid in the band that the whole frame calls invalid.
    wrong_valid: usize,
    /// Frames the whole-frame detector calls valid (counted where it was run).
    whole_valid: usize,
    max_dc: f64,
}

impl Tally {
    /// One frame: the tracked result `t` and, where it was computed, the whole frame's.
    fn add(&mut self, t: &FrameResult, whole: Option<&FrameResult>) {
        self.frames += 1;
        self.tracked += t.tracked as usize;
        let Some(whole) = whole else {
            return;
        };
        self.whole_valid += whole.valid as usize;
        if !t.tracked {
            assert_eq!(t, whole, "a frame measured whole is the whole detector's");
            return;
        }
        assert!(
            t.valid,
            "a frame is only measured in the band when valid there"
        );
        if !whole.valid {
            self.wrong_valid += 1;
            return;
        }
        self.max_dc = self
            .max_dc
            .max((t.c_px.unwrap() - whole.c_px.unwrap()).abs());
        // The raw statistics are the whole frame's.
        assert_eq!(
            (t.focus, t.mean_gradient, t.saturated_px),
            (whole.focus, whole.mean_gradient, whole.saturated_px)
        );
    }

    fn merge(mut self, o: Tally) -> Tally {
        self.frames += o.frames;
        self.tracked += o.tracked;
        self.wrong_valid += o.wrong_valid;
        self.whole_valid += o.whole_valid;
        self.max_dc = self.max_dc.max(o.max_dc);
        self
    }

    fn check(&self, what: &str) {
        assert_eq!(self.wrong_valid, 0, "{what}: {self:?}");
        assert!(self.max_dc <= AGREE_PX, "{what}: {self:?}");
    }
}

/// A turn of 200 frames (one table turn at the seed's 180°/s and 100 frames/s) through
/// `SourceDetector` with tracking on, each frame's window also through the whole detector.
fn turn(scene: ScenePreset, e_um: f64, psi_deg: f64, seed: u64) -> Tally {
    let optics = Optics::default();
    let t = Turn {
        eccentricity_um: e_um,
        ecc_angle_deg: psi_deg,
        ..Turn::default()
    };
    let src = RenderedFrames::new(&optics, SceneChoice::Preset(scene), t, 200, seed).unwrap();
    let mut det = SourceDetector::new(src, &optics).unwrap();
    det.track_frames(true);
    let mut whole = Detector::new(&optics).unwrap();
    let mut tally = Tally::default();
    while let Some(d) = det.detect_next().unwrap() {
        let w = whole.detect(det.window().unwrap()).unwrap();
        tally.add(&d.result, Some(&w));
    }
    let tracker = det.tracker().unwrap();
    assert_eq!(
        tracker.tracked_frames() as usize,
        tally.tracked,
        "the tracker counts what it reports"
    );
    eprintln!(
        "{scene:?}, e {e_um} µm: {tally:?}; whole frames: {:?}",
        tracker.fallbacks().filter(|f| f.1 > 0).collect::<Vec<_>>()
    );
    tally
}

#[test]
fn turns_are_measured_in_the_band_and_agree_with_the_whole_frame() {
    // (scene, e µm, ψ°, seed): realistic turns at three eccentricities, the dense and the
    // clean scene, and a ring 50 px from the window's sides at its extremes (500 µm).
    let cases = [
        (ScenePreset::Realistic, 100.0, 30.0, 1),
        (ScenePreset::Realistic, 250.0, 200.0, 2),
        (ScenePreset::Realistic, 30.0, 95.0, 3),
        (ScenePreset::Dense, 150.0, 20.0, 4),
        (ScenePreset::Clean, 150.0, 20.0, 4),
        (ScenePreset::Realistic, 500.0, 0.0, 5),
        // The turn starting as the ring crosses the window's middle at its fastest, 21 px a
        // frame: tracked from its second frame.
        (ScenePreset::Realistic, 500.0, 45.0, 7),
    ];
    let tallies: Vec<Tally> = cases
        .par_iter()
        .map(|&(scene, e, psi, seed)| turn(scene, e, psi, seed))
        .collect();
    for (t, (scene, e, ..)) in tallies.iter().zip(&cases) {
        let what = format!("{scene:?}, e {e} µm");
        t.check(&what);
        assert_eq!(
            t.whole_valid, t.frames,
            "{what}: the ring is in every frame"
        );
        assert!(t.tracked * 100 >= 99 * t.frames, "{what}: {t:?}");
    }
}

#[test]
fn a_ring_lost_and_found_again_is_tracked_again() {
    // 700 µm takes the ring out of the window on both sides and back, entering at ≈ 19 px a
    // frame.
    let t = turn(ScenePreset::Realistic, 700.0, 130.0, 6);
    t.check("lost and found");
    assert!(
        t.whole_valid < t.frames * 3 / 4,
        "the ring leaves the window: {t:?}"
    );
    // Every frame with the ring is tracked but the first after it comes back (and the
    // frames where it touches the side on its way out or in).
    assert!(t.tracked + 6 >= t.whole_valid, "{t:?}");
}

/// `frame` (rows `w` wide) moved right by `dx` px (left when negative), the columns it uncovers
/// repeating its side column.
fn moved(frame: &[u8], w: usize, dx: i64) -> Vec<u8> {
    let mut out = Vec::with_capacity(frame.len());
    for row in frame.chunks_exact(w) {
        out.extend((0..w as i64).map(|x| row[(x - dx).clamp(0, w as i64 - 1) as usize]));
    }
    out
}

#[test]
fn random_scenes_measured_after_a_frame_of_them_moved() {
    let optics = Optics::default();
    let p = optics.params().unwrap();
    let family = SceneFamily::default();
    let base = GratingRenderer::new(&optics, Default::default()).unwrap();
    const SCENES: u64 = 2000;
    let t = (0..SCENES)
        .into_par_iter()
        .map(|k| {
            let seed = frame_seed(20_260_109, k);
            let d = family.draw(seed, p.um_per_px, p.width, p.height);
            let r = base.with_scene(d.scene.clone()).unwrap();
            let mut f = vec![0u8; r.frame_len()];
            r.render(
                d.theta_deg,
                d.eccentricity_um,
                d.ecc_angle_deg,
                d.focus_um,
                seed,
                &mut f,
            )
            .unwrap();
            let mut det = Detector::new(&optics).unwrap();
            let mut whole = Detector::new(&optics).unwrap();
            let mut tracker = Tracker::new(&optics).unwrap();
            let mut tally = Tally::default();
            // The frame before: the scene moved 0 … 12 px to either side (up to what a 560 µm
            // eccentricity moves the ring at 1.8° a frame), measured whole; then the scene as
            // drawn.
            let dx = (k % 25) as i64 - 12;
            for (j, f) in [moved(&f, p.width, dx), f].iter().enumerate() {
                let t = tracker.detect(f, j as u64, &mut det, None).unwrap();
                // The whole frame where the band measured (a frame measured whole is the
                // whole detector's by construction; the turns check it).
                let whole = t.tracked.then(|| whole.detect(f).unwrap());
                tally.add(&t, whole.as_ref());
            }
            tally
        })
        .reduce(Tally::default, Tally::merge);
    eprintln!("random scenes: {t:?}");
    t.check("random scenes");
    // The band measures most second frames (the first is always whole).
    assert!(t.tracked * 2 >= SCENES as usize, "{t:?}");
}
