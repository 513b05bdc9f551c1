//! Fuzz target: instrument files (TOML), parsed and combined with a random part. The invariants
//! are in `checks/uncertainty.rs`, shared with the regression test that `cargo test` runs.
#![no_main]

#[path = "../checks/uncertainty.rs"]
mod checks;

libfuzzer_sys::fuzz_target!(|data: &[u8]| checks::instrument_toml(data));
