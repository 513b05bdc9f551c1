//! Every code path (scalar, AVX2, AVX-512, as far as the CPU has them) gives the same bits at
//! every stage. One test in its own binary: the level is process-wide.

use gonio_vision::simd::{Level, set_level};
use gonio_vision::{Detector, Optics};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

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

#[test]
fn every_level_gives_the_same_bits() {
    for (w, h, tol) in [(203usize, 101usize, None), (331, 77, Some(40.0))] {
        let o = Optics {
            window_width_px: w as u32,
            window_height_px: h as u32,
            direction_tolerance_deg: tol,
            ..Optics::default()
        };
        let f = frame(w, h, w as u64);
        let mut runs = Vec::new();
        for want in [Level::Scalar, Level::Avx2, Level::Avx512] {
            let got = set_level(want);
            let mut det = Detector::new(&o).unwrap();
            det.set_dump(true);
            let r = det.detect(&f).unwrap();
            runs.push((got, r, det.dump().unwrap().clone()));
        }
        set_level(Level::Avx512);
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
}
