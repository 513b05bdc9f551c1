//! The example recipes parse, and a bad key names its line.

use gonio_station::{Recipe, StationError};

fn example(name: &str) -> String {
    let p = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../examples/recipes")
        .join(name);
    std::fs::read_to_string(p).unwrap()
}

#[test]
fn standard_recipe_is_the_default() {
    let r = Recipe::from_toml(&example("r40-standard.toml")).unwrap();
    assert_eq!(
        Recipe {
            name: "default".into(),
            ..r
        },
        Recipe::default()
    );
}

#[test]
fn published_sequence_recipe_is_recipe_published() {
    let r = Recipe::from_toml(&example("published-sequence.toml")).unwrap();
    assert_eq!(r, Recipe::published());
    assert_eq!(r.frames_per_turn(), 200);
}

#[test]
fn fine_recipe_parses() {
    let r = Recipe::from_toml(&example("r25-fine.toml")).unwrap();
    // 3 s at 120°/s and 100 fps; from rest, the 0.133 s ramp covers 8° in 13 frames.
    assert_eq!(r.frames_per_turn(), 307);
    assert_eq!(r.push.max_pushes, 6);
    assert_eq!(r.threshold_um, 3.0);
}

#[test]
fn unknown_key_and_bad_values_are_errors() {
    let text = example("r25-fine.toml").replace("max_pushes = 6", "max_pushes = 6\nmaxpushes = 7");
    match Recipe::from_toml(&text).unwrap_err() {
        StationError::Recipe { line, message, .. } => {
            assert_eq!(line, 13, "{message}");
            assert!(message.contains("maxpushes"));
        }
        e => panic!("{e:?}"),
    }
    assert!(Recipe::from_toml("um_per_px = -1.0").is_err());
    assert!(Recipe::from_toml("[focus]\nsteps = 2").is_err());
    assert!(Recipe::from_toml("threshold_um = \"five\"").is_err());
}
