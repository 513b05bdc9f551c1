//! `gonio serve --opcua HOST:PORT`: the flags of the OPC UA server and its start beside the
//! dashboard (the server itself is `gonio_opcua`).

use anyhow::{Context, Result, bail};
use gonio_opcua::feed::{Feed, LinkRoundTrips};
use gonio_opcua::security::Security;
use gonio_opcua::users::Users;
use gonio_opcua::{Config, Machine, Running, StationMode};
use gonio_web::live::Hub;
use std::net::{SocketAddr, TcpListener};
use std::path::PathBuf;
use std::sync::Arc;

/// The OPC UA flags of `gonio serve`.
#[derive(Debug, Clone, clap::Args)]
pub struct Args {
    /// Also serve the station's results and live values over OPC UA (OPC 40001-1 Machinery,
    /// OPC 40001-101 Result Transfer) on this address, e.g. 127.0.0.1:4840 (port 0: any free
    /// port; the URL is printed at start). See docs/opcua.md.
    #[arg(long, value_name = "HOST:PORT")]
    pub opcua: Option<String>,
    /// The OPC UA server's PKI directory: its certificate, generated there once
    /// (own/cert.der, private/private.pem) unless --opcua-cert/--opcua-key are given, and the
    /// client certificates it trusts (trusted/; refused ones land in rejected/).
    /// Needed for the encrypted endpoints.
    #[arg(long, value_name = "DIR", requires = "opcua")]
    pub opcua_pki: Option<PathBuf>,
    /// The OPC UA server's certificate (.der or .pem) instead of the generated one.
    #[arg(long, value_name = "FILE", requires_all = ["opcua", "opcua_key"])]
    pub opcua_cert: Option<PathBuf>,
    /// The private key of --opcua-cert (PEM).
    #[arg(long, value_name = "FILE", requires_all = ["opcua", "opcua_cert"])]
    pub opcua_key: Option<PathBuf>,
    /// Users who may log in over an encrypted endpoint: one `NAME:HASH` a line, HASH the
    /// password's argon2 PHC string (e.g. `printf %s "$PW" | argon2 "$(openssl rand -hex
    /// 16)" -id -e`).
    #[arg(long, value_name = "FILE", requires = "opcua")]
    pub opcua_users: Option<PathBuf>,
    /// Allow anonymous sessions (SecurityPolicy None) — on a loopback address only.
    #[arg(long, requires = "opcua")]
    pub opcua_anonymous: bool,
}

/// The PLC link's round trips from the dashboard's snapshot of them (`null` without a PLC).
fn link_from(hub: Arc<Hub>) -> gonio_opcua::feed::LinkSource {
    Box::new(move || {
        let v = hub.plc_status();
        Some(LinkRoundTrips {
            requests: v.get("requests")?.as_u64()?,
            round_trip_p50_ms: v.get("round_trip_p50_ms")?.as_f64()?,
            round_trip_p99_ms: v.get("round_trip_p99_ms")?.as_f64()?,
        })
    })
}

/// Starts the OPC UA server when `--opcua` is given (before the station, so that none of its
/// parts is missed), printing `OPC UA on opc.tcp://HOST:PORT/` once it listens. `station`:
/// the station's name; `mode`: what runs it. The returned feed takes the station's events.
pub fn start(
    a: &Args,
    db: &str,
    station: &str,
    mode: StationMode,
    hub: &Arc<Hub>,
) -> Result<(Arc<Feed>, Option<Running>)> {
    let feed = Feed::new();
    let Some(addr) = &a.opcua else {
        return Ok((feed, None));
    };
    let sa: SocketAddr = addr.parse().with_context(|| {
        format!("--opcua {addr}: expected HOST:PORT with an IP address, e.g. 127.0.0.1:4840")
    })?;
    if a.opcua_anonymous && !sa.ip().to_canonical().is_loopback() {
        bail!(
            "--opcua {addr} --opcua-anonymous: anonymous access is for a loopback address only; off loopback every session needs a user (--opcua-users) over an encrypted endpoint"
        );
    }
    let users = match &a.opcua_users {
        Some(p) => Some(Arc::new(Users::read(p)?)),
        None => None,
    };
    let security = Security {
        pki_dir: a.opcua_pki.clone(),
        certificate: a.opcua_cert.clone().zip(a.opcua_key.clone()),
        users,
        anonymous: a.opcua_anonymous,
    };
    // The endpoints are checked before anything listens.
    gonio_opcua::security::endpoints(sa, &security)?;
    let listener =
        TcpListener::bind(sa).with_context(|| format!("--opcua {addr}: cannot listen"))?;
    if mode == StationMode::Plc {
        feed.set_link_source(link_from(hub.clone()));
    }
    let config = Config {
        machine: Machine::new(station, mode),
        store: db.to_string(),
        security,
    };
    let running = gonio_opcua::start(listener, config, feed.clone())
        .map_err(|e| anyhow::anyhow!("OPC UA: {e}"))?;
    gonio_cli::note!("OPC UA on {}", running.url());
    Ok((feed, Some(running)))
}
