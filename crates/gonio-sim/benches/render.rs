//! Criterion benchmark: rendering one 1440×540 grating frame (rows on the rayon pool; set
//! `RAYON_NUM_THREADS=1` for one core).

use criterion::{Criterion, criterion_group, criterion_main};
use gonio_sim::frames::{GratingRenderer, GratingScene};
use gonio_vision::Optics;

fn bench(c: &mut Criterion) {
    let optics = Optics::default();
    for (name, scene) in [
        ("render 1440x540", GratingScene::default()),
        (
            "render 1440x540, no code tracks",
            GratingScene {
                code_tracks: false,
                ..GratingScene::default()
            },
        ),
        (
            "render 1440x540, no ring, no tracks, no dust",
            GratingScene {
                code_tracks: false,
                ring_present: false,
                dust_per_frame: 0,
                ..GratingScene::default()
            },
        ),
    ] {
        one(c, name, &optics, scene);
    }
}

fn one(c: &mut Criterion, name: &str, optics: &Optics, scene: GratingScene) {
    let r = GratingRenderer::new(optics, scene).unwrap();
    let mut buf = vec![0u8; r.frame_len()];
    let mut k = 0u64;
    c.bench_function(name, |b| {
        b.iter(|| {
            k += 1;
            r.render(k as f64 * 1.8, 150.0, 20.0, 0.0, k, &mut buf)
                .unwrap()
        })
    });
}

criterion_group!(benches, bench);
criterion_main!(benches);
