//! gonio-uncertainty (in progress).
#![deny(missing_docs)]
