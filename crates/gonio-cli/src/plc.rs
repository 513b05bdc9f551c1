//! A batch through a station's PLC (`--plc modbus://HOST:PORT --camera ID`): the one setup of
//! `gonio mount --plc` and `gonio serve --station plc` (the PLC's address, its register map, the
//! camera, the station over the link, the batch in the results store) and the batch itself,
//! every part committed to the store as it ends.

use crate::station::{self, StrategyArg};
use anyhow::{Result, anyhow, bail};
use gonio_plc::batch::{LinkFigures, PartEnd, PlcBatchReport, PlcPartDone, run_batch_observed};
use gonio_plc::station::{PlcStation, StationOptions};
use gonio_station::observe::{NoObserver, Observer};
use gonio_station::tap::FrameTap;
use gonio_station::{Controller, Recipe, Strategy};
use gonio_store::writer::{BatchSpec, BatchWriter};
use std::path::PathBuf;

/// What a batch through the PLC is asked for: the flags `mount` and `serve` share.
#[derive(Debug, Clone)]
pub struct Request {
    /// `--plc`: modbus://HOST:PORT.
    pub url: String,
    /// `--camera`: the camera's GenICam id.
    pub camera: String,
    /// `--plc-map`: the register map (TOML), if not the default one.
    pub plc_map: Option<PathBuf>,
    /// The recipe.
    pub recipe: Recipe,
    /// `--strategy`.
    pub strategy: StrategyArg,
    /// `--parts`.
    pub parts: usize,
    /// `--db`: the results store, if any.
    pub db: Option<String>,
    /// `--station-name`: the station's name in the store.
    pub station_name: String,
}

/// A batch ready to run: the station over its link with its camera, the controller, and the
/// batch begun in the store.
pub struct Batch {
    station: PlcStation<plc_camera::Camera>,
    ctl: Controller,
    store: Option<BatchWriter>,
    location: String,
    parts: usize,
}

/// `HOST:PORT` of a `modbus://HOST:PORT` URL.
pub fn plc_address(url: &str) -> Result<String> {
    let rest = url
        .strip_prefix("modbus://")
        .ok_or_else(|| anyhow!("--plc {url}: expected modbus://HOST:PORT (Modbus TCP)"))?;
    let rest = rest.trim_end_matches('/');
    match rest.rsplit_once(':') {
        Some((h, p)) if !h.is_empty() && p.parse::<u16>().is_ok() => Ok(rest.to_string()),
        _ => bail!("--plc {url}: expected modbus://HOST:PORT with a port number"),
    }
}

/// The register map of `--plc-map` (errors name the file, line and column), or the default.
/// (`mount --plc` records the file among its inputs, so that no output overwrites it.)
fn register_map(path: Option<&std::path::Path>) -> Result<gonio_plc::RegisterMap> {
    Ok(match path {
        Some(p) => gonio_io::input::Inputs::new().load(p, |name, text| {
            gonio_plc::RegisterMap::from_toml(text).map_err(|e| match (&e, e.position()) {
                (gonio_plc::map::MapError::Syntax { message, .. }, Some((line, column))) => {
                    anyhow!("{name}:{line}:{column}: {message}")
                }
                (_, Some((line, column))) => anyhow!("{name}:{line}:{column}: {e}"),
                (_, None) => anyhow!("{name}: {e}"),
            })
        })?,
        None => gonio_plc::RegisterMap::default(),
    })
}

/// Opens the station: checks the PLC's address, reads the register map, connects to the PLC,
/// opens the camera as the PLC says it is (a real camera on its trigger line, or the simulated
/// station's free-running one: [`gonio_plc::link::bits::SIMULATED`]), opens the station (with
/// `tap`, if any, shown every frame it delivers: a recorder, the live view's thumbnail) and,
/// with a store, begins the batch in it.
///
/// # Errors
/// One-line errors naming the flag: a bad address or map, no camera, no PLC, no store.
pub fn open(r: Request, tap: Option<FrameTap<'static>>) -> Result<Batch> {
    if !(1..=station::MAX_PARTS).contains(&r.parts) {
        bail!("--parts {}: expected 1 to {}", r.parts, station::MAX_PARTS);
    }
    let addr = plc_address(&r.url)?;
    let map = register_map(r.plc_map.as_deref())?;
    let frame_timeout_ms = map.timing.frame_timeout_ms;
    // The camera is looked for before the PLC is touched: no camera, no station.
    plc_camera::check(&r.camera)?;
    let mut link = gonio_plc::Link::connect(&addr, map).map_err(|e| anyhow!("--plc: {e}"))?;
    let simulated = link
        .status()
        .map_err(|e| anyhow!("--plc: {e}"))?
        .has(gonio_plc::link::bits::SIMULATED);
    let camera = plc_camera::open(&r.camera, &r.recipe, frame_timeout_ms, simulated)?;
    let opts = StationOptions {
        fps: r.recipe.measure.fps,
        exposure_s: r.recipe.measure.exposure_s,
        um_per_px: r.recipe.um_per_px,
    };
    let st = PlcStation::new(link, camera, opts).map_err(|e| anyhow!("--plc: {e}"))?;
    if let Some(tap) = tap {
        st.set_tap(tap);
    }
    let store = match r.db.as_deref() {
        Some(db) => {
            let config = serde_json::to_string(&serde_json::json!({
                "plc": r.url,
                "camera": r.camera,
                "parts": r.parts,
                "strategy": Strategy::from(r.strategy).name(),
                "recipe": r.recipe,
            }))?;
            let spec = BatchSpec {
                station: &r.station_name,
                seed: None,
                config_json: &config,
                parts: r.parts,
                recipe: &r.recipe,
                simulated,
            };
            let loc = gonio_store::display_location(db);
            let w = BatchWriter::begin(crate::db::open(db)?, &spec)
                .map_err(|e| anyhow!("{loc}: {e}"))?;
            Some((w, loc))
        }
        None => None,
    };
    let (store, location) = match store {
        Some((w, loc)) => (Some(w), loc),
        None => (None, String::new()),
    };
    Ok(Batch {
        station: st,
        ctl: Controller::new(r.recipe, r.strategy.into()),
        store,
        location,
        parts: r.parts,
    })
}

impl Batch {
    /// Whether the PLC said it is a simulation: the parts are the digital twin's.
    pub fn simulated(&self) -> bool {
        self.station.simulated()
    }

    /// The recipe the parts are mounted with.
    pub fn recipe(&self) -> &Recipe {
        &self.ctl.recipe
    }

    /// Ends the batch safely when `interrupt` is raised (a signal): the part in progress ends
    /// `interrupted` and is stored, the station is left safe (retract, stop, trigger off within
    /// the map's `timing.safe_state_ms`), and the batch is stored as stopped.
    pub fn set_interrupt(&self, interrupt: gonio_plc::Interrupt) {
        self.station.set_interrupt(interrupt);
    }

    /// Shows every frame the station delivers to the controller to `tap` (replacing any tap
    /// before): a recorder, the live view's thumbnail.
    pub fn set_tap(&self, tap: FrameTap<'static>) {
        self.station.set_tap(tap);
    }

    /// The link's figures as they are when called (requests, round trips, frames paired and
    /// stale): call it on the batch's thread, between the controller's steps (its observer),
    /// and after the batch.
    pub fn link_figures(&self) -> impl Fn() -> LinkFigures + use<> {
        let station = self.station.clone();
        move || station.link_figures()
    }

    /// Mounts the parts, telling `observer` what the controller does as it does it and
    /// `on_part` each part as it ends, with its id in the store once committed there. A part
    /// that cannot be stored stops the batch; the batch's end is written to the store.
    ///
    /// # Errors
    /// An invalid recipe, a part that could not be stored, or the store's batch not ended.
    /// A device error is no error: it ends the part and the batch ([`PlcBatchReport::stopped`]).
    pub fn run(
        mut self,
        observer: &mut dyn Observer,
        on_part: &mut dyn FnMut(&PlcPartDone<'_>, Option<i64>),
    ) -> Result<PlcBatchReport> {
        let mut store_error = None;
        let store = &mut self.store;
        let location = &self.location;
        let mut clock = store.as_ref().map(BatchWriter::clock);
        let mut none = NoObserver;
        let clock: &mut dyn Observer = match clock.as_mut() {
            Some(c) => c,
            None => &mut none,
        };
        let mut both = (clock, observer);
        let report = run_batch_observed(
            &self.station,
            &mut self.ctl,
            self.parts,
            &mut both,
            &mut |d: &PlcPartDone<'_>| {
                let id = match store
                    .as_mut()
                    .map(|s| s.commit(d.index, d.record, d.learned, None))
                {
                    Some(Ok(id)) => Some(id),
                    Some(Err(e)) => {
                        store_error = Some(anyhow!("{location}: storing {}: {e}", d.record.serial));
                        None
                    }
                    None => None,
                };
                on_part(d, id);
                if store_error.is_some() {
                    PartEnd::Stop
                } else {
                    PartEnd::Continue
                }
            },
        )?;
        if let Some(e) = store_error {
            return Err(e);
        }
        if let Some(s) = self.store.as_mut() {
            s.end(report.stopped.as_deref())
                .map_err(|e| anyhow!("{}: {e}", self.location))?;
        }
        Ok(report)
    }
}

/// The station's camera for `--plc`: a GenICam camera through Aravis (feature `genicam`).
mod plc_camera {
    use anyhow::Result;
    use gonio_station::Recipe;

    #[cfg(feature = "genicam")]
    pub use with::{Camera, check, open};
    #[cfg(not(feature = "genicam"))]
    pub use without::{NoCamera as Camera, check, open};

    #[cfg(feature = "genicam")]
    mod with {
        use super::*;
        use anyhow::anyhow;
        use gonio_camera::{AravisSource, CameraConfig, CameraError, Trigger};
        use gonio_plc::sim::StampedSource;
        use gonio_plc::triggered::DetectorTriggered;
        use gonio_station::tap::SeenFrame;
        use gonio_vision::{FrameHeader, FrameSource};

        /// A real camera's frames numbered by the camera's frame id (= the PLC's trigger count
        /// on a hardware trigger line).
        #[derive(Debug)]
        pub struct ById(AravisSource);

        impl FrameSource for ById {
            type Error = CameraError;
            fn next_frame(&mut self, px: &mut Vec<u8>) -> Result<Option<FrameHeader>, CameraError> {
                let Some(mut h) = self.0.next_frame(px)? else {
                    return Ok(None);
                };
                if let Some(m) = self.0.take_meta(h.stamp.index) {
                    h.stamp.index = m.frame_id;
                }
                Ok(Some(h))
            }
        }

        /// The camera: a real one on the PLC's trigger line, or the simulated station's (free
        /// running, its frames carrying the trigger count), as the PLC says.
        pub enum Camera {
            /// `gonio simulate station`'s camera.
            Sim(DetectorTriggered<StampedSource<AravisSource>>),
            /// A camera triggered on line 1.
            Real(DetectorTriggered<ById>),
        }

        impl std::fmt::Debug for Camera {
            fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
                f.write_str("Camera")
            }
        }

        impl gonio_plc::TriggeredCamera for Camera {
            type Error = gonio_vision::SourceError<CameraError>;
            fn next_frame(
                &mut self,
                timeout: std::time::Duration,
            ) -> Result<Option<gonio_plc::triggered::TriggeredFrame>, Self::Error> {
                match self {
                    Camera::Sim(c) => c.next_frame(timeout),
                    Camera::Real(c) => c.next_frame(timeout),
                }
            }
            fn seen(&self) -> Option<SeenFrame<'_>> {
                match self {
                    Camera::Sim(c) => c.seen(),
                    Camera::Real(c) => c.seen(),
                }
            }
        }

        /// Whether camera `id` is there (GigE Vision discovery: about a second).
        pub fn check(id: &str) -> Result<()> {
            if gonio_camera::list_cameras().iter().any(|c| c.id == id) {
                Ok(())
            } else {
                Err(anyhow!(
                    "--camera {id}: no camera with this id answers (gonio camera list shows those that do)"
                ))
            }
        }

        /// Opens camera `id` for the recipe's window and exposure: the simulated station's
        /// camera when its PLC says it is simulated (`sim`), else a real one.
        pub fn open(id: &str, recipe: &Recipe, frame_timeout_ms: u64, sim: bool) -> Result<Camera> {
            let optics = recipe.optics();
            let config = CameraConfig {
                window_size: (optics.window_width_px, optics.window_height_px),
                exposure_us: Some(recipe.measure.exposure_s * 1e6),
                // The simulated camera is paced by its PLC's trigger itself.
                trigger: if sim { Trigger::Free } else { Trigger::Line1 },
                frame_timeout_ms,
                ..CameraConfig::default()
            };
            let src = AravisSource::open(id, &config).map_err(|e| anyhow!("--camera {id}: {e}"))?;
            let bad = |e| anyhow!("--camera {id}: {e}");
            Ok(if sim {
                Camera::Sim(DetectorTriggered::new(StampedSource(src), &optics).map_err(bad)?)
            } else {
                Camera::Real(DetectorTriggered::new(ById(src), &optics).map_err(bad)?)
            })
        }
    }

    #[cfg(not(feature = "genicam"))]
    mod without {
        use super::*;
        use anyhow::bail;

        /// A camera that is never built: this gonio has no GenICam support.
        #[derive(Debug)]
        pub enum NoCamera {}

        /// Its error (never made either).
        #[derive(Debug)]
        pub struct NoCameraError;

        impl std::fmt::Display for NoCameraError {
            fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
                f.write_str("no camera")
            }
        }

        impl gonio_station::hal::DeviceError for NoCameraError {
            fn kind(&self) -> gonio_station::hal::DeviceErrorKind {
                gonio_station::hal::DeviceErrorKind::Other
            }
        }

        impl gonio_plc::TriggeredCamera for NoCamera {
            type Error = NoCameraError;
            fn next_frame(
                &mut self,
                _timeout: std::time::Duration,
            ) -> Result<Option<gonio_plc::triggered::TriggeredFrame>, NoCameraError> {
                match *self {}
            }
        }

        /// Whether camera `id` is there: never, without GenICam.
        pub fn check(id: &str) -> Result<()> {
            bail!(
                "--camera {id}: this gonio is built without GenICam cameras (cargo build --features genicam)"
            )
        }

        /// Opens camera `id`: never, without GenICam.
        pub fn open(
            id: &str,
            _recipe: &Recipe,
            _frame_timeout_ms: u64,
            _sim: bool,
        ) -> Result<NoCamera> {
            bail!(
                "--camera {id}: this gonio is built without GenICam cameras (cargo build --features genicam)"
            )
        }
    }
}
