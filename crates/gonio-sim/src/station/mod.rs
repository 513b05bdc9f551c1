//! The mounting station's digital twin (the station of Yu et al., 2024): the default plant,
//! a discrete-event clock, simulated servo, camera, focus drive and push rod implementing
//! `gonio_station::hal`, and a batch runner; with the feature `store`, the batch committed part by
//! part to the results store ([`stored`]).
//!
//! Two fidelities: [`Fidelity::Fast`] computes each frame's ring column from the geometry plus
//! the detector's noise ([`SimCamera`]); [`Fidelity::Frames`] renders each frame
//! ([`TwinFrames`]) and runs it through the station's own camera path
//! (`gonio_station::DetectorCamera`). Both report the detector's typed reasons.
//!
//! ```
//! use gonio_sim::station::{BatchConfig, run_batch};
//! let cfg = BatchConfig { parts: 3, ..BatchConfig::default() };
//! let report = run_batch(&cfg, 7, &mut |_, _, _| {}).unwrap();
//! assert_eq!(report.parts.len(), 3);
//! let again = run_batch(&cfg, 7, &mut |_, _, _| {}).unwrap();
//! assert_eq!(report.summary, again.summary);
//! ```

pub mod batch;
pub mod frames;
pub mod pace;
pub mod plant;
#[cfg(feature = "store")]
pub mod stored;
pub mod twin;

pub use batch::{
    BatchConfig, BatchReport, BatchSummary, Fidelity, PartDone, RunOptions, SimPartRecord,
    SummaryBuilder, run_batch, run_batch_from, run_batch_observed, run_batch_on, run_batch_with,
};
pub use frames::{FrameCamera, FrameTap, SeenFrame, TappedCamera, TwinFrames, frame_camera};
pub use pace::{FrameTiming, Pace, TimingSummary};
pub use plant::{PartTruth, PlantConfig, StationTruth, Timing};
pub use twin::{
    DeviceId, Exposure, Faults, Shared, SimCamera, SimClock, SimDeviceError, SimFocus, SimRod,
    SimServo, Twin,
};
