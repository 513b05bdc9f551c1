//! Acceptance of the ring detector on the `random` scene family: 2,000 scenes
//! from a fixed seed list, run through the one path from a frame source to the result
//! (`RenderedFrames` → `SourceDetector`), judged against the renderer's ground truth.
//!
//! - No wrong-but-valid frame: valid with |c − c_true| > 1 px, or valid without a ring.
//! - ≥ 99 % valid where the ring lies fully inside the window with a visible contrast at or above
//!   the optics' minimum (whatever else the scene holds: borders, tracks, dust, scratches, gaps,
//!   saturated patches).
//! - |c − c_true| ≤ 0.1 px on every valid frame, RMS ≤ 0.03 px.
//!
//! Per-class figures are printed (`--nocapture`) for VALIDATION.md.

use gonio_sim::frames::{RenderedFrames, SceneChoice, SceneDraw, Turn};
use gonio_vision::{FrameResult, InvalidReason, Optics, SourceDetector};
use rayon::prelude::*;

/// The fixed seed list: frames 0 … N−1 of the run seeded with this.
const RUN_SEED: u64 = 20_260_109;
const SCENES: u64 = 2000;

struct Outcome {
    index: u64,
    draw: SceneDraw,
    truth: gonio_sim::frames::FrameTruth,
    result: FrameResult,
}

fn run(optics: &Optics, first: u64, end: u64) -> Vec<Outcome> {
    let chunks: Vec<(u64, u64)> = (first..end)
        .step_by(50)
        .map(|a| (a, (a + 50).min(end)))
        .collect();
    chunks
        .par_iter()
        .flat_map_iter(|&(a, b)| {
            let turn = Turn {
                drawn_pose: true,
                ..Turn::default()
            };
            let src = RenderedFrames::new(
                optics,
                SceneChoice::Random(Box::default()),
                turn,
                end,
                RUN_SEED,
            )
            .unwrap()
            .frames(a, b);
            let mut det = SourceDetector::new(src, optics).unwrap();
            let mut out = Vec::new();
            while let Some(d) = det.detect_next().unwrap() {
                out.push(Outcome {
                    index: d.stamp.index,
                    draw: det.source().last_draw().unwrap().clone(),
                    truth: *det.source().last_truth().unwrap(),
                    result: d.result,
                });
            }
            out
        })
        .collect()
}

/// The scene's defects in one line (for the failure list).
fn summary(o: &Outcome) -> String {
    let s = &o.draw.scene;
    let mut v = Vec::new();
    for k in &s.scratches {
        v.push(format!(
            "scratch {:.0}° {:.1} px {:+.0} grey",
            k.angle_deg, k.width_px, k.depth_grey
        ));
    }
    let half = o.truth.ring_width_px / 2.0;
    for t in &s.radial_tracks {
        let gap = if t.inner_px > 0.0 {
            t.inner_px - half
        } else {
            -t.outer_px - half
        };
        if gap < 30.0 {
            v.push(format!("track {gap:.0} px away, mark {:.1} px", t.mark_px));
        }
    }
    for b in &s.track_borders {
        if b.offset_px.abs() < 100.0 {
            v.push(format!("border {:.0} px", b.offset_px));
        }
    }
    if o.truth.patch_distance_px.is_finite() {
        v.push(format!("patch {:.0} px", o.truth.patch_distance_px));
    }
    v.push(format!(
        "blur {:.2} noise {:.1} dust-on-ring {} e {:.0}",
        o.truth.blur_sigma_px, s.read_noise_grey, s.dust_on_ring_per_frame, o.truth.eccentricity_um
    ));
    v.join(", ")
}

/// A named class of scenes.
type Class<'a> = (&'a str, &'a dyn Fn(&Outcome) -> bool);

#[derive(Default)]
struct Tally {
    frames: usize,
    eligible: usize,
    eligible_valid: usize,
    valid: usize,
    wrong_valid: usize,
    ambiguous: usize,
    worst: f64,
    ss: f64,
}

impl Tally {
    fn add(&mut self, o: &Outcome, eligible: bool, wrong: bool) {
        self.frames += 1;
        self.eligible += eligible as usize;
        self.eligible_valid += (eligible && o.result.valid) as usize;
        self.ambiguous += (o.result.reason == Some(InvalidReason::Ambiguous)) as usize;
        if o.result.valid {
            self.valid += 1;
            if wrong {
                self.wrong_valid += 1;
            } else {
                let e = o.result.c_px.unwrap() - o.truth.c_true_px;
                self.worst = self.worst.max(e.abs());
                self.ss += e * e;
            }
        }
    }
    fn rms(&self) -> f64 {
        let n = (self.valid - self.wrong_valid).max(1);
        (self.ss / n as f64).sqrt()
    }
}

#[test]
fn random_scenes_never_wrong_and_almost_always_found() {
    let optics = Optics::default();
    let n: u64 = std::env::var("GONIO_SCENES")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(SCENES);
    let out = run(&optics, 0, n);
    assert_eq!(out.len() as u64, n);
    let classes: [Class; 12] = [
        ("all", &|_| true),
        ("ring-less", &|o| !o.draw.scene.ring_present),
        ("ring leaves the window", &|o| {
            o.draw.scene.ring_present && !o.truth.ring_in_window
        }),
        ("faint ring (< 60 grey)", &|o| {
            o.draw.scene.ring_present && o.truth.ring_contrast_grey < 60.0
        }),
        ("track borders", &|o| !o.draw.scene.track_borders.is_empty()),
        ("borders nearer than 400 px", &|o| {
            o.draw
                .scene
                .track_borders
                .iter()
                .any(|b| b.offset_px.abs() < 400.0)
        }),
        ("radial tracks", &|o| !o.draw.scene.radial_tracks.is_empty()),
        ("scratch", &|o| !o.draw.scene.scratches.is_empty()),
        ("scratch within 20° of the ring", &|o| {
            o.draw.scene.scratches.iter().any(|s| {
                let a = s.angle_deg.rem_euclid(180.0);
                !(20.0..=160.0).contains(&a)
            })
        }),
        ("ring gap", &|o| o.truth.ring_gap_rows > 0),
        ("saturated patch", &|o| {
            !o.draw.scene.saturated_patches.is_empty()
        }),
        ("blur ≥ 1.2 px or noise ≥ 5", &|o| {
            o.truth.blur_sigma_px >= 1.2 || o.draw.scene.read_noise_grey >= 5.0
        }),
    ];
    let mut tallies: Vec<Tally> = classes.iter().map(|_| Tally::default()).collect();
    let mut reasons = std::collections::BTreeMap::<String, usize>::new();
    for o in &out {
        let s = &o.draw.scene;
        let eligible = s.ring_present
            && o.truth.ring_in_window
            && o.truth.ring_contrast_grey >= optics.min_ring_contrast_grey;
        let wrong = o.result.valid
            && !(s.ring_present
                && o.truth.c_true_px.is_finite()
                && (o.result.c_px.unwrap() - o.truth.c_true_px).abs() <= 1.0);
        let inaccurate =
            o.result.valid && !wrong && (o.result.c_px.unwrap() - o.truth.c_true_px).abs() > 0.1;
        if wrong || inaccurate || (eligible && !o.result.valid) {
            eprintln!(
                "frame {} ({}): valid {} reason {:?} c {:?} truth {:.3} contrast {:.0} width {:.1} \
                 gap {} score {:?} margin {:?} width change {:?} | {}",
                o.index,
                if wrong {
                    "WRONG"
                } else if o.result.valid {
                    "INACCURATE"
                } else {
                    "missed"
                },
                o.result.valid,
                o.result.reason,
                o.result.c_px,
                o.truth.c_true_px,
                o.truth.ring_contrast_grey,
                o.truth.ring_width_px,
                o.truth.ring_gap_rows,
                o.result.score,
                o.result.margin,
                o.result.width_change_px,
                summary(o),
            );
        }
        *reasons.entry(format!("{:?}", o.result.reason)).or_default() += 1;
        for ((_, f), t) in classes.iter().zip(tallies.iter_mut()) {
            if f(o) {
                t.add(o, eligible, wrong);
            }
        }
    }
    eprintln!(
        "| class | frames | valid | wrong-but-valid | eligible | valid of eligible | ambiguous | worst |c − c_true| px | RMS px |"
    );
    eprintln!("|---|---|---|---|---|---|---|---|---|");
    for ((name, _), t) in classes.iter().zip(&tallies) {
        eprintln!(
            "| {name} | {} | {} | {} | {} | {} ({:.1} %) | {} | {:.3} | {:.4} |",
            t.frames,
            t.valid,
            t.wrong_valid,
            t.eligible,
            t.eligible_valid,
            100.0 * t.eligible_valid as f64 / t.eligible.max(1) as f64,
            t.ambiguous,
            t.worst,
            t.rms()
        );
    }
    eprintln!("reasons: {reasons:?}");
    let all = &tallies[0];
    assert_eq!(all.wrong_valid, 0, "wrong-but-valid frames");
    assert_eq!(tallies[1].valid, 0, "a ring-less scene called valid");
    // ≥ 99 % of the eligible frames valid: with ≈ 1,500 eligible frames, 1 % is ≈ 15 frames.
    assert!(
        all.eligible_valid as f64 >= 0.99 * all.eligible as f64,
        "{} of {} eligible frames valid",
        all.eligible_valid,
        all.eligible
    );
    assert!(all.worst <= 0.1, "worst |c − c_true| = {:.4} px", all.worst);
    assert!(all.rms() <= 0.03, "RMS |c − c_true| = {:.4} px", all.rms());
}

/// Writes the frames listed in `GONIO_DUMP` (indices, comma-separated) as raw 1440×540 files
/// into `GONIO_DUMP_DIR` with their drawn scene, for a look with `gonio detect --raw
/// --dump-stages`.
#[test]
#[ignore = "a tool: run on purpose with GONIO_DUMP=3,17"]
fn dump_frames() {
    let optics = Optics::default();
    let dir = std::env::var("GONIO_DUMP_DIR").unwrap_or_else(|_| "/tmp".into());
    let list = std::env::var("GONIO_DUMP").unwrap_or_default();
    for k in list.split(',').filter_map(|s| s.trim().parse::<u64>().ok()) {
        let turn = Turn {
            drawn_pose: true,
            ..Turn::default()
        };
        let mut src = RenderedFrames::new(
            &optics,
            SceneChoice::Random(Box::default()),
            turn,
            k + 1,
            RUN_SEED,
        )
        .unwrap()
        .frames(k, k + 1);
        let mut buf = Vec::new();
        use gonio_vision::FrameSource;
        src.next_frame(&mut buf).unwrap().unwrap();
        std::fs::write(format!("{dir}/scene_{k}.raw"), &buf).unwrap();
        std::fs::write(
            format!("{dir}/scene_{k}.txt"),
            format!(
                "{:#?}\n{:#?}",
                src.last_draw().unwrap(),
                src.last_truth().unwrap()
            ),
        )
        .unwrap();
    }
}

/// Prints the selection's tracks and candidates for the raw frames listed in `GONIO_EXPLAIN`
/// (paths of 1440×540 raw files, comma-separated), through the reference stages.
#[test]
#[ignore = "a tool: run on purpose with GONIO_EXPLAIN=/tmp/scene_3.raw"]
fn explain_frames() {
    use gonio_vision::reference::{self, Image};
    let optics = Optics::default();
    let p = optics.params().unwrap();
    let list = std::env::var("GONIO_EXPLAIN").unwrap_or_default();
    for path in list.split(',').filter(|s| !s.is_empty()) {
        let f = std::fs::read(path).unwrap();
        let r = reference::run(&Image::from_vec(p.width, p.height, f), &p);
        let cands: Vec<_> = r
            .components
            .iter()
            .copied()
            .filter(|c| c.is_candidate(p.min_fragment_rows))
            .collect();
        let mut el = reference::edge_list(&r.filled, &r.mag, &r.components, &r.labels, &p);
        let mut sat = Vec::new();
        for (y, row) in r.input.data.chunks_exact(p.width).enumerate() {
            gonio_vision::features::saturated_runs(row, y, &mut sat);
        }
        let sel = gonio_vision::select::select(&cands, &mut el, &sat, &p);
        eprintln!("{path}: {:?} {:?}", r.result.reason, r.result.c_px);
        let mut det = gonio_vision::Detector::new(&optics).unwrap();
        det.set_dump(true);
        let sr = det.detect(&r.input.data).unwrap();
        let d = det.dump().unwrap();
        eprintln!(
            "  streaming: {:?} {:?}; stages equal: filled {} components {}",
            sr.reason,
            sr.c_px,
            d.filled.class == r.filled.0.data && d.filled.sub == r.filled.2.data,
            {
                let mut c = d.components.clone();
                c.sort_by_key(|c| c.first_index);
                c == r.components
            }
        );
        for (i, t) in sel.tracks.iter().enumerate() {
            if t.coverage < 60 {
                continue;
            }
            eprintln!(
                "  track {i}: pol {:+} rows {:?} cov {} col@mid {:.1} rms {:.2} grad {:.0} strong {:.2}",
                t.polarity,
                t.rows,
                t.coverage,
                t.curve.at(270.0, p.height),
                t.curve.rms_px,
                t.gradient,
                t.strong_share
            );
        }
        if let Some(b) = &sel.best {
            let lr = b.fit.left_rows.iter().filter(|&&x| x).count();
            let rr = b.fit.right_rows.iter().filter(|&&x| x).count();
            eprintln!(
                "  best: tracks {} {} sep {:.2} shared {} score {:.3} c {:.3} rows kept {lr} {rr} \
                 px {} {} q {:.3e}",
                b.left,
                b.right,
                b.separation_px,
                b.shared_rows,
                b.score,
                b.c_px,
                b.fit.left.pos_n,
                b.fit.right.pos_n,
                b.fit.q
            );
            let rows: Vec<usize> = (0..p.height).filter(|&y| !b.fit.right_rows[y]).collect();
            eprintln!(
                "  right rows dropped: {} … {:?}",
                rows.len(),
                &rows[..rows.len().min(40)]
            );
            let rows: Vec<usize> = (0..p.height).filter(|&y| !b.fit.left_rows[y]).collect();
            eprintln!(
                "  left rows dropped: {} … {:?}",
                rows.len(),
                &rows[..rows.len().min(40)]
            );
        }
        eprintln!("  margin {:?}", sel.margin);
    }
}
