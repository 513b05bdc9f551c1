//! The station simulated as its own server: a Modbus TCP PLC ([`plc::Plc`]: motion profiles on
//! the wall clock, link latency, limits, watchdog, fault bits, the part handshake) with the
//! twin's plant, and the exposures it triggers for a camera (a GigE Vision camera rendering the
//! grating at each latched angle, or the in-process [`SimTriggered`] stand-in that reports the
//! twin's fast-fidelity column).
//!
//! The same seed gives the same station constants and the same parts (the twin's
//! `PartTruth::draw`); the noise follows the wall clock, so two runs differ in their last bits
//! as two days on a real station do.
//!
//! Errors: [`SimServerError`] when the server cannot bind.
//!
//! ```no_run
//! use gonio_plc::sim::{SimConfig, SimServer};
//! let server = SimServer::start(SimConfig::new(7), "127.0.0.1:0".parse().unwrap()).unwrap();
//! println!("PLC on {}", server.addr());
//! ```

pub mod plc;

pub use plc::{Plc, SimConfig, SimFaults, TriggeredExposure, TruthPart};

use crate::triggered::{TriggeredCamera, TriggeredFrame};
use gonio_station::hal::{DeviceError, DeviceErrorKind};
use gonio_vision::{FrameHeader, FrameSource};
use std::future::Future;
use std::net::SocketAddr;
use std::pin::Pin;
use std::sync::mpsc;
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};
use thiserror::Error;
use tokio_modbus::prelude::{ExceptionCode, Request, Response, SlaveRequest};
use tokio_modbus::server::Service;
use tokio_modbus::server::tcp::{Server, accept_tcp_connection};

/// An error of the simulated station's server.
#[derive(Debug, Error)]
#[non_exhaustive]
pub enum SimServerError {
    /// The address cannot be bound.
    #[error("cannot listen on {addr}: {source}")]
    Bind {
        /// The address.
        addr: SocketAddr,
        /// Why.
        source: std::io::Error,
    },
}

struct Shared {
    plc: Mutex<Plc>,
    t0: Instant,
    silent_at_s: Option<f64>,
    latency: Duration,
}

impl Shared {
    fn now(&self) -> f64 {
        self.t0.elapsed().as_secs_f64()
    }
}

#[derive(Clone)]
struct PlcService(Arc<Shared>);

type Reply = Pin<Box<dyn Future<Output = Result<Response, ExceptionCode>> + Send>>;

impl Service for PlcService {
    type Request = SlaveRequest<'static>;
    type Response = Response;
    type Exception = ExceptionCode;
    type Future = Reply;

    fn call(&self, req: Self::Request) -> Self::Future {
        let s = &self.0;
        let now = s.now();
        if s.silent_at_s.is_some_and(|x| now >= x) {
            return Box::pin(std::future::pending());
        }
        let r = {
            let mut p = s.plc.lock().unwrap_or_else(|e| e.into_inner());
            p.advance(now);
            match req.request {
                Request::ReadInputRegisters(a, n) => p
                    .read_input(a, n)
                    .map(Response::ReadInputRegisters)
                    .ok_or(ExceptionCode::IllegalDataAddress),
                Request::ReadHoldingRegisters(a, n) => p
                    .read_holding(a, n)
                    .map(Response::ReadHoldingRegisters)
                    .ok_or(ExceptionCode::IllegalDataAddress),
                Request::WriteSingleRegister(a, v) => {
                    if p.write_holding(a, &[v]) {
                        Ok(Response::WriteSingleRegister(a, v))
                    } else {
                        Err(ExceptionCode::IllegalDataAddress)
                    }
                }
                Request::WriteMultipleRegisters(a, ref w) => {
                    if p.write_holding(a, w) {
                        Ok(Response::WriteMultipleRegisters(a, w.len() as u16))
                    } else {
                        Err(ExceptionCode::IllegalDataAddress)
                    }
                }
                _ => Err(ExceptionCode::IllegalFunction),
            }
        };
        let d = s.latency;
        Box::pin(async move {
            if !d.is_zero() {
                tokio::time::sleep(d).await;
            }
            r
        })
    }
}

/// A running simulated station: the PLC on a TCP port, its exposures for a camera. Stops when
/// dropped.
pub struct SimServer {
    addr: SocketAddr,
    shared: Arc<Shared>,
    stop: Option<tokio::sync::oneshot::Sender<()>>,
    thread: Option<std::thread::JoinHandle<()>>,
    frames: Option<mpsc::Receiver<TriggeredExposure>>,
}

impl std::fmt::Debug for SimServer {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("SimServer")
            .field("addr", &self.addr)
            .finish_non_exhaustive()
    }
}

impl SimServer {
    /// Starts the PLC on `bind` (port 0: an ephemeral port; see [`SimServer::addr`]).
    ///
    /// # Errors
    /// [`SimServerError::Bind`].
    pub fn start(cfg: SimConfig, bind: SocketAddr) -> Result<Self, SimServerError> {
        let std_listener = std::net::TcpListener::bind(bind)
            .map_err(|source| SimServerError::Bind { addr: bind, source })?;
        std_listener
            .set_nonblocking(true)
            .map_err(|source| SimServerError::Bind { addr: bind, source })?;
        let addr = std_listener
            .local_addr()
            .map_err(|source| SimServerError::Bind { addr: bind, source })?;
        let reset_at = cfg.faults.reset_at_s;
        let shared = Arc::new(Shared {
            silent_at_s: cfg.faults.silent_at_s,
            latency: Duration::from_secs_f64(cfg.latency_ms.max(0.0) * 1e-3),
            plc: Mutex::new(Plc::new(cfg)),
            t0: Instant::now(),
        });
        let (stop_tx, stop_rx) = tokio::sync::oneshot::channel::<()>();
        let (frame_tx, frame_rx) = mpsc::sync_channel::<TriggeredExposure>(256);
        let sh = shared.clone();
        let thread = std::thread::Builder::new()
            .name("gonio-plc-sim".into())
            .spawn(move || {
                let rt = match tokio::runtime::Builder::new_multi_thread()
                    .worker_threads(2)
                    .enable_all()
                    .build()
                {
                    Ok(rt) => rt,
                    Err(_) => return,
                };
                rt.block_on(async move {
                    let Ok(listener) = tokio::net::TcpListener::from_std(std_listener) else {
                        return;
                    };
                    let server = Server::new(listener);
                    let svc = PlcService(sh.clone());
                    let on_connected = move |stream, socket_addr| {
                        let svc = svc.clone();
                        async move {
                            let _ = stream_nodelay(&stream);
                            accept_tcp_connection(stream, socket_addr, move |_| {
                                Ok(Some(svc.clone()))
                            })
                        }
                    };
                    // The scan: 1 ms ticks, exposures to the camera.
                    let scan_sh = sh.clone();
                    let scan = async move {
                        let mut tick = tokio::time::interval(Duration::from_millis(1));
                        tick.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Skip);
                        loop {
                            tick.tick().await;
                            let now = scan_sh.now();
                            let ex = {
                                let mut p = scan_sh.plc.lock().unwrap_or_else(|e| e.into_inner());
                                p.advance(now);
                                p.take_exposures()
                            };
                            for e in ex {
                                // A camera that cannot keep up drops frames, as a real one does.
                                let _ = frame_tx.try_send(e);
                            }
                            if reset_at.is_some_and(|x| now >= x) {
                                break;
                            }
                        }
                    };
                    let abort = async move {
                        tokio::select! {
                            _ = stop_rx => {}
                            _ = scan => {}
                        }
                    };
                    let _ = server.serve_until(&on_connected, |_| {}, abort).await;
                });
                rt.shutdown_timeout(Duration::from_millis(100));
            })
            .ok();
        Ok(SimServer {
            addr,
            shared,
            stop: Some(stop_tx),
            thread,
            frames: Some(frame_rx),
        })
    }

    /// The address the PLC listens on.
    pub fn addr(&self) -> SocketAddr {
        self.addr
    }

    /// The exposures the PLC triggers (once: the camera takes them).
    pub fn take_frames(&mut self) -> Option<mpsc::Receiver<TriggeredExposure>> {
        self.frames.take()
    }

    /// The parts so far with their truth.
    pub fn truth(&self) -> Vec<TruthPart> {
        let mut p = self.shared.plc.lock().unwrap_or_else(|e| e.into_inner());
        p.advance(self.shared.now());
        p.truth()
    }

    /// The station's true constants.
    pub fn station_truth(&self) -> gonio_sim::station::StationTruth {
        self.shared
            .plc
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .station_truth()
    }

    /// Stops the server and waits for its thread.
    pub fn stop(&mut self) {
        if let Some(s) = self.stop.take() {
            let _ = s.send(());
        }
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

impl Drop for SimServer {
    fn drop(&mut self) {
        self.stop();
    }
}

fn stream_nodelay(s: &tokio::net::TcpStream) -> std::io::Result<()> {
    s.set_nodelay(true)
}

/// The in-process camera stand-in: the PLC's exposures as the twin's fast fidelity reports them
/// (the ring's column from the geometry plus the detector's noise), numbered by trigger.
#[derive(Debug)]
pub struct SimTriggered {
    rx: mpsc::Receiver<TriggeredExposure>,
}

impl SimTriggered {
    /// The camera over a server's exposures.
    pub fn new(rx: mpsc::Receiver<TriggeredExposure>) -> Self {
        SimTriggered { rx }
    }
}

/// The stand-in camera's error: the station is gone.
#[derive(Debug, Error)]
#[error("simulated camera: the station stopped sending frames")]
pub struct SimCameraGone;

impl DeviceError for SimCameraGone {
    fn kind(&self) -> DeviceErrorKind {
        DeviceErrorKind::Communication
    }
}

impl TriggeredCamera for SimTriggered {
    type Error = SimCameraGone;
    fn next_frame(&mut self, timeout: Duration) -> Result<Option<TriggeredFrame>, SimCameraGone> {
        match self.rx.recv_timeout(timeout) {
            Ok(e) => Ok(Some(TriggeredFrame {
                frame_id: e.frame_id,
                timestamp_s: Some(e.exposure.start_s),
                reading: e.fast,
            })),
            Err(mpsc::RecvTimeoutError::Timeout) => Ok(None),
            Err(mpsc::RecvTimeoutError::Disconnected) => Err(SimCameraGone),
        }
    }
}

/// Pixels at the start of every simulated frame that carry its trigger count (4 bytes, most
/// significant first): the simulated camera's embedded frame counter, as a real camera's chunk
/// data (`ChunkCounterValue`) carries its trigger counter.
pub const STAMP_PIXELS: usize = 4;

/// Writes trigger count `k` into the first [`STAMP_PIXELS`] pixels.
pub fn stamp_trigger(pixels: &mut [u8], k: u64) {
    if pixels.len() >= STAMP_PIXELS {
        pixels[..STAMP_PIXELS].copy_from_slice(&(k as u32).to_be_bytes());
    }
}

/// Reads the trigger count of [`stamp_trigger`].
pub fn read_trigger(pixels: &[u8]) -> Option<u64> {
    (pixels.len() >= STAMP_PIXELS)
        .then(|| u32::from_be_bytes([pixels[0], pixels[1], pixels[2], pixels[3]]) as u64)
}

/// A frame source whose frames carry their trigger count in their first pixels (the simulated
/// camera's embedded counter, [`stamp_trigger`]): each frame's stamp index becomes
/// its trigger count, for [`DetectorTriggered`](crate::triggered::DetectorTriggered).
#[derive(Debug)]
pub struct StampedSource<S>(pub S);

impl<S: FrameSource> FrameSource for StampedSource<S> {
    type Error = S::Error;
    fn next_frame(&mut self, pixels: &mut Vec<u8>) -> Result<Option<FrameHeader>, S::Error> {
        let Some(mut h) = self.0.next_frame(pixels)? else {
            return Ok(None);
        };
        if let Some(k) = read_trigger(pixels) {
            h.stamp.index = k;
            // The counter's pixels back to their neighbours' grey, for the detector.
            let fill = pixels.get(STAMP_PIXELS).copied().unwrap_or(0);
            for p in pixels.iter_mut().take(STAMP_PIXELS) {
                *p = fill;
            }
        }
        Ok(Some(h))
    }
}

/// The simulated camera's sensor: waits for the PLC's next trigger and renders the grating as
/// the twin has it at that exposure (angle at mid-exposure, offset, defocus), with the trigger
/// count stamped into the first pixels. For a GigE Vision fake camera's per-frame callback.
pub struct SimRenderer {
    rx: mpsc::Receiver<TriggeredExposure>,
    renderer: gonio_sim::frames::GratingRenderer,
    /// Frames rendered.
    pub rendered: u64,
    /// Triggers dropped because the renderer was behind.
    pub dropped: u64,
}

impl std::fmt::Debug for SimRenderer {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("SimRenderer")
            .field("rendered", &self.rendered)
            .finish_non_exhaustive()
    }
}

/// The simulated station's optics for a `width × height` window: the seed's, with the plant's
/// ring (the default recipe's 20 mm ring, whose chord the twin's columns have too).
fn station_optics(width: u32, height: u32) -> gonio_vision::Optics {
    gonio_vision::Optics {
        window_width_px: width,
        window_height_px: height,
        ring_radius_um: gonio_sim::station::PlantConfig::default().ring_radius_um,
        ..gonio_vision::Optics::default()
    }
}

impl SimRenderer {
    /// A renderer of `scene` through the station's optics for the exposures of `rx`.
    ///
    /// # Errors
    /// An invalid scene.
    pub fn new(
        rx: mpsc::Receiver<TriggeredExposure>,
        scene: gonio_sim::frames::GratingScene,
    ) -> Result<Self, gonio_sim::SimError> {
        let d = gonio_vision::Optics::default();
        let optics = station_optics(d.window_width_px, d.window_height_px);
        Ok(SimRenderer {
            rx,
            renderer: gonio_sim::frames::GratingRenderer::new(&optics, scene)?,
            rendered: 0,
            dropped: 0,
        })
    }

    /// The frame size rendered, px.
    pub fn size(&self) -> (usize, usize) {
        self.renderer.size()
    }

    /// Fills `pixels` (`width × height`, row-major Mono8) with the next triggered exposure;
    /// blocks until the PLC triggers. The window follows `width × height` (centred on the
    /// sensor); a size the optics refuse, or a frame after the station stopped, is left
    /// mid-grey with trigger count 0.
    pub fn fill(&mut self, width: usize, height: usize, pixels: &mut [u8]) {
        let x = loop {
            match self.rx.recv_timeout(Duration::from_millis(200)) {
                Ok(mut x) => {
                    // A renderer that cannot keep up serves the newest trigger (the others are
                    // dropped, as a camera drops frames it cannot send).
                    while let Ok(newer) = self.rx.try_recv() {
                        x = newer;
                        self.dropped += 1;
                    }
                    break Some(x);
                }
                Err(mpsc::RecvTimeoutError::Timeout) => continue,
                Err(mpsc::RecvTimeoutError::Disconnected) => break None,
            }
        };
        // The camera renders the window its client asks for (a real camera's ROI), where the
        // optics allow it.
        if self.renderer.size() != (width, height) {
            let optics = station_optics(
                u32::try_from(width).unwrap_or(u32::MAX),
                u32::try_from(height).unwrap_or(u32::MAX),
            );
            if let Ok(r) =
                gonio_sim::frames::GratingRenderer::new(&optics, self.renderer.scene().clone())
            {
                self.renderer = r;
            }
        }
        let (w, h) = self.renderer.size();
        let n = (width * height).min(pixels.len());
        let px = &mut pixels[..n];
        match x {
            Some(x) if (w, h) == (width, height) => {
                if x.exposure.render(&self.renderer, px).is_err() {
                    px.fill(128);
                }
                stamp_trigger(px, x.frame_id);
                self.rendered += 1;
            }
            _ => {
                px.fill(128);
                stamp_trigger(px, 0);
            }
        }
    }
}
