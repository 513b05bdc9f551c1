//! The live view's thumbnail of the frames a station's camera takes: told every frame (a
//! `gonio_station::tap::FrameTap`, on the station's thread), it makes one at most every
//! [`THUMBNAIL_EVERY`] ([`crate::live::thumbnail`]: the frame reduced, the strip around the
//! ring, the detected edges) and publishes it to the [`Hub`]; the other frames return at once.
//!
//! ```
//! use gonio_station::tap::SeenFrame;
//! use gonio_web::live::Hub;
//! use gonio_web::thumbnails::Thumbnails;
//! let hub = Hub::new(true);
//! let mut thumbnails = Thumbnails::new(hub.clone());
//! let mut tap = move |f: &SeenFrame<'_>| thumbnails.show(f);
//! # let _ = &mut tap;
//! ```

use crate::live::Hub;
use gonio_station::tap::SeenFrame;
use std::sync::Arc;
use std::time::{Duration, Instant};

/// Fewest wall-clock time between two live thumbnails.
pub const THUMBNAIL_EVERY: Duration = Duration::from_millis(200);

/// The live thumbnail of the frames a station's camera takes: one at most every
/// [`THUMBNAIL_EVERY`], the rest return at once.
#[derive(Debug)]
pub struct Thumbnails {
    hub: Arc<Hub>,
    last: Option<Instant>,
}

impl Thumbnails {
    /// Thumbnails published to `hub`.
    pub fn new(hub: Arc<Hub>) -> Self {
        Thumbnails { hub, last: None }
    }

    /// A frame (8-bit grey pixels) and what the detector found in it.
    pub fn show(&mut self, f: &SeenFrame<'_>) {
        if self.last.is_some_and(|t| t.elapsed() < THUMBNAIL_EVERY) {
            return;
        }
        self.last = Some(Instant::now());
        let r = f.result;
        let edges_px = r.edges.iter().map(|e| e.column_px).collect();
        if let Some(img) = crate::live::thumbnail(f.width, f.height, f.pixels, edges_px, r.c_px) {
            self.hub.image(&img);
        }
    }
}
