//! gonio-station (in progress).
#![deny(missing_docs)]
