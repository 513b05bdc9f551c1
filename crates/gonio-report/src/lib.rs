//! Reports a calibration laboratory can sign: plots as inline SVG ([`plot`], `plotters`' SVG
//! backend with an embedded font, [`font`]), one self-contained offline HTML file ([`html`]), and
//! the Digital Calibration Certificate of PTB (DCC v3.1.2 XML, [`dcc`]).
//!
//! Inputs are a calibration [`Certificate`](gonio_calib::certificate::Certificate), a rotary
//! axis tested to ISO 230-2 ([`axis`], the document of `gonio axis`), a
//! [`Comparison`](gonio_calib::compare::Comparison) of two certificates, or a mounting batch
//! ([`batch::BatchView`]). Nothing here prints or touches the network; outputs are strings the
//! caller writes.
//!
//! ```
//! use gonio_report::html::Report;
//! let html = Report::new("Empty report").render();
//! assert!(html.starts_with("<!DOCTYPE html>") && !html.contains("http://") && !html.contains("https://"));
//! ```
#![deny(missing_docs)]

pub mod axis;
pub mod batch;
pub mod dcc;
pub mod font;
pub mod html;
pub mod plot;

use thiserror::Error;

/// An error of report or DCC generation.
#[derive(Debug, Error, Clone, PartialEq)]
#[non_exhaustive]
pub enum ReportError {
    /// A plot could not be drawn.
    #[error("plot '{figure}': {message}")]
    Plot {
        /// The figure's id.
        figure: String,
        /// The plotting library's message.
        message: String,
    },
    /// The XML writer failed.
    #[error("DCC XML: {message}")]
    Xml {
        /// The writer's message.
        message: String,
    },
    /// Metadata the DCC schema requires is missing (write a draft to go on).
    #[error("the DCC needs these metadata fields: {}", missing.join(", "))]
    MissingMeta {
        /// The missing fields, by name.
        missing: Vec<String>,
    },
}
