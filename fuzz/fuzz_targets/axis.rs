//! Fuzz target `axis`: see `checks/cli.rs` (the invariants, shared with the regression test that
//! `cargo test` runs).
#![no_main]

#[path = "../checks/cli.rs"]
mod checks;

libfuzzer_sys::fuzz_target!(|data: &[u8]| checks::axis(data));
