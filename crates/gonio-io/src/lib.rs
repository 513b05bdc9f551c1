//! gonio's files: the lab formats' readers and writers ([`formats`]), input reading with size
//! limits and the record of the files read ([`input`]), the result documents of the commands that
//! more than one front end gives ([`results`]: the `gonio` binary's JSON, the Python module's
//! dicts), the one strict JSON emitter, which refuses a number that is not finite ([`json`]), and
//! the replay recorder, the writer of the replay format whose reader is [`formats::replay`]
//! ([`recorder`]), the detector's stage images as PNG files ([`stage_dump`]), and a command's
//! outputs written as one atomic set that never overwrites an input ([`output`]), results
//! as text tables for a terminal ([`table`]), and `gonio demo`, the simulated lab end to end
//! scored against its truth ([`demo`]), and the address space a command checks before it
//! sizes its work by a flag ([`memory`]).
//!
//! Every parser takes text (or bytes) and a name, so that it can be tested and fuzzed (`fuzz/`)
//! without files. Errors are `anyhow` errors whose one-line text names the file, line and column
//! (`NAME:LINE:COL: message`). Nothing here prints: the front ends say what happened.
//!
//! ```
//! use gonio_io::formats::readings;
//! let text = "shift_deg,start_face,step,reading_arcsec\n0,1,1,0.5\n0,x,1,0.5\n";
//! let e = readings::parse("r.csv", text, None).unwrap_err();
//! assert!(e.to_string().starts_with("r.csv:3:"), "{e}");
//!
//! #[derive(serde::Serialize)]
//! struct P { u_arcsec: f64 }
//! assert!(gonio_io::json::to_bytes(&P { u_arcsec: f64::NAN }).is_err());
//! ```
#![deny(missing_docs)]

pub mod demo;
pub mod formats;
pub mod input;
pub mod json;
pub mod memory;
pub mod output;
pub mod recorder;
pub mod results;
pub mod stage_dump;
pub mod table;
