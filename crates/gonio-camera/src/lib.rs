//! GenICam cameras (GigE Vision, USB3 Vision) for gonio through Aravis (libaravis 0.8), and a
//! GigE Vision fake camera that serves frames the caller draws.
//!
//! With the cargo feature `genicam` (needs `libaravis-dev` ≥ 0.8.25 through pkg-config):
//!
//! - [`list_cameras`] → [`CameraInfo`] (`id`, `vendor`, `model`, `serial`, `address`,
//!   `protocol`): every camera Aravis finds.
//! - [`AravisSource::open`]`(id, &`[`CameraConfig`]`)` → a
//!   [`FrameSource`](gonio_vision::FrameSource) of 8-bit grey frames of the configured window.
//!   Each frame's stamp has `index` = its slot (0 for the first frame, one per frame of the
//!   camera, received or missing), `start_s` (the camera's timestamp on the host's monotonic
//!   clock, see [`source`]) and `exposure_s`; [`AravisSource::take_meta`]`(index)` gives its
//!   [`FrameMeta`]: `frame_id` (the camera's, counted on across the 16-bit wrap), `timestamp_ns`
//!   (the camera's), `complete`, `missing_before`. [`AravisSource::stats`] counts frames complete,
//!   incomplete, missing and the packets resent. Its error, [`CameraError`], implements
//!   [`DeviceError`](gonio_station::hal::DeviceError), so
//!   `gonio_station::camera::DetectorCamera<AravisSource>` is the station's
//!   [`Camera`](gonio_station::hal::Camera) (use it with `deliver_incomplete: false`).
//! - With the feature `fake` (the simulated camera, beside the real path):
//!   [`FakeGvCamera::start`]`(&`[`FakeConfig`]`, fill)` serves a GigE Vision camera (Aravis's
//!   `GvFakeCamera`) whose every frame is drawn by `fill`, a [`FrameFill`] (any
//!   `FnMut(&FillInfo, &mut [u8]) + Send + 'static`), called per frame on Aravis's streaming
//!   thread with [`FillInfo`] { `frame_id`, `timestamp_ns`, `index`, `width`, `height`, `mono8`,
//!   `exposure_us` } and the frame's Mono8 pixels to fill. [`FakeGvCamera::last_served`] and
//!   [`FakeGvCamera::frames_served`] tell which id and timestamp each frame got.
//!
//! Without the feature the crate holds only what needs no system library: the configuration
//! types, [`CameraError`] (whose [`CameraError::NotBuilt`] says how to get cameras),
//! [`FrameIds`] and [`gvcp`] (whether a GigE Vision camera answers at an address, and which);
//! [`ENABLED`] says which build this is.
//!
//! Units: pixels, µs for exposure, dB for gain, ns for camera timestamps, s for `start_s`.
//!
//! Errors: one [`CameraError`] for everything, each naming the camera; it maps to the station's
//! `DeviceErrorKind` (no frame in time → timeout; not found or link failures → communication;
//! refused settings and values out of range → fault).
//!
//! ```
//! use gonio_camera::{CameraConfig, Trigger};
//! let config = CameraConfig {
//!     window_size: (1440, 540),
//!     exposure_us: Some(500.0),
//!     trigger: Trigger::Line1,
//!     frames: Some(200),
//!     ..CameraConfig::default()
//! };
//! assert!(config.stream.packet_socket_disabled); // loopback needs it; see StreamOptions
//! # #[cfg(feature = "genicam")]
//! # fn open(config: &CameraConfig) -> Result<(), gonio_camera::CameraError> {
//! let mut cam = gonio_camera::AravisSource::open("Aravis-Fake-GV01", config)?;
//! let mut px = Vec::new();
//! use gonio_vision::FrameSource;
//! while let Some(h) = cam.next_frame(&mut px)? {
//!     let meta = cam.take_meta(h.stamp.index).unwrap();
//!     println!("{} {} complete={}", meta.frame_id, meta.timestamp_ns, meta.complete);
//! }
//! # Ok(()) }
//! ```
#![deny(missing_docs)]
// The links above name the items of the `genicam` and `fake` builds; without them they do not
// exist.
#![cfg_attr(not(feature = "fake"), allow(rustdoc::broken_intra_doc_links))]

mod config;
mod error;
pub mod gvcp;
mod ids;
mod wake;

pub use config::{CameraConfig, FrameMeta, StreamOptions, StreamStats, Trigger, Window};
pub use error::CameraError;
pub use ids::{FrameIds, IdStep};

/// True when built with the `genicam` feature (cameras through Aravis).
pub const ENABLED: bool = cfg!(feature = "genicam");

#[cfg(feature = "fake")]
pub mod fake;
// The fake camera's fill callback is the larger part of the boundary; a `genicam` build without
// `fake` uses only the device list and the buffers' bytes.
#[cfg(feature = "genicam")]
#[cfg_attr(not(feature = "fake"), allow(dead_code))]
mod ffi;
#[cfg(feature = "genicam")]
mod list;
#[cfg(feature = "genicam")]
pub mod source;

#[cfg(feature = "fake")]
pub use fake::{FakeConfig, FakeGvCamera, FillInfo, FrameFill, ServedFrame};
#[cfg(feature = "fake")]
pub use list::enable_fake_interface;
#[cfg(feature = "genicam")]
pub use list::{CameraInfo, list_cameras};
#[cfg(feature = "genicam")]
pub use source::AravisSource;
