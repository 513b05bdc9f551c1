//! The fuzz targets' kept corpora and every crash they found (`fuzz/corpus/<target>/`,
//! `fuzz/regressions/<target>/`), replayed through the same checks as the fuzzers
//! (`fuzz/checks/uncertainty.rs`), so that `cargo test` keeps them passing. See fuzz/README.md.

#[path = "../../../fuzz/checks/uncertainty.rs"]
mod checks;
#[path = "../../../fuzz/checks/replay.rs"]
mod replay;

use std::path::Path;

fn fuzz_dir() -> &'static Path {
    Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../../fuzz"))
}

#[test]
fn budget_toml_corpus_and_regressions() {
    let n = replay::replay(fuzz_dir(), "budget_toml", checks::budget_toml);
    assert!(n >= 10, "{n} files");
}

#[test]
fn instrument_toml_corpus_and_regressions() {
    let n = replay::replay(fuzz_dir(), "instrument_toml", checks::instrument_toml);
    assert!(n >= 3, "{n} files");
}
