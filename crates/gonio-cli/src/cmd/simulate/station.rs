//! `gonio simulate station`: the mounting station's twin as its own process: a Modbus TCP PLC
//! (docs/plc-interface.md) with the twin's plant, and the camera it triggers.

use anyhow::{Context, Result, anyhow};
use gonio_cli::flag;
use gonio_core::bound::Bound;
use gonio_io::json;
use gonio_plc::sim::{SimConfig, SimServer, TruthPart};
use std::net::SocketAddr;
use std::path::{Path, PathBuf};
use std::time::Duration;

/// The scene the station's camera renders.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum SceneArg {
    /// The ring alone: noise and blur only.
    Clean,
    /// A typical grating near its ring (default).
    Realistic,
    /// Everything at once, close to the ring.
    Dense,
}

/// Arguments of `gonio simulate station`.
#[derive(Debug, clap::Args)]
#[command(after_help = "\
Serves the station's PLC on --plc (Modbus TCP, the registers of docs/plc-interface.md) with
the digital twin's plant: motion profiles on the wall clock, link latency, the rod's travel
limit, the watchdog on the client's heartbeat, fault bits, and the part handshake (a part is
present; `part done` unloads it and the next arrives with a new random mounting). The PLC
triggers the station's camera and latches the servo angle of every trigger.

--truth writes every part's true initial and final eccentricity (rewritten as parts finish):
[{\"part\": 1, \"true_initial_e_um\": …, \"true_final_e_um\": …}, …].
Runs until interrupted (Ctrl-C, SIGTERM).

Examples:
  gonio simulate station --plc 127.0.0.1:1502 --seed 7 --truth truth.json
  gonio mount --plc modbus://127.0.0.1:1502 --camera Aravis-Fake-GONIOSTATION --station-name line-3 --parts 3 --json mount.json

The PLC says it is simulated (bit 7 of its status word), so `gonio mount --plc` opens its
camera as the simulated one and records its parts as the digital twin's.")]
pub struct Args {
    /// Listen for the Modbus TCP client here (HOST:PORT; port 0: any free port, printed).
    #[arg(long, value_name = "HOST:PORT")]
    pub plc: SocketAddr,
    /// The camera's address (the GigE Vision camera listens on its port 3956).
    #[arg(long, value_name = "ADDR", default_value = "127.0.0.1")]
    pub camera_addr: std::net::IpAddr,
    /// Seed: the station's constants and every part's mounting.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Write the parts' true eccentricities here (JSON), rewritten as each part finishes.
    #[arg(long, value_name = "TRUTH.json")]
    pub truth: Option<PathBuf>,
    /// The scene the camera renders (docs/scenes.md).
    #[arg(long, value_enum, default_value = "realistic")]
    pub scene: SceneArg,
    /// Delay added to every Modbus reply, ms.
    #[arg(long, default_value_t = 0.5, value_name = "MS", value_parser = flag::real(LATENCY_MS))]
    pub latency_ms: f64,
}

/// `--latency-ms`: up to a second, far above any PLC's.
const LATENCY_MS: Bound = Bound::new(0.0, 1000.0, "ms");

fn write_truth(path: &Path, truth: &[TruthPart]) -> Result<()> {
    let bytes = json::to_bytes(truth).map_err(|e| anyhow!("{}: {e}", path.display()))?;
    let dir = path
        .parent()
        .filter(|p| !p.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    let mut f = tempfile::NamedTempFile::new_in(dir)
        .with_context(|| format!("{}: cannot write", path.display()))?;
    std::io::Write::write_all(&mut f, &bytes)
        .with_context(|| format!("{}: cannot write", path.display()))?;
    f.persist(path)
        .map_err(|e| anyhow!("{}: cannot write: {}", path.display(), e.error))?;
    Ok(())
}

/// Runs `gonio simulate station`.
pub fn run(a: Args) -> Result<()> {
    let mut cfg = SimConfig::new(a.seed);
    cfg.latency_ms = a.latency_ms;
    let mut server = SimServer::start(cfg, a.plc).map_err(|e| anyhow!("--plc {}: {e}", a.plc))?;
    let frames = server
        .take_frames()
        .ok_or_else(|| anyhow!("the station's frames are taken"))?;
    let (camera, keep) = camera::serve(frames, a.camera_addr, a.scene, a.seed)?;
    gonio_cli::note!(
        "station PLC on {} (Modbus TCP), camera {}; seed {}; Ctrl-C stops",
        server.addr(),
        camera,
        a.seed
    );
    let stop = std::sync::Arc::new(std::sync::atomic::AtomicBool::new(false));
    #[cfg(unix)]
    {
        use signal_hook::consts::{SIGINT, SIGTERM};
        for s in [SIGINT, SIGTERM] {
            signal_hook::flag::register(s, stop.clone())
                .map_err(|e| anyhow!("cannot handle signal {s}: {e}"))?;
        }
    }
    let mut written: Vec<TruthPart> = Vec::new();
    while !stop.load(std::sync::atomic::Ordering::Relaxed) {
        std::thread::sleep(Duration::from_millis(100));
        if let Some(p) = &a.truth {
            let t = server.truth();
            if t != written {
                write_truth(p, &t)?;
                written = t;
            }
        }
    }
    // The PLC first: its frames end, so the camera's callback returns and the camera stops.
    server.stop();
    drop(keep);
    Ok(())
}

/// The camera the simulated PLC triggers: a GigE Vision camera rendering the grating at each
/// latched angle (feature `genicam`).
mod camera {
    use super::SceneArg;
    use anyhow::Result;
    use gonio_plc::sim::TriggeredExposure;
    use std::net::IpAddr;
    use std::sync::mpsc::Receiver;

    /// Serves the exposures as a GigE Vision camera on `addr`; returns its id and the camera
    /// (kept alive by the caller).
    #[cfg(feature = "genicam")]
    pub fn serve(
        frames: Receiver<TriggeredExposure>,
        addr: IpAddr,
        scene: SceneArg,
        _seed: u64,
    ) -> Result<(String, Box<dyn std::any::Any>)> {
        use anyhow::anyhow;
        use gonio_sim::frames::{GratingScene, ScenePreset};
        let scene = GratingScene::preset(match scene {
            SceneArg::Clean => ScenePreset::Clean,
            SceneArg::Realistic => ScenePreset::Realistic,
            SceneArg::Dense => ScenePreset::Dense,
        });
        let mut warned = false;
        let mut r =
            gonio_plc::sim::SimRenderer::new(frames, scene).map_err(|e| anyhow!("--scene: {e}"))?;
        let config = gonio_camera::FakeConfig {
            address: addr.to_string(),
            serial: "GONIOSTATION".into(),
            // Above the frame rate of the default recipe's 180-row window (263.7 fps): the
            // PLC's trigger paces the frames, not the camera.
            fps: 300.0,
            ..gonio_camera::FakeConfig::default()
        };
        let cam = gonio_camera::FakeGvCamera::start(
            &config,
            move |info: &gonio_camera::FillInfo, px: &mut [u8]| {
                let (w, h) = (info.width as usize, info.height as usize);
                r.fill(w, h, px);
                if !warned && (w, h) != r.size() {
                    warned = true;
                    gonio_cli::note!(
                        "camera: the client asks {w}×{h} px; the station renders {}×{} (frames left grey)",
                        r.size().0,
                        r.size().1
                    );
                }
            },
        )
        .map_err(|e| anyhow!("--camera-addr {addr}: {e}"))?;
        Ok((format!("{} on {addr}", cam.id()), Box::new(cam)))
    }

    /// Without GenICam nothing takes the frames: the PLC drops them as a camera would.
    #[cfg(not(feature = "genicam"))]
    pub fn serve(
        frames: Receiver<TriggeredExposure>,
        _addr: IpAddr,
        _scene: SceneArg,
        _seed: u64,
    ) -> Result<(String, Box<dyn std::any::Any>)> {
        drop(frames);
        Ok((
            "none (this gonio is built without the genicam feature)".into(),
            Box::new(()),
        ))
    }
}
