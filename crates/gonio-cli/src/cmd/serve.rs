//! `gonio serve`: the station's dashboard in the browser (live view, history, calibrations,
//! JSON API), optionally with the simulated station running and publishing to it.

use crate::db::NewStore;
use crate::station::{self, FidelityArg, StrategyArg, load_recipe};
use anyhow::{Context, Result, bail};
use gonio_cli::flag;
use gonio_core::bound::Bound;
use gonio_opcua::feed::Feed;
use gonio_sim::station::{BatchConfig, Fidelity, FrameTiming, Pace, PartDone};
use gonio_station::Recipe;
use gonio_station::tap::{FrameTap, SeenFrame};
use gonio_web::link_watch::{self, LinkWatch};
use gonio_web::live::{Hub, LiveObserver};
use gonio_web::secret::{self, Permissions};
use gonio_web::thumbnails::Thumbnails;
use std::net::{SocketAddr, TcpListener};
use std::path::PathBuf;
use std::sync::Arc;

/// A station to run under the dashboard.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum StationArg {
    /// The simulated station (the digital twin), paced to the wall clock.
    Sim,
    /// A station through its PLC (--plc modbus://HOST:PORT) and its camera (--camera ID), as
    /// `gonio mount --plc` runs it.
    Plc,
}

/// Arguments of `gonio serve`.
#[derive(Debug, clap::Args)]
#[command(after_help = "\
Serves the dashboard of a results store: a live view of the station (the current frame with the
ring's detected edges, the ring column c(θ) filling in as the turn proceeds and then its fit,
each push as it happens, counters beside the figures of Yu et al., 2024), the history of parts
with filters and a page per part with its plots, the calibration certificates, and a read-only
JSON API:
  GET /api/parts         the same array as `gonio parts --json` (filters: since, verdict,
                         serial, batch, limit)
  GET /api/parts/{id}    one part
  GET /api/events        server-sent events (part, phase, frames, turn, push, finished, stored)
  GET /api/stats, /api/calibrations, /api/calibrations/{id}, /api/live, /api/status

The dashboard only reads: nothing in it changes the station or the store. It listens on
127.0.0.1 (this machine only) over plain HTTP unless --allow-remote is given with another
address; off loopback it is served only over TLS (--tls-cert, --tls-key) and every request must
carry `Authorization: Bearer TOKEN` with the token of --token-file (401 without it): without
all three it refuses to start. Every request's Host must name the address it came in on,
`localhost` on loopback, or a --host-name (DNS rebinding); a client has 10 s to send a
request's headers, and at most 256 connections are open at once.

With --station sim, the simulated station mounts --parts parts (seed --seed) in step with the
wall clock (--speed times real time), committing each part to --db as it finishes, exactly as
`gonio mount --sim --db` does; the dashboard stays up after the batch until Ctrl-C.

With --opcua HOST:PORT the same process serves the station to the line's MES over OPC UA
(OPC 40001-1 Machinery, OPC 40001-101 Result Transfer; docs/opcua.md): Objects/Machines/NAME
with Identification, Monitoring (live), ResultManagement (results from --db, an event per
part). Read-only; SecurityPolicy None only on loopback and only with --opcua-anonymous, users
(--opcua-users) only over Basic256Sha256 or Aes Sign & Encrypt with --opcua-pki. It prints
`OPC UA on opc.tcp://HOST:PORT/` when it listens. Without --station it serves the results of
--station-name.

With --station plc, --parts parts are mounted through the station's PLC (--plc
modbus://HOST:PORT, register map --plc-map, docs/plc-interface.md) and its GenICam camera
(--camera ID), at the station's own pace: the same controller, records and store as
`gonio mount --plc --db`, each part committed as it ends. A device error ends its part
rejected_device_error and the batch; the dashboard shows why and stays up until Ctrl-C.
--seed, --fidelity, --speed and --resume are for the simulated station only.

Examples:
  gonio serve --db results.sqlite
  gonio serve --db results.sqlite --station sim --parts 25 --seed 7
  gonio serve --db results.sqlite --station sim --parts 100 --seed 7 --speed 4 --addr 127.0.0.1:9000
  gonio serve --db results.sqlite --station plc --plc modbus://station-plc:502 --camera Basler-1234 --parts 50
  gonio serve --db results.sqlite --station sim --parts 3 --seed 1 --opcua 127.0.0.1:4840 --opcua-anonymous
  gonio serve --db results.sqlite --station-name line-3 --opcua 0.0.0.0:4840 --opcua-pki opcua-pki \\
      --opcua-users mes-users.txt
  gonio serve --db postgres://gonio@/results?host=/run/postgresql --addr 0.0.0.0:8443 --allow-remote \\
      --tls-cert station.crt --tls-key station.key --token-file dashboard.token --host-name station.lab
  curl --cacert station.crt -H \"Authorization: Bearer $(cat dashboard.token)\" https://station.lab:8443/api/stats")]
#[command(group(clap::ArgGroup::new("serving").args(["station", "opcua"]).multiple(true)))]
pub struct Args {
    /// The results store: a SQLite file (it must exist, unless --station runs and fills it)
    /// or a postgres:// URL.
    #[arg(long, value_name = "PATH|postgres://…")]
    pub db: String,
    /// Address to listen on (port 0: any free port, printed at start).
    #[arg(long, default_value = "127.0.0.1:8080", value_name = "HOST:PORT")]
    pub addr: String,
    /// Allow listening on an address other than loopback (the dashboard is then reachable
    /// from the network; it needs --tls-cert, --tls-key and --token-file).
    #[arg(long)]
    pub allow_remote: bool,
    /// Serve over TLS with this certificate chain (PEM, the server's certificate first).
    #[arg(long, value_name = "PEM", requires = "tls_key")]
    pub tls_cert: Option<PathBuf>,
    /// The private key of --tls-cert (PEM).
    #[arg(long, value_name = "PEM", requires = "tls_cert")]
    pub tls_key: Option<PathBuf>,
    /// Require `Authorization: Bearer TOKEN` on every request, TOKEN being this file's text
    /// (at least 16 visible ASCII characters; a final newline is dropped).
    #[arg(long, value_name = "FILE")]
    pub token_file: Option<PathBuf>,
    /// Use a --token-file or --tls-key that its group or others may read or write (with a
    /// warning); without it such a file is refused, as ssh refuses a private key.
    #[arg(long)]
    pub allow_insecure_permissions: bool,
    /// A host name the dashboard is reached by (besides its address, and `localhost` on
    /// loopback); requests naming another host are refused (421). Repeatable.
    #[arg(long, value_name = "NAME")]
    pub host_name: Vec<String>,
    /// Run this station and show it live.
    #[arg(long, value_enum)]
    pub station: Option<StationArg>,
    /// The station's PLC with --station plc: modbus://HOST:PORT (Modbus TCP,
    /// docs/plc-interface.md).
    #[arg(long, value_name = "modbus://HOST:PORT")]
    pub plc: Option<String>,
    /// The station's camera with --station plc (a GenICam id, as `gonio camera list` shows
    /// it), triggered by the PLC.
    #[arg(long, value_name = "ID")]
    pub camera: Option<String>,
    /// The PLC's register map (TOML; default: examples/plc/modbus-map.toml's values).
    #[arg(long, value_name = "FILE")]
    pub plc_map: Option<PathBuf>,
    /// Parts the station mounts.
    #[arg(long, default_value_t = 25, requires = "station", value_parser = flag::whole::<usize>(station::PARTS))]
    pub parts: usize,
    /// Seed of the simulated station (same seed, same records) [default: 1].
    #[arg(long, requires = "station")]
    pub seed: Option<u64>,
    /// Push strategy (the default, as in `gonio mount`: the rod watched live through the
    /// camera).
    #[arg(long, value_enum, default_value = "live", requires = "station")]
    pub strategy: StrategyArg,
    /// Frame fidelity of the simulation [default: fast].
    #[arg(long, value_enum, requires = "station")]
    pub fidelity: Option<FidelityArg>,
    /// Recipe (TOML) for the grating type.
    #[arg(long, requires = "station")]
    pub recipe: Option<PathBuf>,
    /// Simulated seconds per wall-clock second (1: real time, as the station runs)
    /// [default: 1].
    #[arg(long, requires = "station", value_parser = flag::real(SPEED))]
    pub speed: Option<f64>,
    /// The station's name in its records and the results store, and its OPC UA machine's (with
    /// --opcua and no --station, the station whose results are served) [default: sim for the
    /// simulated station, this machine's host name otherwise].
    #[arg(long, value_name = "NAME", requires = "serving")]
    pub station_name: Option<String>,
    /// Continue the station's interrupted batch with these settings (as `gonio mount --resume`).
    #[arg(long, requires = "station")]
    pub resume: bool,
    /// The OPC UA server.
    #[command(flatten)]
    pub opcua: crate::opcua::Args,
}

/// The address to listen on: loopback, or another address only with `allow_remote` and TLS
/// and a token (`missing`: the flags of those that are missing, if any).
fn address(addr: &str, allow_remote: bool, missing: &[&str]) -> Result<SocketAddr> {
    let sa: SocketAddr = addr.parse().with_context(|| {
        format!("--addr {addr}: expected HOST:PORT with an IP address, e.g. 127.0.0.1:8080")
    })?;
    if !sa.ip().to_canonical().is_loopback() {
        if !allow_remote {
            bail!(
                "--addr {addr}: not a loopback address; listening on the network needs --allow-remote (with --tls-cert, --tls-key and --token-file)"
            );
        }
        if !missing.is_empty() {
            bail!(
                "--addr {addr} --allow-remote: off loopback the dashboard is served only over TLS with a bearer token; missing {}",
                missing.join(", ")
            );
        }
    }
    Ok(sa)
}

/// The serving options of the flags: TLS and the token read from their files.
fn serve_options(a: &Args) -> Result<gonio_web::ServeOptions> {
    let mut o = gonio_web::ServeOptions::default();
    let permissions = if a.allow_insecure_permissions {
        Permissions::AllowInsecure
    } else {
        Permissions::Strict
    };
    let secret = |p: &PathBuf, flag: &str| -> Result<Vec<u8>> {
        let s = secret::read(p, permissions).with_context(|| flag.to_string())?;
        if let Some(w) = s.warning {
            gonio_cli::note!("warning: {flag} {w}");
        }
        Ok(s.bytes)
    };
    if let (Some(c), Some(k)) = (&a.tls_cert, &a.tls_key) {
        let cert = std::fs::read(c).with_context(|| format!("--tls-cert {}", c.display()))?;
        let key = secret(k, "--tls-key")?;
        o.tls =
            Some(gonio_web::Tls::from_pem(&cert, &key).with_context(|| {
                format!("--tls-cert {} --tls-key {}", c.display(), k.display())
            })?);
    }
    if let Some(f) = &a.token_file {
        let bytes = secret(f, "--token-file")?;
        let text = String::from_utf8(bytes)
            .map_err(|_| anyhow::anyhow!("--token-file {}: not UTF-8 text", f.display()))?;
        o.token = Some(
            gonio_web::BearerToken::new(&text)
                .with_context(|| format!("--token-file {}", f.display()))?,
        );
    }
    for n in &a.host_name {
        if n.is_empty()
            || n.parse::<std::net::IpAddr>().is_ok()
            || !n
                .bytes()
                .all(|b| b.is_ascii_alphanumeric() || b == b'-' || b == b'.')
        {
            bail!("--host-name {n:?}: expected a DNS name (letters, digits, - and .)");
        }
    }
    o.host_names = a.host_name.clone();
    Ok(o)
}

/// Slowest and fastest pace of the simulated station under the dashboard (simulated seconds
/// per wall-clock second): slower would wait for ages between frames, faster is `mount --sim`.
const SPEED: Bound = Bound::new(1e-3, 1e6, "simulated s per s");

impl Args {
    /// `--speed`, 1 (real time) when not given.
    fn speed(&self) -> f64 {
        self.speed.unwrap_or(1.0)
    }

    /// `--seed`, 1 when not given.
    fn seed(&self) -> u64 {
        self.seed.unwrap_or(1)
    }
}

/// The flags given, of `flags` (whether given, name), said as the subject of a sentence:
/// "--seed is", "--speed, --resume are"; `None` when none is given.
fn given(flags: &[(bool, &str)]) -> Option<String> {
    let names: Vec<&str> = flags.iter().filter(|f| f.0).map(|f| f.1).collect();
    (!names.is_empty()).then(|| {
        let verb = if names.len() == 1 { "is" } else { "are" };
        format!("{} {verb}", names.join(", "))
    })
}

/// Checks that the station's flags fit the station: --plc and --camera with --station plc
/// (and only with it), no flag of the simulation with it.
fn check_station_flags(a: &Args) -> Result<()> {
    if a.station == Some(StationArg::Plc) {
        let sim = given(&[
            (a.seed.is_some(), "--seed"),
            (a.fidelity.is_some(), "--fidelity"),
            (a.speed.is_some(), "--speed"),
            (a.resume, "--resume"),
        ]);
        if let Some(sim) = sim {
            bail!(
                "{sim} for --station sim only: --station plc mounts real parts at the station's own pace"
            );
        }
        if a.plc.is_none() || a.camera.is_none() {
            bail!("--station plc needs --plc modbus://HOST:PORT and --camera ID");
        }
    } else if let Some(plc) = given(&[
        (a.plc.is_some(), "--plc"),
        (a.camera.is_some(), "--camera"),
        (a.plc_map.is_some(), "--plc-map"),
    ]) {
        bail!("{plc} for --station plc only");
    }
    Ok(())
}

/// Runs `gonio serve`.
pub fn run(a: Args) -> Result<()> {
    check_station_flags(&a)?;
    let recipe = match &a.recipe {
        Some(p) => load_recipe(&gonio_io::input::Inputs::new(), p)?,
        None => Recipe::default(),
    };
    let mut missing = Vec::new();
    if a.tls_cert.is_none() {
        missing.extend(["--tls-cert", "--tls-key"]);
    }
    if a.token_file.is_none() {
        missing.push("--token-file");
    }
    let options = serve_options(&a)?;
    let sa = address(&a.addr, a.allow_remote, &missing)?;
    // Open (and migrate) the store before anything listens: a bad --db fails here. Without a
    // station the dashboard only reads: it never creates a store; with one, a store created
    // here is removed again if the station cannot be set up.
    let created = NewStore::before_open(&a.db);
    drop(if a.station.is_some() {
        crate::db::open(&a.db)?
    } else {
        crate::db::open_existing(&a.db)?
    });
    let addr = &a.addr;
    let listener =
        TcpListener::bind(sa).with_context(|| format!("--addr {addr}: cannot listen"))?;
    let bound = listener.local_addr()?;
    let hub = Hub::new(a.station.is_some());
    let mode = match a.station {
        Some(StationArg::Sim) => gonio_opcua::StationMode::Sim,
        Some(StationArg::Plc) => gonio_opcua::StationMode::Plc,
        None => gonio_opcua::StationMode::None,
    };
    let station_name = station::station_name(
        a.station_name.as_deref(),
        matches!(a.station, Some(StationArg::Sim)),
    );
    let (feed, opcua) = crate::opcua::start(&a.opcua, &a.db, &station_name, mode, &hub)?;
    let station = match a.station {
        Some(StationArg::Sim) => {
            let cfg = BatchConfig {
                parts: a.parts,
                strategy: a.strategy.into(),
                fidelity: a.fidelity.unwrap_or(FidelityArg::Fast).into(),
                recipe,
                ..BatchConfig::default()
            };
            let prepared = station::prepare(
                &cfg,
                a.seed(),
                &station::Target {
                    db: Some(&a.db),
                    resume: a.resume,
                    station: &station_name,
                },
            )?;
            Some(spawn_station(prepared, cfg, &a, hub.clone(), feed))
        }
        Some(StationArg::Plc) => Some(spawn_plc(
            crate::plc::Request {
                url: a.plc.clone().unwrap_or_default(),
                camera: a.camera.clone().unwrap_or_default(),
                plc_map: a.plc_map.clone(),
                recipe,
                strategy: a.strategy,
                parts: a.parts,
                db: Some(a.db.clone()),
                station_name: station_name.clone(),
            },
            hub.clone(),
            feed,
        )?),
        None => None,
    };
    created.keep();
    gonio_cli::note!(
        "gonio dashboard on {}://{bound}/ (read-only{}{}); Ctrl-C stops",
        if options.tls.is_some() {
            "https"
        } else {
            "http"
        },
        if options.token.is_some() {
            ", bearer token required"
        } else {
            ""
        },
        match a.station {
            Some(StationArg::Sim) => ", simulated station running".to_string(),
            Some(StationArg::Plc) => format!(
                ", station running through {} and camera {}",
                a.plc.as_deref().unwrap_or_default(),
                a.camera.as_deref().unwrap_or_default()
            ),
            None => String::new(),
        }
    );
    let served = gonio_web::serve_blocking(listener, &a.db, hub, options);
    drop(opcua);
    drop(station);
    served.map_err(|e| anyhow::anyhow!("dashboard: {e}"))
}

/// Runs the station on a thread of its own, publishing to `hub` and committing to the store.
fn spawn_station(
    prepared: station::Start,
    cfg: BatchConfig,
    a: &Args,
    hub: Arc<Hub>,
    feed: Arc<Feed>,
) -> std::thread::JoinHandle<()> {
    let timing = FrameTiming::shared();
    {
        let timing = timing.clone();
        hub.set_status_source(Box::new(move || {
            timing
                .lock()
                .map(|t| serde_json::to_value(t.summary()).unwrap_or_default())
                .unwrap_or_default()
        }));
    }
    let pace = Pace::new(a.speed(), timing);
    let seed = a.seed();
    std::thread::spawn(move || {
        let p = match prepared {
            station::Start::Run(p) => p,
            station::Start::Complete(note) => {
                gonio_cli::note!("{note}");
                hub.batch_finished(&note);
                return;
            }
        };
        if let Some(note) = &p.note {
            gonio_cli::note!("{note}");
        }
        let mut live = (LiveObserver::new(hub.clone()), feed.observer());
        let h = hub.clone();
        // The live thumbnail: a rendered frame (full fidelity only).
        let mut thumbnails = Thumbnails::new(hub.clone());
        let tap = |f: &SeenFrame<'_>| thumbnails.show(f);
        let frames = cfg.fidelity == Fidelity::Frames;
        let report = station::run(
            *p,
            &cfg,
            seed,
            station::Run {
                observer: &mut live,
                pace: Some(pace),
                frame_tap: frames.then(|| Box::new(tap) as FrameTap<'_>),
                // Every part is in the store as it ends; the report keeps only the summary.
                discard_parts: true,
            },
            &mut |d: &PartDone, id| {
                if let Some(id) = id {
                    h.part_stored(id, &d.part.record.serial, d.part.record.result.name());
                    feed.part_stored();
                }
            },
        );
        batch_finished(
            &hub,
            report.map(|r| match &r.stopped {
                Some(why) => format!("the batch {why} (recipe on_device_error = \"stop\")"),
                None => format!("batch done: {} parts mounted", r.summary.parts),
            }),
        );
    })
}

/// Says how the batch ended (its message, or the error that stopped the station) on standard
/// error and to the dashboard, which stays up.
fn batch_finished(hub: &Hub, ended: Result<String>) {
    let message = ended.unwrap_or_else(|e| {
        let m = format!("station stopped: {}", gonio_io::input::one_line(&e));
        gonio_cli::note!("error: {m}");
        m
    });
    gonio_cli::note!("{message}; the dashboard stays up until Ctrl-C");
    hub.batch_finished(&message);
}

/// Runs the batch through the PLC on a thread of its own (the station's link and camera live
/// there), publishing to `hub` (the controller's steps, a thumbnail of the camera's frames, the
/// link's figures for `/api/status`) and committing every part to the store as `gonio mount
/// --plc --db` does. Returns once the station is open: its setup's error (no PLC, no camera, a
/// bad map or store) is this function's.
fn spawn_plc(
    request: crate::plc::Request,
    hub: Arc<Hub>,
    feed: Arc<Feed>,
) -> Result<std::thread::JoinHandle<()>> {
    let (opened, is_open) = std::sync::mpsc::channel::<Result<()>>();
    let snapshot = link_watch::snapshot(&hub);
    let address = request.url.clone();
    let thread = std::thread::spawn(move || {
        let mut thumbnails = Thumbnails::new(hub.clone());
        let tap: FrameTap = Box::new(move |f: &SeenFrame<'_>| thumbnails.show(f));
        let batch = match crate::plc::open(request, Some(tap)) {
            Ok(b) => {
                let _ = opened.send(Ok(()));
                b
            }
            Err(e) => {
                let _ = opened.send(Err(e));
                return;
            }
        };
        let mut watch = LinkWatch::new(batch.link_figures(), address, snapshot);
        watch.refresh(true);
        let mut live = (
            (LiveObserver::new(hub.clone()), feed.observer()),
            &mut watch,
        );
        let report = batch.run(&mut live, &mut |d, id| {
            if let Some(id) = id {
                hub.part_stored(id, &d.record.serial, d.record.result.name());
                feed.part_stored();
            }
        });
        // The batch's last requests (the station left safe) included.
        watch.refresh(true);
        batch_finished(
            &hub,
            report.map(|r| match &r.stopped {
                Some(why) => format!("the batch {why}; the records so far are kept"),
                None => format!(
                    "batch done: {} parts mounted through {}",
                    r.summary.parts, r.plc
                ),
            }),
        );
    });
    match is_open.recv() {
        Ok(Ok(())) => Ok(thread),
        Ok(Err(e)) => {
            let _ = thread.join();
            Err(e)
        }
        Err(_) => bail!("the station's thread ended before the station was open"),
    }
}
