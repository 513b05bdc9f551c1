//! Criterion benchmarks: the whole detector on rendered 1440×540 frames (the default scene and
//! the dense one, one frame repeated and 32 new frames in turn), the tracked detector beside the
//! whole one on consecutive frames of a realistic turn, each stage alone on the dense frame (the
//! per-stage split), and the renderer.
//!
//! `GONIO_BENCH_ON_CPU=1` measures the benchmark thread's on-CPU time instead of wall time
//! (for a machine shared with other work; see `bench/criterion_on_cpu.rs`).

#[path = "../../../bench/criterion_on_cpu.rs"]
mod on_cpu;

use criterion::measurement::{Measurement, WallTime};
use criterion::{BatchSize, Criterion};
use gonio_sim::frames::{GratingRenderer, GratingScene, ScenePreset};
use gonio_vision::blur_sobel::BlurSobel;
use gonio_vision::features::{RawStats, baseline_features};
use gonio_vision::fill::EdgeFill;
use gonio_vision::gaussian::Gaussian5;
use gonio_vision::gradient::{GradRow, Sobel};
use gonio_vision::label::{EdgePixel, Labeller};
use gonio_vision::morphology::{BlackTopHat, Disk, Opening};
use gonio_vision::pipeline::EdgeRowsImage;
use gonio_vision::rows::RowStage;
use gonio_vision::segment::{EdgeRow, STRONG, SegmentParams, Segmenter, SparseEdgeRow};
use gonio_vision::track::Tracker;
use gonio_vision::{Detector, Optics};
use std::cell::RefCell;
use std::hint::black_box;

fn render(optics: &Optics, scene: GratingScene) -> Vec<u8> {
    render_at(&GratingRenderer::new(optics, scene).unwrap(), 33.0, 1)
}

/// A frame of `r`'s scene at shaft angle `theta_deg`, noise and dust from `seed`.
fn render_at(r: &GratingRenderer, theta_deg: f64, seed: u64) -> Vec<u8> {
    let mut f = vec![0u8; r.frame_len()];
    r.render(theta_deg, 150.0, 20.0, 0.0, seed, &mut f).unwrap();
    f
}

/// Frames of the `dense` scene in turn ([`bench`]).
const NEW_FRAMES: usize = 32;
/// Consecutive frames of the realistic turn the tracked detector runs over ([`bench`]).
const TURN_FRAMES: usize = 64;

fn bench<M: Measurement + 'static>(c: &mut Criterion<M>) {
    let optics = Optics::default();
    let p = optics.params().unwrap();
    let w = p.width;
    let f = render(&optics, GratingScene::default());
    let mut det = Detector::new(&optics).unwrap();
    c.bench_function("detector 1440x540", |b| {
        b.iter(|| det.detect(black_box(&f)).unwrap())
    });
    // The dense scene: track-border groups, incremental lines and code bars close to the ring,
    // 150 dust specks, a scratch, noise 5: over a thousand components a frame.
    let dense = render(&optics, GratingScene::preset(ScenePreset::Dense));
    let r = det.detect(&dense).unwrap();
    assert!(r.valid, "dense scene: {:?}", r.reason);
    eprintln!("dense scene: {} components", r.components);
    c.bench_function("detector 1440x540 dense", |b| {
        b.iter(|| det.detect(black_box(&dense)).unwrap())
    });
    // A camera never repeats a frame, and one frame detected over and over lets the branch
    // predictor learn its data-dependent branches (a new component, an edge stepping a column,
    // a component ending): ≈ 0.1 ms a frame on the dense scene. So the same scene is also
    // detected over NEW_FRAMES frames at angles spread over a turn, each with its own noise
    // and dust, one after the other (25 MB of frames: each comes from memory, as a camera's
    // frame does).
    let renderer = GratingRenderer::new(&optics, GratingScene::preset(ScenePreset::Dense)).unwrap();
    let turn: Vec<Vec<u8>> = (0..NEW_FRAMES)
        .map(|k| {
            let theta = 33.0 + 360.0 * k as f64 / NEW_FRAMES as f64;
            render_at(&renderer, theta, k as u64 + 1)
        })
        .collect();
    for f in &turn {
        let r = det.detect(f).unwrap();
        assert!(r.valid, "dense scene, new frames: {:?}", r.reason);
    }
    let mut next = 0;
    c.bench_function("detector 1440x540 dense, new frames", |b| {
        b.iter(|| {
            next = (next + 1) % NEW_FRAMES;
            det.detect(black_box(&turn[next])).unwrap()
        })
    });

    // The tracked detector (`gonio_vision::track`) over consecutive frames of a realistic turn
    // (1.8° a frame, e = 150 µm), beside the whole detector on the same frames. Each frame is
    // first copied into the detector's buffer, outside the timing, as a source writes it there
    // (a camera's frame is copied out of the driver's buffer, a pipe's read into it): the
    // frame is then in the cache, as it is on the one path from a source to a result. Every
    // timed frame of the tracked benchmark is measured in the band: the tracker is primed on
    // the turn's first two frames, outside the timing, whenever the turn starts over.
    let renderer =
        GratingRenderer::new(&optics, GratingScene::preset(ScenePreset::Realistic)).unwrap();
    let realistic: Vec<Vec<u8>> = (0..TURN_FRAMES)
        .map(|k| render_at(&renderer, 33.0 + 1.8 * k as f64, k as u64 + 1))
        .collect();
    let mut next = 0;
    c.bench_function("detector 1440x540 realistic, new frames", |b| {
        b.iter_batched_ref(
            || {
                next = (next + 1) % TURN_FRAMES;
                realistic[next].clone()
            },
            |buf| det.detect(black_box(buf)).unwrap(),
            BatchSize::PerIteration,
        )
    });
    let buf = vec![0u8; realistic[0].len()];
    let state = RefCell::new((
        Tracker::new(&optics).unwrap(),
        Detector::new(&optics).unwrap(),
        TURN_FRAMES - 1,
        0usize,
        buf,
    ));
    c.bench_function("detector 1440x540 realistic, tracked", |b| {
        b.iter_batched(
            || {
                let (tracker, det, next, _, buf) = &mut *state.borrow_mut();
                *next += 1;
                if *next == TURN_FRAMES {
                    tracker.reset();
                    for (k, f) in realistic.iter().enumerate().take(2) {
                        tracker.detect(f, k as u64, det, None).unwrap();
                    }
                    *next = 2;
                }
                buf.copy_from_slice(&realistic[*next]);
                *next
            },
            |k| {
                let (tracker, det, _, whole, buf) = &mut *state.borrow_mut();
                let r = tracker.detect(black_box(buf), k as u64, det, None).unwrap();
                *whole += !r.tracked as usize;
                r
            },
            BatchSize::PerIteration,
        )
    });
    let (tracker, _, _, whole, _) = state.into_inner();
    assert_eq!(whole, 0, "every timed frame measured in the band");
    eprintln!(
        "tracked: {} frames in the band, {} whole",
        tracker.tracked_frames(),
        tracker.whole_frames()
    );

    // Stage inputs from a dump of the dense frame. Each stage runs alone, its input rows copied
    // in (in the detector a stage writes its rows straight into the next one's ring).
    det.set_dump(true);
    det.detect(&dense).unwrap();
    let d = det.dump().unwrap().clone();
    let rows = |v: &Vec<u8>| v.chunks_exact(w).map(|r| r.to_vec()).collect::<Vec<_>>();

    let mut g = c.benchmark_group("stage");
    let mut out = vec![0u8; w];
    let input = rows(&d.input);
    let mut th = BlackTopHat::new(w, Disk::new(p.close_radius_px));
    g.bench_function("black top-hat 23x23", |b| {
        b.iter(|| {
            th.reset();
            for r in &input {
                th.push_row(r, &mut out);
            }
            while th.flush_row(&mut out) {}
        })
    });
    let mut op = Opening::new(w, Disk::new(p.open_radius_px));
    let tophat = rows(&d.tophat);
    g.bench_function("opening 5x5", |b| {
        b.iter(|| {
            op.reset();
            for r in &tophat {
                op.push_row(r, &mut out);
            }
            while op.flush_row(&mut out) {}
        })
    });
    let mut ga = Gaussian5::new(w);
    let opened = rows(&d.opened);
    g.bench_function("gaussian 5x5", |b| {
        b.iter(|| {
            ga.reset();
            for r in &opened {
                ga.push_row(r, &mut out);
            }
            while ga.flush_row(&mut out) {}
        })
    });
    let mut so = Sobel::new(w);
    let blurred = rows(&d.blurred);
    let mut gr = GradRow::new(w);
    g.bench_function("sobel", |b| {
        b.iter(|| {
            so.reset();
            for r in &blurred {
                so.push_row(r, &mut gr);
            }
            while so.flush_row(&mut gr) {}
        })
    });
    // The detector's stage: the blur and the Sobel fused.
    let mut bs = BlurSobel::new(w);
    g.bench_function("gaussian 5x5 + sobel", |b| {
        b.iter(|| {
            bs.reset();
            for r in &opened {
                bs.push_row(r, &mut gr);
            }
            while bs.flush_row(&mut gr) {}
        })
    });
    let grads: Vec<GradRow> = (0..p.height)
        .map(|y| {
            let mut g = GradRow::new(w);
            g.gx.copy_from_slice(&d.gx[y * w..(y + 1) * w]);
            g.gy.copy_from_slice(&d.gy[y * w..(y + 1) * w]);
            g.mag.copy_from_slice(&d.mag[y * w..(y + 1) * w]);
            g
        })
        .collect();
    let sp = SegmentParams {
        low: p.grad_low,
        high: p.grad_high,
        tan_q10: p.tan_tolerance_q10,
    };
    let mut se = Segmenter::new(w, sp);
    let mut er = SparseEdgeRow::new(w);
    g.bench_function("nms + thresholds + baseline filter", |b| {
        b.iter(|| {
            se.reset();
            for r in &grads {
                se.push_row(r, &mut er);
            }
            while se.flush_row(&mut er) {}
        })
    });
    let sparse_rows = |e: &EdgeRowsImage| {
        (0..p.height)
            .map(|y| {
                let dense = EdgeRow {
                    class: e.class[y * w..(y + 1) * w].to_vec(),
                    dir: e.dir[y * w..(y + 1) * w].to_vec(),
                    sub: e.sub[y * w..(y + 1) * w].to_vec(),
                    mag: e.mag[y * w..(y + 1) * w].to_vec(),
                };
                let mut s = SparseEdgeRow::new(w);
                s.set_from(&dense, y);
                s
            })
            .collect::<Vec<_>>()
    };
    let edges = sparse_rows(&d.edges);
    let mut fi = EdgeFill::new(w);
    g.bench_function("edge filling", |b| {
        b.iter(|| {
            fi.reset();
            for r in &edges {
                fi.push_row(r, &mut er);
            }
            while fi.flush_row(&mut er) {}
        })
    });
    let filled = sparse_rows(&d.filled);
    let mut la = Labeller::new(w, p.height, false)
        .min_rows(p.min_fragment_rows)
        .keep_pixels(p.max_edge_pixels);
    // 32 straight vertical lines, one pixel a row each: the labeller's cost per pixel with
    // no branch ever mispredicted and no merge (the `dense` frame has ≈ 17,500 pixels, 98 % of
    // its runs one pixel long; this one 17,280).
    let lines: Vec<SparseEdgeRow> = (0..p.height)
        .map(|y| {
            let mut s = SparseEdgeRow::new(w);
            for k in 0..32u16 {
                s.push(EdgePixel {
                    row: y as u16,
                    col: 10 + k * 44,
                    class: STRONG,
                    dir: 0,
                    sub: 3,
                    mag: 100,
                    comp: 0,
                });
            }
            s
        })
        .collect();
    g.bench_function("labelling synthetic 32 lines", |b| {
        b.iter(|| black_box(label_frame(&mut la, &lines).candidates().len()))
    });
    g.bench_function("labelling", |b| {
        b.iter(|| black_box(label_frame(&mut la, &filled).candidates().len()))
    });
    g.bench_function("labelling + ring selection + features", |b| {
        b.iter(|| {
            let count = label_frame(&mut la, &filled).component_count();
            let (cands, edges) = la.candidates_and_edges();
            baseline_features(cands, count, edges, &[], RawStats::default(), &p)
        })
    });
    g.finish();

    let r = GratingRenderer::new(&optics, GratingScene::default()).unwrap();
    let mut buf = vec![0u8; r.frame_len()];
    let mut k = 0u64;
    c.bench_function("render 1440x540", |b| {
        b.iter(|| {
            k += 1;
            r.render(k as f64 * 1.8, 150.0, 20.0, 0.0, k, &mut buf)
                .unwrap()
        })
    });
}

/// Labels one frame's sparse rows with `la` (reset first); `la` holds the result.
fn label_frame<'a>(la: &'a mut Labeller, rows: &[SparseEdgeRow]) -> &'a mut Labeller {
    la.reset();
    for r in rows {
        la.push_sparse(r);
    }
    la.finish();
    la
}

fn main() {
    on_cpu::run(bench::<on_cpu::OnCpu>, bench::<WallTime>);
}
