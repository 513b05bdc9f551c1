//! Fuzz target: budget files (TOML, nested budgets with `from =` graphs, correlations), parsed,
//! evaluated, flattened and run through a short Monte Carlo. The invariants are in
//! `checks/uncertainty.rs`, shared with the regression test that `cargo test` runs.
#![no_main]

#[path = "../checks/uncertainty.rs"]
mod checks;

libfuzzer_sys::fuzz_target!(|data: &[u8]| checks::budget_toml(data));
