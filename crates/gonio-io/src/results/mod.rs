//! The results of the commands that more than one front end gives (the binary's JSON, the Python
//! module's dicts): their JSON shape and the evaluation from the inputs to the result, so that
//! both give the same keys and values, accept and refuse the same inputs and say the same
//! errors, from one code path. The calibrations (`shift_angle`, `selfcal`, `joint`) return the
//! certificate (`gonio.certificate/1`), `compare` the comparison of two.

pub mod budget;
pub mod compare;
pub mod detect;
pub mod eccentricity;
pub mod joint;
pub mod selfcal;
pub mod shift_angle;

use anyhow::Result;
use gonio_calib::certificate::{Certificate, CertificateMeta};
use std::path::Path;

/// A calibration's certificate with its metadata, checked finite: an overflow (a reading of
/// 1e308) is an error naming the input, before any output.
fn finish(cert: Certificate, meta: Option<CertificateMeta>, input: &str) -> Result<Certificate> {
    let cert = match meta {
        Some(m) => cert.with_meta(m),
        None => cert,
    };
    crate::json::finite_result(&cert, Path::new(input), "the calibration")?;
    Ok(cert)
}
