//! The library half of the `gonio` binary: file formats, input reading, the output set and the
//! terminal, so that the parsers can be tested and fuzzed (`fuzz/`) on bytes without the binary.
//!
//! The commands (`src/cmd/`, in the binary) are glue: arguments, a call into the library crates,
//! and output through [`output::Outputs`] and [`term`]. Errors here are `anyhow` errors whose
//! one-line text names the file, line and column (the binary prints them with exit code 2).
#![deny(missing_docs)]

pub mod formats;
pub mod input;
pub mod output;
pub mod results;
pub mod term;
