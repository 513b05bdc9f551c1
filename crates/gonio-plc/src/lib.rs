//! The mounting station over real protocols: gonio-station's `Servo`, `FocusDrive`, `PushRod`
//! and `Clock` through a PLC's Modbus TCP registers, every camera frame paired with the servo
//! angle the PLC latched at its trigger, contact seen in the ring's column, and a simulated
//! station that serves the same registers (`docs/plc-interface.md`).
//!
//! - [`map`]: the register map as data (`examples/plc/modbus-map.toml`), units and scaling.
//! - [`protocol`]: the status word's bits, fault codes, commands and the status block.
//! - [`link`]: the blocking Modbus TCP link: command word and sequence counter, status word,
//!   heartbeat both ways with a watchdog; [`round_trips`]: its round-trip times.
//! - [`error`]: [`PlcError`], every error of the station over the wire.
//! - [`pairing`]: a frame's angle from the latch ring, or interpolated in timestamped samples.
//! - [`contact`]: contact when the ring's column starts to move.
//! - [`triggered`]: the camera the PLC triggers, through the detector.
//! - [`station`]: the station core: one link and one triggered camera, each frame paired with
//!   its latched angle; [`devices`]: its five device handles for the controller.
//! - [`batch`]: a batch of parts through the PLC, with the part handshake.
//! - [`sim`]: the station as a Modbus TCP server with the twin's plant.
//!
//! ```no_run
//! use gonio_plc::link::Link;
//! use gonio_plc::map::RegisterMap;
//! use gonio_plc::sim::{SimConfig, SimServer, SimTriggered};
//! use gonio_plc::station::{PlcStation, StationOptions};
//! use gonio_station::{Controller, Recipe, Strategy};
//! use std::time::Duration;
//! let mut server = SimServer::start(SimConfig::new(3), "127.0.0.1:0".parse().unwrap()).unwrap();
//! let camera = SimTriggered::new(server.take_frames().unwrap());
//! let link = Link::connect(&server.addr().to_string(), RegisterMap::default()).unwrap();
//! let recipe = Recipe::default();
//! let opts = StationOptions { fps: recipe.measure.fps, exposure_s: recipe.measure.exposure_s,
//!                             um_per_px: recipe.um_per_px };
//! let station = PlcStation::new(link, camera, opts).unwrap();
//! let part = station.wait_part(Duration::from_secs(5)).unwrap();
//! let mut ctl = Controller::new(recipe, Strategy::Live);
//! let rec = ctl.mount(&mut station.devices(), &format!("PLC-{part:04}")).unwrap();
//! println!("{:?} µm", rec.final_e_um); // None when the part was not measured
//! ```
#![deny(missing_docs)]

pub mod batch;
pub mod contact;
pub mod devices;
pub mod error;
pub mod link;
pub mod map;
pub mod pairing;
pub mod protocol;
pub mod round_trips;
pub mod sim;
pub mod station;
pub mod triggered;

pub use error::PlcError;
pub use link::Link;
pub use map::RegisterMap;
pub use station::{PlcStation, StationOptions};
pub use triggered::TriggeredCamera;
