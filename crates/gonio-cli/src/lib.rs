//! The library half of the `gonio` binary: the output set, the terminal and the bounded numeric
//! flags, shared by the commands and the tests. The file formats, input reading, the commands' result documents and
//! the JSON emitter are `gonio_io`'s (`crates/gonio-io`), tested and fuzzed (`fuzz/`) on bytes
//! without the binary.
//!
//! The commands (`src/cmd/`, in the binary) are glue: arguments, a call into the library crates,
//! and output through [`output::Outputs`] and [`term`]. Errors here are `anyhow` errors whose
//! one-line text names the file, line and column (the binary prints them with exit code 2).
#![deny(missing_docs)]

pub mod flag;
pub mod output;
pub mod term;
