//! Discovery: every camera Aravis finds on its enabled interfaces (GigE Vision, USB3 Vision, and
//! the in-process `Fake` interface once [`enable_fake_interface`] was called).

use crate::ffi;

/// A camera Aravis found.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct CameraInfo {
    /// Aravis's id: what `open` and `gonio detect --camera` take (`Vendor-Model-Serial` for a GigE
    /// Vision camera, e.g. `Aravis-GV01`).
    pub id: String,
    /// Vendor name.
    pub vendor: String,
    /// Model name.
    pub model: String,
    /// Serial number.
    pub serial: String,
    /// Address: IPv4 for GigE Vision, bus address for USB3 Vision.
    pub address: String,
    /// `GigEVision`, `USB3Vision` or `Fake`.
    pub protocol: String,
}

/// Every camera Aravis finds now (GigE Vision discovery waits ≈ 1 s for answers).
pub fn list_cameras() -> Vec<CameraInfo> {
    ffi::list_devices()
        .into_iter()
        .map(|d| CameraInfo {
            id: d.id,
            vendor: d.vendor,
            model: d.model,
            serial: d.serial,
            address: d.address,
            protocol: d.protocol,
        })
        .collect()
}

/// Enables Aravis's in-process `Fake` interface (a simulated camera with no network, id
/// `Fake_1`), for tests.
#[cfg(feature = "fake")]
pub fn enable_fake_interface() {
    ffi::enable_interface("Fake");
}
