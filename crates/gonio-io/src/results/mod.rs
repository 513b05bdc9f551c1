//! The results of the commands that more than one front end gives (the binary's JSON, the Python
//! module's dicts): their JSON shape and, where the command does more than one library call, the
//! evaluation, so that both give the same keys and values from one code path.

pub mod budget;
pub mod detect;
pub mod eccentricity;
