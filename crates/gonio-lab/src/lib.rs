//! The lab bench: an ELCOMAT-type autocollimator read over its serial line while the operator
//! turns the polygon through a shift-angle measuring plan, and nothing acquired is lost.
//!
//! - [`plan`]: the measuring plan (TOML): which reading comes when.
//! - [`axis`]: a rotary axis's ISO 230-2 test cycle (TOML): targets, runs, overruns.
//! - [`log`]: the autocollimator's line format (`4 003 X Y`, `2 103 X Y`, arcsec) and its logs.
//! - [`import`]: a log and its plan → the readings of the shift-angle CSV.
//! - [`readings`]: that CSV as the lab writes it.
//! - [`instrument`]: the serial driver (request `a`/`r` + CR LF, one answer line ended by CR).
//! - [`journal`]: every accepted reading appended and synced before the next is asked for.
//! - [`sequence`]: what an acquisition walks (the shift-angle plan, an axis's test cycle).
//! - [`acquire`]: the plan walked position by position: K samples averaged, spread checked,
//!   flagged answers rejected, closure and drift checked.
//! - [`simulator`]: a simulated autocollimator and polygon on a pseudo-terminal.
//!
//! Angles of the readings are arcseconds (`_arcsec`), shifts degrees (`_deg`). The library
//! never prints or exits: every failure is a typed error naming the file and line or the port.
//!
//! ```
//! use gonio_lab::plan::Plan;
//! let plan = Plan::parse_text("plan.toml", "faces = 24\nshifts_deg = \"0:5:10\"\nstart_faces = [1]\n").unwrap();
//! let first = plan.readings()[0];
//! assert_eq!((first.shift_deg, first.start_face, first.step), (0.0, 1, 1));
//! ```

#![deny(missing_docs)]

pub mod acquire;
pub mod axis;
pub mod import;
pub mod instrument;
pub mod journal;
pub mod log;
pub mod plan;
pub mod readings;
pub mod sequence;
pub mod simulator;
