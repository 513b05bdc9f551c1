//! Every code path (scalar, AVX2, AVX-512 and its VBMI and VNNI kernels, as far as the CPU has
//! them) gives the same bits at every stage. One test in its own binary: the level is
//! process-wide. It prints which paths each comparison really ran (a level the CPU lacks runs
//! as the best one below it) and fails when the CPU offers a path it did not compare.

use gonio_vision::blur_sobel::BlurSobel;
use gonio_vision::fill::{EdgeFill, fill_pixel};
use gonio_vision::gradient::GradRow;
use gonio_vision::label::{EdgePixel, Labeller};
use gonio_vision::pipeline::StageImages;
use gonio_vision::reference::{self, Image};
use gonio_vision::rows::RowStage;
use gonio_vision::segment::{FILLED, NONE, STRONG, SegmentParams, Segmenter, SparseEdgeRow, WEAK};
use gonio_vision::simd::{self, Level, set_level, set_vbmi};
use gonio_vision::{Detector, Optics};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::collections::BTreeSet;

/// The paths (names of `simd::offered`) one comparison really ran.
type Ran = BTreeSet<&'static str>;

/// Asks for `want`, notes in `ran` the level really in use (and the VBMI kernels when `vbmi`
/// and they are on), and returns that level.
fn at(ran: &mut Ran, want: Level, vbmi: bool) -> Level {
    let got = set_level(want);
    let now = simd::in_use();
    ran.insert(now[0]);
    if vbmi && now.contains(&"vbmi") {
        ran.insert("vbmi");
    }
    got
}

/// The levels (`scalar`, `avx2`, `avx512`) the CPU offers that `ran` lacks.
fn levels_missing(ran: &Ran) -> Vec<&'static str> {
    simd::offered()
        .into_iter()
        .filter(|p| ["scalar", "avx2", "avx512"].contains(p) && !ran.contains(p))
        .collect()
}

/// A frame with a slanted dark band, bars and noise, on an odd width (rows end mid-vector).
fn frame(w: usize, h: usize, seed: u64) -> Vec<u8> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut f = vec![0u8; w * h];
    for y in 0..h {
        let c = w as f64 / 2.0 + 0.2 * (y as f64 - h as f64 / 2.0);
        for x in 0..w {
            let mut v = 180.0 - 0.1 * x as f64;
            if (x as f64 - c).abs() < 5.5 {
                v = 70.0;
            }
            if x % 97 < 30 && (y / 25) % 2 == 0 {
                v -= 80.0;
            }
            v += rng.random_range(-8.0..8.0);
            f[y * w + x] = v.clamp(0.0, 255.0) as u8;
        }
    }
    f
}

/// A random gradient value: mostly what a Sobel of 8-bit rows gives (|G| ≤ 1020 a component),
/// some at the ends of the i16 range.
fn gradient(rng: &mut ChaCha8Rng) -> i16 {
    match rng.random_range(0..10) {
        0 => [i16::MIN, -32767, 32767, -1, 0, 1][rng.random_range(0..6)],
        1 => rng.random(),
        _ => rng.random_range(-1020..=1020),
    }
}

/// The segmentation alone at every level (the AVX-512 row kernel: classification into mask
/// registers, the kept columns compressed, direction and sub-pixel offset in vector lanes):
/// rows of every width 1 … 70 and a few wide ones (every tail after the 64-column steps and
/// their 32-column halves, the border columns), rows where most halves keep nothing, random
/// and extreme gradients (i16::MIN, ±32767, magnitudes up to u16::MAX unrelated to the
/// components), tolerances in the horizontal kernel's range (≤ 22.5°) and
/// beyond (every sector); the rows out must be identical.
fn segmentation_rows_at_every_level() -> Ran {
    let mut ran = Ran::new();
    let mut rng = ChaCha8Rng::seed_from_u64(11);
    let mut kept = 0;
    for width in (1..=70).chain([127, 128, 129, 191, 192, 193, 1440]) {
        for tan_q10 in [339, 424, 859, 2047] {
            let params = SegmentParams {
                low: 40,
                high: 300,
                tan_q10,
            };
            let rows: Vec<GradRow> = (0..9)
                .map(|y| {
                    let mut g = GradRow::new(width);
                    for x in 0..width {
                        let (gx, gy) = (gradient(&mut rng), gradient(&mut rng));
                        g.gx[x] = gx;
                        g.gy[x] = gy;
                        g.mag[x] = if rng.random_range(0..8) == 0 {
                            rng.random()
                        } else {
                            gx.unsigned_abs().saturating_add(gy.unsigned_abs())
                        };
                        // Rows 3 and 4: below the low threshold but in a few runs of columns
                        // (most 64-column words keep nothing or a few pixels). Row 7: one
                        // diagonal gradient above zero rows 6 and 8, so at 63° every column is
                        // kept (full words of kept columns).
                        if (3..5).contains(&y) && (x / 7) % 9 != 0 {
                            g.mag[x] %= params.low;
                        }
                        if y == 6 || y == 8 {
                            g.mag[x] = 0;
                        }
                        if y == 7 {
                            (g.gx[x], g.gy[x], g.mag[x]) = (100, 100, 200);
                        }
                    }
                    g
                })
                .collect();
            let mut outs = Vec::new();
            for want in [Level::Scalar, Level::Avx2, Level::Avx512] {
                let got = at(&mut ran, want, true);
                let mut se = Segmenter::new(width, params);
                let mut er = SparseEdgeRow::new(width);
                let mut out = Vec::new();
                for r in &rows {
                    if se.push_row(r, &mut er) {
                        out.push(er.clone());
                    }
                }
                while se.flush_row(&mut er) {
                    out.push(er.clone());
                }
                outs.push((got, out));
            }
            set_level(Level::Avx512);
            let (_, o0) = &outs[0];
            assert_eq!(o0.len(), rows.len());
            kept += o0.iter().map(|r| r.pixels.len()).sum::<usize>();
            for (l, o) in &outs[1..] {
                assert_eq!(o, o0, "{l:?}, width {width}, tan_q10 {tan_q10}");
            }
        }
    }
    assert!(kept > 10_000, "only {kept} edge pixels compared");
    ran
}

/// The edge filling with and without its AVX-512 row scan (eight words of edge bits at once)
/// against [`fill_pixel`], the definition: rows of every width 1 … 70 and a few wide ones
/// (every tail of the 8-word steps, pairs across word boundaries, the border columns), edge
/// densities from sparse to nearly full, random directions (so some pairs are 45° or more
/// apart and the next pair decides).
fn filling_rows_with_and_without_avx512() -> Ran {
    let mut ran = Ran::new();
    let mut rng = ChaCha8Rng::seed_from_u64(12);
    let mut filled = 0;
    for width in (1..=70).chain([127, 128, 129, 511, 512, 513, 1440]) {
        for density in [2, 5, 12] {
            let h = 7;
            let mut class = vec![vec![NONE; width]; h];
            let mut dir = vec![vec![0u8; width]; h];
            let rows: Vec<SparseEdgeRow> = (0..h)
                .map(|y| {
                    let mut r = SparseEdgeRow::new(width);
                    for x in 0..width {
                        if rng.random_range(0..16) < density {
                            let (c, d) = ([WEAK, STRONG][rng.random_range(0..2)], rng.random());
                            class[y][x] = c;
                            dir[y][x] = d;
                            r.push(EdgePixel {
                                row: y as u16,
                                col: x as u16,
                                class: c,
                                dir: d,
                                sub: rng.random_range(-16..=16),
                                mag: rng.random(),
                                comp: 0,
                            });
                        }
                    }
                    r
                })
                .collect();
            // The definition: each row's pixels and the filled ones, by column.
            let at = |y: usize, x: usize, dy: usize, dx: usize, v: &Vec<Vec<u8>>| {
                let (yy, xx) = ((y + dy).wrapping_sub(1), (x + dx).wrapping_sub(1));
                if yy < h && xx < width { v[yy][xx] } else { 0 }
            };
            let want: Vec<Vec<EdgePixel>> = (0..h)
                .map(|y| {
                    let mut p = Vec::new();
                    let mut own = rows[y].pixels.iter().peekable();
                    for x in 0..width {
                        if let Some(q) = own.next_if(|q| q.col as usize == x) {
                            p.push(*q);
                            continue;
                        }
                        let c = std::array::from_fn(|dy| {
                            std::array::from_fn(|dx| at(y, x, dy, dx, &class))
                        });
                        let d = std::array::from_fn(|dy| {
                            std::array::from_fn(|dx| at(y, x, dy, dx, &dir))
                        });
                        if let Some((c, d, s)) = fill_pixel(&c, &d) {
                            assert_eq!(s, FILLED);
                            filled += 1;
                            p.push(EdgePixel {
                                row: y as u16,
                                col: x as u16,
                                class: c,
                                dir: d,
                                sub: s,
                                mag: 0,
                                comp: 0,
                            });
                        }
                    }
                    p
                })
                .collect();
            for vbmi in [false, true] {
                set_vbmi(vbmi);
                ran.insert(if simd::vbmi() { "vbmi" } else { "without vbmi" });
                let mut fi = EdgeFill::new(width);
                let mut out = SparseEdgeRow::new(width);
                let mut got = Vec::new();
                for r in &rows {
                    if fi.push_row(r, &mut out) {
                        got.push(out.clone());
                    }
                }
                while fi.flush_row(&mut out) {
                    got.push(out.clone());
                }
                assert_eq!(got.len(), h);
                for (y, g) in got.iter().enumerate() {
                    assert_eq!(g.pixels, want[y], "vbmi {vbmi}, width {width}, row {y}");
                    let mut bits = SparseEdgeRow::new(width);
                    for p in &want[y] {
                        bits.push(*p);
                    }
                    assert_eq!(g.bits, bits.bits, "vbmi {vbmi}, width {width}, row {y}");
                }
            }
            set_vbmi(true);
        }
    }
    assert!(filled > 5_000, "only {filled} filled pixels compared");
    ran
}

/// The blur and the Sobel as one stage (the AVX-512 kernel: vertical sums, lane shifts for the
/// horizontal taps, the Sobel from the blurred row in registers) at every level against the
/// whole-frame reference: every width 2 … 70 and a few wide ones (every tail after the
/// 32-column steps, the replicated border columns inside and across a vector), heights 1 … 6
/// (the flush with fewer rows than the lags) and taller, random bytes and the extremes (0 and
/// 255 alternating, all 255: the largest sums, ±1020 gradients). Each stage object is reused
/// for a second frame (the reset).
fn blur_sobel_at_every_level() -> Ran {
    let mut ran = Ran::new();
    let mut rng = ChaCha8Rng::seed_from_u64(5);
    for width in (2..=70).chain([95, 96, 97, 127, 128, 129, 1440]) {
        for height in [1, 2, 3, 4, 5, 6, 11] {
            let frames: Vec<Vec<u8>> = (0..3)
                .map(|kind| {
                    (0..width * height)
                        .map(|i| match kind {
                            0 => rng.random(),
                            1 => [0, 255][(i % width + i / width + (i / 7) % 2) % 2],
                            _ if i % 5 == 0 && rng.random() => 0,
                            _ => 255,
                        })
                        .collect()
                })
                .collect();
            for level in [Level::Scalar, Level::Avx2, Level::Avx512] {
                let level = at(&mut ran, level, false);
                let mut stage = BlurSobel::new(width);
                let mut g = GradRow::new(width);
                for f in &frames {
                    let mut obs = StageImages::default();
                    stage.reset();
                    for row in f.chunks_exact(width) {
                        stage.input().copy_from_slice(row);
                        stage.pushed(&mut g, &mut obs);
                    }
                    while stage.flushed(&mut g, &mut obs) {}
                    let b = reference::gaussian5(&Image::from_vec(width, height, f.clone()));
                    let (gx, gy, mag) = reference::sobel(&b);
                    let at = format!("{level:?}, {width}×{height}");
                    assert_eq!(obs.blurred, b.data, "blurred rows, {at}");
                    assert_eq!(obs.gx, gx.data, "gx, {at}");
                    assert_eq!(obs.gy, gy.data, "gy, {at}");
                    assert_eq!(obs.mag, mag.data, "|G|, {at}");
                }
            }
        }
    }
    set_level(Level::Avx512);
    ran
}

/// The labeller at every level (AVX-512: its kept edge pixels written four at a time by
/// `vpcompressq`) against the scalar level: every component's sums and the edge list, on rows
/// of every width 1 … 70 and a few wide ones (every tail of the four-pixel steps), sparse to
/// nearly full rows (runs of every length, merges), with filled pixels (not kept) among them.
/// One labeller per level is reused for every frame of a width (the reset).
fn labelling_at_every_level() -> Ran {
    let mut ran = Ran::new();
    let mut rng = ChaCha8Rng::seed_from_u64(21);
    let mut kept = 0;
    for width in (1..=70).chain([127, 128, 129, 1440]) {
        let h = 9;
        let mut labellers: Vec<Labeller> = (0..2)
            .map(|_| Labeller::new(width, h, true).keep_pixels(width * h))
            .collect();
        for density in [2, 8, 15] {
            let rows: Vec<SparseEdgeRow> = (0..h)
                .map(|y| {
                    let mut r = SparseEdgeRow::new(width);
                    for x in 0..width {
                        if rng.random_range(0..16) < density {
                            let filled = rng.random_range(0..5) == 0;
                            r.push(EdgePixel {
                                row: y as u16,
                                col: x as u16,
                                class: [WEAK, STRONG][rng.random_range(0..2)],
                                dir: rng.random(),
                                sub: if filled {
                                    FILLED
                                } else {
                                    rng.random_range(-16..=16)
                                },
                                mag: rng.random(),
                                comp: 0,
                            });
                        }
                    }
                    r
                })
                .collect();
            let mut got = Vec::new();
            for (l, level) in labellers.iter_mut().zip([Level::Scalar, Level::Avx512]) {
                at(&mut ran, level, false);
                l.reset();
                for r in &rows {
                    l.push_sparse(r);
                }
                l.finish();
                let all = l.all().to_vec();
                let pixels = l.edge_list().and_then(|e| e.pixels().map(|p| p.to_vec()));
                got.push((all, pixels));
            }
            set_level(Level::Avx512);
            let want = rows
                .iter()
                .flat_map(|r| &r.pixels)
                .filter(|p| p.sub != FILLED)
                .count();
            let pixels = got[0].1.as_ref().expect("complete edge list");
            assert_eq!(pixels.len(), want, "width {width}: kept pixels");
            kept += want;
            assert_eq!(got[1], got[0], "width {width}, density {density}");
        }
    }
    assert!(kept > 10_000, "only {kept} kept pixels compared");
    ran
}

#[test]
fn every_level_gives_the_same_bits() {
    // One test function: the level is process-wide, tests run in parallel threads.
    let offered = simd::offered();
    println!("this CPU offers the paths {offered:?}");
    let segmentation = segmentation_rows_at_every_level();
    let filling = filling_rows_with_and_without_avx512();
    let blur_sobel = blur_sobel_at_every_level();
    let labelling = labelling_at_every_level();
    let mut detector = Ran::new();
    for (w, h, tol) in [(203usize, 101usize, None), (331, 77, Some(40.0))] {
        let o = Optics {
            window_width_px: w as u32,
            window_height_px: h as u32,
            direction_tolerance_deg: tol,
            ..Optics::default()
        };
        let f = frame(w, h, w as u64);
        let mut runs = Vec::new();
        // AVX-512 twice: without and with the VBMI kernels (the morphology's register chain).
        for (want, vbmi) in [
            (Level::Scalar, false),
            (Level::Avx2, false),
            (Level::Avx512, false),
            (Level::Avx512, true),
        ] {
            let got = set_level(want);
            set_vbmi(vbmi);
            detector.extend(simd::in_use());
            let mut det = Detector::new(&o).unwrap();
            det.set_dump(true);
            let r = det.detect(&f).unwrap();
            runs.push(((got, vbmi), r, det.dump().unwrap().clone()));
        }
        set_level(Level::Avx512);
        set_vbmi(true);
        let (_, r0, d0) = &runs[0];
        assert!(
            d0.filled.class.iter().any(|&c| c != 0),
            "no edges to compare"
        );
        for (l, r, d) in &runs[1..] {
            assert_eq!(r, r0, "{l:?} result");
            assert_eq!(d, d0, "{l:?} stage images");
        }
    }
    for (what, ran) in [
        ("segmentation", &segmentation),
        ("edge filling", &filling),
        ("blur and Sobel", &blur_sobel),
        ("labelling", &labelling),
        ("the whole detector", &detector),
    ] {
        println!("{what}: compared {ran:?}");
    }
    // Every level at every stage that has one, and every path the CPU offers in the whole
    // detector (whose focus sums take the VNNI kernel at the AVX-512 level).
    for (what, ran) in [
        ("segmentation", &segmentation),
        ("blur and Sobel", &blur_sobel),
        ("the whole detector", &detector),
    ] {
        let missing = levels_missing(ran);
        assert!(
            missing.is_empty(),
            "{what}: the CPU offers {missing:?}, not compared"
        );
    }
    let missing: Vec<&str> = offered
        .iter()
        .filter(|p| !detector.contains(*p))
        .copied()
        .collect();
    assert!(
        missing.is_empty(),
        "the CPU offers {missing:?}, which the detector comparison did not run"
    );
    if offered.contains(&"avx512") {
        assert!(
            labelling.contains("avx512"),
            "labelling: AVX-512 offered, not compared"
        );
    }
    if offered.contains(&"vbmi") {
        assert!(
            filling.contains("vbmi"),
            "filling: VBMI offered, not compared"
        );
    }
}
