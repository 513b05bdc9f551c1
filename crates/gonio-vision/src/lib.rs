//! gonio-vision (in progress).
#![deny(missing_docs)]
