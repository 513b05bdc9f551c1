//! The detector's golden PNGs (here, beside the renderer that draws the inputs: gonio-vision
//! cannot dev-depend on gonio-sim, which depends on it): small frames and their stage outputs, checked bit for bit. Regenerate on purpose
//! with `GONIO_REGENERATE_GOLDEN=1 cargo test -p gonio-sim --test vision_golden` (never silently).

use gonio_vision::{Detector, InvalidReason, Optics};
use std::path::{Path, PathBuf};

fn dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/vision_golden")
}

fn small_optics() -> Optics {
    Optics {
        window_width_px: 480,
        window_height_px: 96,
        ..Optics::default()
    }
}

fn load(p: &Path) -> (u32, u32, Vec<u8>) {
    let img = image::open(p).unwrap_or_else(|e| {
        panic!(
            "{}: {e} (regenerate with GONIO_REGENERATE_GOLDEN=1)",
            p.display()
        )
    });
    let g = img.into_luma8();
    (g.width(), g.height(), g.into_raw())
}

fn save(p: &Path, w: u32, h: u32, data: Vec<u8>) {
    image::GrayImage::from_raw(w, h, data)
        .unwrap()
        .save(p)
        .unwrap();
}

/// Three small rendered frames: a ring with blur and noise, a slanted one, and one without.
fn render_inputs() {
    use gonio_sim::frames::{GratingRenderer, GratingScene};
    let o = small_optics();
    let cases = [
        (10.0, 20.0, true, 0.0),
        (95.0, 300.0, true, 15.0),
        (40.0, 10.0, false, 0.0),
    ];
    for (i, (th, e, ring, z)) in cases.into_iter().enumerate() {
        let scene = GratingScene {
            ring_present: ring,
            ..GratingScene::default()
        };
        let r = GratingRenderer::new(&o, scene).unwrap();
        let mut f = vec![0u8; r.frame_len()];
        r.render(th, e, 0.0, z, 40 + i as u64, &mut f).unwrap();
        save(&dir().join(format!("frame{i}_input.png")), 480, 96, f);
    }
}

#[test]
fn golden_stage_outputs() {
    let regen = std::env::var_os("GONIO_REGENERATE_GOLDEN").is_some();
    if regen {
        std::fs::create_dir_all(dir()).unwrap();
        render_inputs();
    }
    let o = small_optics();
    let mut det = Detector::new(&o).unwrap();
    det.set_dump(true);
    let mut summary = String::new();
    for i in 0..3 {
        let (w, h, f) = load(&dir().join(format!("frame{i}_input.png")));
        assert_eq!((w, h), (480, 96));
        let res = det.detect(&f).unwrap();
        let d = det.dump().unwrap();
        let class_img: Vec<u8> = d.filled.class.iter().map(|&c| c * 127).collect();
        let stages = [
            ("tophat", d.tophat.clone()),
            ("blurred", d.blurred.clone()),
            ("edges", class_img),
        ];
        for (name, data) in stages {
            let p = dir().join(format!("frame{i}_{name}.png"));
            if regen {
                save(&p, w, h, data);
            } else {
                let (_, _, want) = load(&p);
                assert!(
                    want == data,
                    "{}: stage output differs from the golden file",
                    p.display()
                );
            }
        }
        summary.push_str(&format!(
            "frame{i} valid={} reason={:?} c_px={:?}\n",
            res.valid, res.reason, res.c_px
        ));
        if i < 2 {
            assert!(res.valid, "frame{i}: {:?}", res.reason);
        } else {
            assert_eq!(res.reason, Some(InvalidReason::NoRing));
        }
    }
    let p = dir().join("results.txt");
    if regen {
        std::fs::write(&p, &summary).unwrap();
    } else {
        assert_eq!(std::fs::read_to_string(&p).unwrap(), summary);
    }
}

#[test]
fn one_edge_when_the_other_side_fades_out() {
    // A sharp dark→bright step on the left of a dark band whose right side only ramps back up
    // slowly (a gradient below the low threshold).
    let o = small_optics();
    let (w, h) = (480usize, 96usize);
    let mut f = vec![0u8; w * h];
    for y in 0..h {
        for x in 0..w {
            let v = if x < 70 {
                190.0
            } else if x < 81 {
                60.0
            } else {
                (60.0 + (x - 81) as f64 * 1.5).min(190.0)
            };
            f[y * w + x] = v as u8;
        }
    }
    let res = Detector::new(&o).unwrap().detect(&f).unwrap();
    assert_eq!(res.reason, Some(InvalidReason::OneEdge), "{res:?}");
}
