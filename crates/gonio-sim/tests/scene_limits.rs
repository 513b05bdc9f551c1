//! Bounded resources, checked before any frame: a scene whose features would cost seconds a
//! frame (dust specks the size of the window, thousands of scratches, billions of track-border
//! lines) is refused naming the feature; a recipe whose focus range overflows the twin's noise
//! model runs (its parts fail to focus) instead of panicking.

use gonio_sim::frames::{GratingRenderer, GratingScene, Scratch, TrackBorder};
use gonio_sim::station::batch::{BatchConfig, run_batch};
use gonio_vision::Optics;
use std::time::{Duration, Instant};

fn refused(scene: GratingScene, says: &str) {
    let t = Instant::now();
    let e = GratingRenderer::new(&Optics::default(), scene)
        .err()
        .unwrap_or_else(|| panic!("accepted: expected {says}"));
    assert!(e.to_string().contains(says), "{e}");
    assert!(t.elapsed() < Duration::from_secs(1), "{:?}", t.elapsed());
}

#[test]
fn scenes_that_would_take_seconds_a_frame_are_refused() {
    assert!(GratingRenderer::new(&Optics::default(), GratingScene::default()).is_ok());
    let line = TrackBorder {
        offset_px: 10.0,
        width_px: 1.0,
        count: 4_000_000_000,
        pitch_px: 3.0,
        depth_grey: None,
    };
    refused(
        GratingScene {
            track_borders: vec![line],
            ..GratingScene::default()
        },
        "track_borders.count",
    );
    refused(
        GratingScene {
            track_borders: vec![
                TrackBorder {
                    count: 5_000,
                    width_px: 10.0,
                    ..line
                };
                2
            ],
            ..GratingScene::default()
        },
        "track_borders",
    );
    refused(
        GratingScene {
            dust_per_frame: 10_000,
            dust_radius_px: [200.0, 200.0],
            ..GratingScene::default()
        },
        "dust_per_frame",
    );
    let scratch = Scratch {
        x_px: 100.0,
        y_px: 100.0,
        angle_deg: 10.0,
        width_px: 2000.0,
        depth_grey: 5.0,
        length_px: None,
    };
    refused(
        GratingScene {
            scratches: vec![scratch; 10_000],
            ..GratingScene::default()
        },
        "scratches",
    );
}

#[test]
fn a_focus_range_that_overflows_the_noise_model_does_not_panic_the_twin() {
    let mut cfg = BatchConfig {
        parts: 1,
        ..BatchConfig::default()
    };
    cfg.recipe.focus.range_um = 1e160;
    // Whatever the verdict, a result and no panic.
    let r = run_batch(&cfg, 3, &mut |_, _, _| {});
    if let Ok(r) = r {
        assert_eq!(r.parts.len(), 1);
    }
}
