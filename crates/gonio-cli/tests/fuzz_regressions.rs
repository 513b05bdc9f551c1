//! The CLI fuzz targets' kept corpora and every crash they found (`fuzz/corpus/<target>/`,
//! `fuzz/regressions/<target>/`), replayed through the same checks as the fuzzers
//! (`fuzz/checks/cli.rs`), so that `cargo test` keeps them passing. See fuzz/README.md.

#[path = "../../../fuzz/checks/cli.rs"]
mod checks;
#[path = "../../../fuzz/checks/replay.rs"]
mod replay;

use std::path::Path;

fn fuzz_dir() -> &'static Path {
    Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../../fuzz"))
}

macro_rules! target {
    ($name:ident) => {
        #[test]
        fn $name() {
            let n = replay::replay(fuzz_dir(), stringify!($name), checks::$name);
            assert!(n >= 2, "{n} files");
        }
    };
}

target!(readings_csv);
target!(heads);
target!(station_toml);
target!(angles_csv);
target!(json_files);
target!(frames);
target!(elcomat);
target!(axis);
