//! gonio-calib (in progress).
#![deny(missing_docs)]
