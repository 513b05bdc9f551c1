//! The mounting station over real protocols: gonio-station's `Servo`, `FocusDrive`, `PushRod`
//! and `Clock` through a PLC's Modbus TCP registers, every camera frame paired with the servo
//! angle the PLC latched at its trigger, contact seen in the ring's column
//! (`docs/plc-interface.md`); beside it, behind the feature `sim`, a simulated station that
//! serves the same registers.
//!
//! - [`map`]: the register map as data (`examples/plc/modbus-map.toml`), units and scaling.
//! - [`protocol`]: the status word's bits, fault codes, commands and the status block.
//! - [`link`]: the blocking Modbus TCP link: command word and sequence counter, status word,
//!   heartbeat both ways with a watchdog; [`round_trips`]: its round-trip times;
//!   [`transport`]: the connection under it, which tells a closed, reset or silent PLC apart;
//!   [`abort`]: the safe state after an error or an interrupt, with one deadline.
//! - [`error`]: [`PlcError`], every error of the station over the wire.
//! - [`pairing`]: a frame's angle from the latch ring, or interpolated in timestamped samples.
//! - [`contact`]: contact when the ring's column starts to move.
//! - [`triggered`]: the camera the PLC triggers, through the detector.
//! - [`station`]: the station core: one link and one triggered camera, each frame paired with
//!   its latched angle; [`devices`]: its five device handles for the controller.
//! - [`batch`]: a batch of parts through the PLC, with the part handshake.
//! - `sim` (cargo feature `sim`, off by default): the station as a Modbus TCP server with the
//!   twin's plant, and its camera's frame stamp. Nothing above it depends on it: the real
//!   station compiles and runs without any simulation code.
//!
//! ```no_run
//! use gonio_plc::{Link, PlcStation, RegisterMap, StationOptions, TriggeredCamera};
//! use gonio_station::{Controller, Recipe, Strategy};
//! use std::time::Duration;
//! /// Mounts the part on the shaft through the PLC at `addr`, with its triggered camera.
//! fn mount_one(addr: &str, camera: impl TriggeredCamera) -> Result<(), Box<dyn std::error::Error>> {
//!     let link = Link::connect(addr, RegisterMap::default())?;
//!     let recipe = Recipe::default();
//!     let opts = StationOptions { fps: recipe.measure.fps, exposure_s: recipe.measure.exposure_s,
//!                                 um_per_px: recipe.um_per_px };
//!     let station = PlcStation::new(link, camera, opts)?;
//!     let part = station.wait_part(Duration::from_secs(5))?;
//!     let mut ctl = Controller::new(recipe, Strategy::Live);
//!     let rec = ctl.mount(&mut station.devices(), &format!("PLC-{part:04}"))?;
//!     println!("{:?} µm", rec.final_e_um); // None when the part was not measured
//!     Ok(())
//! }
//! ```
#![deny(missing_docs)]

pub mod abort;
pub mod batch;
pub mod contact;
pub mod devices;
pub mod error;
pub mod link;
pub mod map;
pub mod pairing;
pub mod protocol;
pub mod round_trips;
#[cfg(feature = "sim")]
pub mod sim;
pub mod station;
pub mod transport;
pub mod triggered;

pub use abort::Interrupt;
pub use error::PlcError;
pub use link::Link;
pub use map::RegisterMap;
pub use station::{PlcStation, StationOptions};
pub use triggered::TriggeredCamera;
