//! Criterion benchmarks: the whole detector on rendered 1440×540 frames, each stage alone
//! (the per-stage split), and the renderer.

use criterion::{Criterion, criterion_group, criterion_main};
use gonio_sim::frames::{GratingRenderer, GratingScene, ScenePreset};
use gonio_vision::fill::EdgeFill;
use gonio_vision::gaussian::Gaussian5;
use gonio_vision::gradient::{GradRow, Sobel};
use gonio_vision::label::Labeller;
use gonio_vision::morphology::{BlackTopHat, Disk, Opening};
use gonio_vision::segment::{EdgeRow, SegmentParams, Segmenter};
use gonio_vision::{Detector, Optics};
use std::hint::black_box;

fn frame() -> (Optics, Vec<u8>) {
    let optics = Optics::default();
    let r = GratingRenderer::new(&optics, GratingScene::default()).unwrap();
    let mut f = vec![0u8; r.frame_len()];
    r.render(33.0, 150.0, 20.0, 0.0, 1, &mut f).unwrap();
    (optics, f)
}

fn bench(c: &mut Criterion) {
    let (optics, f) = frame();
    let p = optics.params().unwrap();
    let w = p.width;
    let mut det = Detector::new(&optics).unwrap();
    c.bench_function("detector 1440x540", |b| {
        b.iter(|| det.detect(black_box(&f)).unwrap())
    });
    // The dense scene: track-border groups, incremental lines and code bars close to the ring,
    // 150 dust specks, a scratch, noise 5: several hundred components a frame.
    let dense = {
        let r = GratingRenderer::new(&optics, GratingScene::preset(ScenePreset::Dense)).unwrap();
        let mut f = vec![0u8; r.frame_len()];
        r.render(33.0, 150.0, 20.0, 0.0, 1, &mut f).unwrap();
        f
    };
    let r = det.detect(&dense).unwrap();
    assert!(r.valid, "dense scene: {:?}", r.reason);
    eprintln!("dense scene: {} components", r.components);
    c.bench_function("detector 1440x540 dense", |b| {
        b.iter(|| det.detect(black_box(&dense)).unwrap())
    });

    // Stage inputs from a dump.
    det.set_dump(true);
    det.detect(&f).unwrap();
    let d = det.dump().unwrap().clone();
    let rows = |v: &Vec<u8>| v.chunks_exact(w).map(|r| r.to_vec()).collect::<Vec<_>>();

    let mut g = c.benchmark_group("stage");
    let mut out = vec![0u8; w];
    let mut th = BlackTopHat::new(w, Disk::new(p.close_radius_px));
    g.bench_function("black top-hat 23x23", |b| {
        b.iter(|| {
            th.reset();
            for r in f.chunks_exact(w) {
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
    let grads: Vec<GradRow> = (0..p.height)
        .map(|y| GradRow {
            gx: d.gx[y * w..(y + 1) * w].to_vec(),
            gy: d.gy[y * w..(y + 1) * w].to_vec(),
            mag: d.mag[y * w..(y + 1) * w].to_vec(),
        })
        .collect();
    let sp = SegmentParams {
        low: p.grad_low,
        high: p.grad_high,
        tan_q10: p.tan_tolerance_q10,
    };
    let mut se = Segmenter::new(w, sp);
    let mut er = EdgeRow::new(w);
    g.bench_function("nms + thresholds + baseline filter", |b| {
        b.iter(|| {
            se.reset();
            for r in &grads {
                se.push_row(r, &mut er);
            }
            while se.flush_row(&mut er) {}
        })
    });
    let edge_rows = |e: &gonio_vision::pipeline::EdgeRowsImage| {
        (0..p.height)
            .map(|y| EdgeRow {
                class: e.class[y * w..(y + 1) * w].to_vec(),
                dir: e.dir[y * w..(y + 1) * w].to_vec(),
                sub: e.sub[y * w..(y + 1) * w].to_vec(),
                mag: e.mag[y * w..(y + 1) * w].to_vec(),
            })
            .collect::<Vec<_>>()
    };
    let edges = edge_rows(&d.edges);
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
    let filled = edge_rows(&d.filled);
    let mut la = Labeller::new(w, p.height, false).min_rows(p.min_fragment_rows);
    g.bench_function("labelling + features", |b| {
        b.iter(|| {
            la.reset();
            for r in &filled {
                la.push_row(r);
            }
            la.finish();
            black_box(la.candidates().len())
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

criterion_group!(benches, bench);
criterion_main!(benches);
