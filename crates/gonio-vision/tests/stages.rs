//! Every streaming stage against the whole-frame reference, bit for bit, and the labelling
//! against a flood fill on random binary images.

use gonio_vision::label::{Component, Labeller};
use gonio_vision::reference::{self, Image, edges_from_rows};
use gonio_vision::rows::RowStage;
use gonio_vision::segment::{EdgeRow, STRONG, WEAK};
use gonio_vision::{Detector, Optics, Polarity};
use proptest::prelude::*;
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

fn small_optics(w: u32, h: u32) -> Optics {
    Optics {
        window_width_px: w,
        window_height_px: h,
        ..Optics::default()
    }
}

/// A frame with a dark ring (slanted, curved), wide and thin dark bars, specks and noise.
fn synthetic(w: usize, h: usize, seed: u64) -> Vec<u8> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let c0 = rng.random_range(30.0..(w as f64 - 30.0));
    let slope = rng.random_range(-0.15..0.15);
    let curv = rng.random_range(-0.002..0.002);
    let mut f = vec![0u8; w * h];
    for y in 0..h {
        let yc = y as f64 - h as f64 / 2.0;
        let c = c0 + slope * yc + curv * yc * yc;
        for x in 0..w {
            let mut v = 190.0 + 0.05 * x as f64;
            let s = (x as f64 - c).abs();
            if s < 5.3 {
                v = 70.0;
            } else if s < 6.3 {
                v = 70.0 + 120.0 * (s - 5.3);
            }
            // Wide bars and thin lines well away from the ring.
            if (x as f64 - c).abs() > 25.0 {
                if (y / 40) % 2 == 0 && x % 90 < 35 {
                    v -= 90.0;
                }
                if y % 13 == 0 {
                    v -= 60.0;
                }
            }
            v += rng.random_range(-6.0..6.0);
            f[y * w + x] = v.clamp(0.0, 255.0) as u8;
        }
    }
    for _ in 0..6 {
        let (x, y) = (rng.random_range(2..w - 2), rng.random_range(2..h - 2));
        f[y * w + x] = 20;
        f[y * w + x + 1] = 30;
    }
    f
}

fn check_frame(optics: &Optics, frame: &[u8]) {
    let mut det = Detector::new(optics).unwrap();
    det.set_dump(true);
    let res = det.detect(frame).unwrap();
    let p = det.params().clone();
    let d = det.dump().unwrap();
    let r = reference::run(&Image::from_vec(p.width, p.height, frame.to_vec()), &p);
    assert_eq!(d.input, r.input.data, "input");
    assert_eq!(d.tophat, r.tophat.data, "top-hat");
    assert_eq!(d.opened, r.opened.data, "opening");
    assert_eq!(d.blurred, r.blurred.data, "blur");
    assert_eq!(d.gx, r.gx.data, "gx");
    assert_eq!(d.gy, r.gy.data, "gy");
    assert_eq!(d.mag, r.mag.data, "mag");
    assert_eq!(d.edges.class, r.edges.0.data, "edge class");
    assert_eq!(d.edges.dir, r.edges.1.data, "edge dir");
    assert_eq!(d.edges.sub, r.edges.2.data, "edge sub");
    let edge_mag: Vec<u16> = r
        .mag
        .data
        .iter()
        .zip(&r.edges.0.data)
        .zip(&r.edges.2.data)
        .map(|((&m, &c), &s)| {
            if c != 0 && s != gonio_vision::segment::FILLED {
                m
            } else {
                0
            }
        })
        .collect();
    assert_eq!(d.edges.mag, edge_mag, "edge magnitudes");
    assert_eq!(d.filled.class, r.filled.0.data, "filled class");
    assert_eq!(d.filled.dir, r.filled.1.data, "filled dir");
    assert_eq!(d.filled.sub, r.filled.2.data, "filled sub");
    let mut comps = d.components.clone();
    comps.sort_by_key(|c| c.first_index);
    assert_eq!(comps, r.components, "components");
    assert_eq!(res, r.result, "result");
}

#[test]
fn stages_equal_reference_on_synthetic_frames() {
    let mut valid = 0;
    for seed in 0..6 {
        let (w, h) = (160 + 7 * seed as usize, 96 + 3 * seed as usize);
        let o = small_optics(w as u32, h as u32);
        let f = synthetic(w, h, seed);
        check_frame(&o, &f);
        valid += Detector::new(&o).unwrap().detect(&f).unwrap().valid as usize;
    }
    // The frames hold a ring: the comparison must have covered real edges and components.
    assert!(valid >= 4, "only {valid} of 6 synthetic frames valid");
}

#[test]
fn stages_equal_reference_on_noise_and_bright_polarity() {
    let mut rng = ChaCha8Rng::seed_from_u64(9);
    for k in 0..4 {
        let (w, h) = (64 + k * 5, 48 + k * 3);
        let f: Vec<u8> = (0..w * h)
            .map(|_| {
                if rng.random_bool(0.5) {
                    rng.random()
                } else {
                    128
                }
            })
            .collect();
        let mut o = small_optics(w as u32, h as u32);
        o.ring_width_um = 6.0;
        o.grad_low = Some(10);
        o.grad_high = Some(60);
        if k % 2 == 1 {
            o.polarity = Polarity::Bright;
        }
        check_frame(&o, &f);
    }
}

#[test]
fn stages_equal_reference_with_other_disks() {
    // d = 4 (radius-4 closing, radius-1 opening) and d = 7.
    for (um, seed) in [(3.0, 21u64), (5.2, 22)] {
        let o = Optics {
            ring_width_um: um,
            ..small_optics(120, 80)
        };
        check_frame(&o, &synthetic(120, 80, seed));
    }
}

fn random_edges(w: usize, h: usize, density: f64, seed: u64) -> Vec<EdgeRow> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    (0..h)
        .map(|_| {
            let mut r = EdgeRow::new(w);
            for x in 0..w {
                if rng.random_bool(density) {
                    r.class[x] = if rng.random_bool(0.5) { STRONG } else { WEAK };
                    r.dir[x] = rng.random();
                    r.sub[x] = rng.random_range(-16..=16);
                    r.mag[x] = rng.random_range(1..2000);
                    if rng.random_bool(0.1) {
                        r.sub[x] = gonio_vision::segment::FILLED;
                        r.mag[x] = 0;
                    }
                }
            }
            r
        })
        .collect()
}

fn mags(rows: &[EdgeRow], w: usize) -> Image<u16> {
    Image::from_vec(
        w,
        rows.len(),
        rows.iter().flat_map(|r| r.mag.clone()).collect(),
    )
}

fn stream_label(rows: &[EdgeRow], w: usize) -> Vec<Component> {
    let mut l = Labeller::new(w, rows.len(), true);
    for r in rows {
        l.push_row(r);
    }
    l.finish();
    let mut all = l.all().to_vec();
    all.sort_by_key(|c| c.first_index);
    assert_eq!(l.component_count(), all.len());
    all
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(200))]
    #[test]
    fn labelling_equals_flood_fill(w in 1usize..40, h in 1usize..30, density in 0.05f64..0.7, seed in any::<u64>()) {
        let rows = random_edges(w, h, density, seed);
        let got = stream_label(&rows, w);
        let (want, _) = reference::label(&edges_from_rows(&rows, w), &mags(&rows, w));
        prop_assert_eq!(got, want);
    }
}

#[test]
fn labelling_handles_spirals_and_u_shapes() {
    // A U (merges late), an inverted U (splits), and a comb (many merges in one row).
    let pat = [
        "#...#..#####..#.#.#.#",
        "#...#..#...#..#.#.#.#",
        "#...#..#...#..#######",
        "#####..#...#.........",
        ".......#.###..#.#.#..",
        "#.#.#.##.#....#.#.#..",
        ".#.#.#...#....##.##..",
    ];
    let w = pat[0].len();
    let rows: Vec<EdgeRow> = pat
        .iter()
        .map(|s| {
            let mut r = EdgeRow::new(w);
            for (x, ch) in s.bytes().enumerate() {
                if ch == b'#' {
                    r.class[x] = STRONG;
                }
            }
            r
        })
        .collect();
    let got = stream_label(&rows, w);
    let (want, _) = reference::label(&edges_from_rows(&rows, w), &mags(&rows, w));
    assert_eq!(got, want);
    // U, inverted U (with its hook), comb, the zig-zag, and the pair at the bottom right.
    assert_eq!(got.len(), want.len());
    assert!(got.len() >= 4);
}

#[test]
fn scalar_and_avx2_paths_give_the_same_bits() {
    let (w, h) = (203usize, 101usize);
    let o = small_optics(w as u32, h as u32);
    let f = synthetic(w, h, 77);
    let run = |simd: bool| {
        gonio_vision::simd::set_enabled(simd);
        let mut det = Detector::new(&o).unwrap();
        det.set_dump(true);
        let r = det.detect(&f).unwrap();
        (r, det.dump().unwrap().clone())
    };
    let scalar = run(false);
    let fast = run(true);
    gonio_vision::simd::set_enabled(true);
    assert!(scalar.0.valid);
    assert_eq!(scalar, fast);
}

fn stream_morph<const MAX: bool>(img: &[u8], w: usize, r: usize) -> Vec<u8> {
    use gonio_vision::morphology::{Disk, Morph};
    stream_stage(&mut Morph::<MAX>::new(w, Disk::new(r)), img, w)
}

/// Every output row of one frame through a streaming stage (pushed, then flushed).
fn stream_stage<S: RowStage<In = [u8], Out = [u8]>>(m: &mut S, img: &[u8], w: usize) -> Vec<u8> {
    let mut out = vec![0u8; w];
    let mut got = Vec::new();
    for row in img.chunks_exact(w) {
        if m.push_row(row, &mut out) {
            got.extend_from_slice(&out);
        }
    }
    while m.flush_row(&mut out) {
        got.extend_from_slice(&out);
    }
    got
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(60))]
    /// The streaming black top-hat and opening (batched for radii ≥ 4, frames shorter than the
    /// lag included) equal the reference's on every code path (scalar, AVX2, AVX-512 without
    /// and with the VBMI register chain), frame after frame.
    #[test]
    fn tophat_and_opening_equal_reference(w in 1usize..300, h in 1usize..60, r in 0usize..13, seed in any::<u64>()) {
        use gonio_vision::morphology::{BlackTopHat, Disk, Opening};
        use gonio_vision::reference::{Image, black_tophat, opening};
        use rand::{RngExt, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        let img: Vec<u8> = (0..w * h).map(|_| rng.random::<u8>()).collect();
        let im = Image::from_vec(w, h, img.clone());
        let want_t = black_tophat(&im, &Disk::new(r)).data;
        let want_o = opening(&im, &Disk::new(r)).data;
        use gonio_vision::simd::{Level, set_level, set_vbmi};
        for (level, vbmi) in [
            (Level::Scalar, false),
            (Level::Avx2, false),
            (Level::Avx512, false),
            (Level::Avx512, true),
        ] {
            set_level(level);
            set_vbmi(vbmi);
            let t = stream_stage(&mut BlackTopHat::new(w, Disk::new(r)), &img, w);
            let o = stream_stage(&mut Opening::new(w, Disk::new(r)), &img, w);
            // A second frame through the same stage (its state reset by `reset`).
            let mut again = BlackTopHat::new(w, Disk::new(r));
            let _ = stream_stage(&mut again, &img, w);
            RowStage::reset(&mut again);
            let t2 = stream_stage(&mut again, &img, w);
            set_level(Level::Avx512);
            set_vbmi(true);
            prop_assert_eq!(&t, &want_t);
            prop_assert_eq!(&t2, &want_t);
            prop_assert_eq!(&o, &want_o);
        }
    }
}

/// The last stage of a test cascade: keeps every row it is given.
struct Collect {
    row: Vec<u8>,
    rows: Vec<u8>,
}

impl gonio_vision::rows::RowSink for Collect {
    type Row = [u8];
    fn input(&mut self) -> &mut [u8] {
        &mut self.row
    }
    fn pushed<O: gonio_vision::rows::StageObserver + ?Sized>(&mut self, _: &mut O) {
        self.rows.extend_from_slice(&self.row);
    }
    fn finish<O: gonio_vision::rows::StageObserver + ?Sized>(&mut self, _: &mut O) {}
    fn reset(&mut self) {
        self.rows.clear();
    }
    fn lag(&self) -> usize {
        0
    }
}

/// The top-hat's and the opening's rows as a cascade shows them.
#[derive(Default)]
struct Seen {
    tophat: Vec<u8>,
    opened: Vec<u8>,
}

impl gonio_vision::rows::StageObserver for Seen {
    fn tophat(&mut self, row: &[u8]) {
        self.tophat.extend_from_slice(row);
    }
    fn opened(&mut self, row: &[u8]) {
        self.opened.extend_from_slice(row);
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(40))]
    /// A cascade top-hat → opening → Gaussian, where the register chain writes its batches
    /// straight into the next stage's ring (`RowStage::input_block`): every stage's rows equal
    /// the reference's, with and without the chain, frame after frame (several batches, frames
    /// shorter than the lag, the frame's last batch shorter than the others).
    #[test]
    fn cascade_hands_batches_over_in_place(w in 1usize..300, h in 1usize..90, r in 0usize..13, r2 in 0usize..5, seed in any::<u64>()) {
        use gonio_vision::gaussian::Gaussian5;
        use gonio_vision::morphology::{BlackTopHat, Disk, Opening};
        use gonio_vision::reference::{Image, black_tophat, gaussian5, opening};
        use gonio_vision::rows::{RowSink, Then};
        use gonio_vision::simd::{Level, set_level, set_vbmi};
        use rand::{RngExt, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        let img: Vec<u8> = (0..w * h).map(|_| rng.random::<u8>()).collect();
        let t = black_tophat(&Image::from_vec(w, h, img.clone()), &Disk::new(r));
        let o = opening(&t, &Disk::new(r2));
        let g = gaussian5(&o);
        for vbmi in [false, true] {
            set_level(Level::Avx512);
            set_vbmi(vbmi);
            let mut line = Then {
                stage: BlackTopHat::new(w, Disk::new(r)),
                next: Then {
                    stage: Opening::new(w, Disk::new(r2)),
                    next: Then {
                        stage: Gaussian5::new(w),
                        next: Collect { row: vec![0; w], rows: Vec::new() },
                    },
                },
            };
            set_vbmi(true);
            for frame in 0..2 {
                line.reset();
                let mut seen = Seen::default();
                for row in img.chunks_exact(w) {
                    line.input().copy_from_slice(row);
                    line.pushed(&mut seen);
                }
                line.finish(&mut seen);
                prop_assert_eq!(&seen.tophat, &t.data, "top-hat, frame {}", frame);
                prop_assert_eq!(&seen.opened, &o.data, "opening, frame {}", frame);
                prop_assert_eq!(&line.next.next.next.rows, &g.data, "blur, frame {}", frame);
            }
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(60))]
    /// Streaming dilation and erosion equal the reference for every radius (0 included), narrow
    /// rows and rows that end mid-block, on both code paths.
    #[test]
    fn morphology_equals_reference(w in 1usize..300, h in 1usize..40, r in 0usize..13, seed in any::<u64>()) {
        use gonio_vision::morphology::Disk;
        use gonio_vision::reference::{Image, dilate, erode};
        use rand::{RngExt, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        let img: Vec<u8> = (0..w * h).map(|_| rng.random::<u8>()).collect();
        let im = Image::from_vec(w, h, img.clone());
        let want_d = dilate(&im, &Disk::new(r)).data;
        let want_e = erode(&im, &Disk::new(r)).data;
        for simd in [false, true] {
            gonio_vision::simd::set_enabled(simd);
            let (d, e) = (stream_morph::<true>(&img, w, r), stream_morph::<false>(&img, w, r));
            gonio_vision::simd::set_enabled(true);
            prop_assert_eq!(&d, &want_d);
            prop_assert_eq!(&e, &want_e);
        }
    }
}

#[test]
fn stages_equal_reference_with_a_wide_direction_range() {
    // A 40° baseline filter: the segmentation's general row pass (every quantised direction,
    // neighbours above and below), not only the 0° sector a tolerance under 22.5° allows.
    for (k, seed) in [41u64, 42].into_iter().enumerate() {
        let (w, h) = (150 + 9 * k, 90);
        let mut o = small_optics(w as u32, h as u32);
        o.direction_tolerance_deg = Some(40.0);
        o.grad_low = Some(8);
        check_frame(&o, &synthetic(w, h, seed));
    }
}
