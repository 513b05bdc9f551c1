//! Starting and stopping the server: checks the set-up (endpoints, certificate, store,
//! NodeSets) before anything runs, then serves on a runtime of its own (two worker threads)
//! on a listener the caller bound; stops when the [`Running`] value is dropped.

use crate::auth::Auth;
use crate::feed::Feed;
use crate::machine::ResultMethod;
use crate::node_manager::{self, GonioNodeManager};
use crate::pump::Pump;
use crate::store::Stores;
use crate::{Config, OpcUaError, model, security};
use gonio_store::PartQuery;
use opcua::server::node_manager::memory::InMemoryNodeManagerBuilder;
use opcua::server::{Limits, ServerBuilder};
use opcua::types::BuildInfo;
use std::net::SocketAddr;
use std::sync::{Arc, Mutex, mpsc};
use std::thread::JoinHandle;
use std::time::Duration;
use tokio_util::sync::CancellationToken;

/// Sessions at once (each a client; 50 MES clients and room to spare).
const MAX_SESSIONS: usize = 200;
/// Longest notification queue of a monitored item.
const MAX_QUEUE: usize = 100;
/// How long a stop waits for the clients' connections to close.
const STOP_WAIT: Duration = Duration::from_secs(5);

/// A running server; dropping it stops it.
#[derive(Debug)]
pub struct Running {
    addr: SocketAddr,
    url: String,
    token: CancellationToken,
    done: Option<mpsc::Receiver<Result<(), String>>>,
    thread: Option<JoinHandle<()>>,
    // The PKI directory of a server without one of its own (removed when it stops).
    _scratch_pki: Option<tempfile::TempDir>,
}

impl Running {
    /// The address it listens on.
    pub fn local_addr(&self) -> SocketAddr {
        self.addr
    }

    /// Its endpoint URL, `opc.tcp://HOST:PORT/`.
    pub fn url(&self) -> &str {
        &self.url
    }

    /// Whether it has stopped by itself, and why (`Some(Err)`: it failed).
    pub fn stopped(&self) -> Option<Result<(), String>> {
        self.done.as_ref().and_then(|d| d.try_recv().ok())
    }
}

impl Drop for Running {
    fn drop(&mut self) {
        self.token.cancel();
        if let Some(done) = self.done.take() {
            let _ = done.recv_timeout(STOP_WAIT);
        }
        if let Some(t) = self.thread.take()
            && t.is_finished()
        {
            let _ = t.join();
        }
    }
}

/// `opc.tcp://HOST:PORT/` for an address.
fn url(addr: SocketAddr) -> String {
    format!("opc.tcp://{addr}/")
}

/// The names the server is reached by, for its certificate: the address, `localhost` on
/// loopback, and the machine's host names.
fn hosts(addr: SocketAddr) -> Vec<String> {
    let mut h = vec![addr.ip().to_string()];
    if addr.ip().is_loopback() {
        h.push("localhost".into());
    }
    h.extend(opcua::crypto::X509Data::computer_hostnames());
    h
}

/// Starts the server on `listener` (bound by the caller: a bad address fails there), serving
/// `config` and the live values of `feed`. Returns once it accepts connections.
///
/// # Errors
/// [`OpcUaError::Security`] for endpoints that cannot be offered; [`OpcUaError::Certificate`];
/// [`OpcUaError::Store`] when the store cannot be read; [`OpcUaError::Model`];
/// [`OpcUaError::Server`] when the server cannot be built.
pub fn start(
    listener: std::net::TcpListener,
    config: Config,
    feed: Arc<Feed>,
) -> Result<Running, OpcUaError> {
    let server_err = |message: String| OpcUaError::Server { message };
    let addr = listener
        .local_addr()
        .map_err(|e| server_err(e.to_string()))?;
    let endpoints = security::endpoints(addr, &config.security)?;
    let machine = config.machine.clone();
    let app_uri = machine.application_uri();
    let app_name = format!("gonio OPC UA server ({})", machine.station);
    let cert = security::certificate(&config.security, &app_uri, &app_name, &hosts(addr))?;
    let scratch_pki = match &config.security.pki_dir {
        Some(_) => None,
        None => Some(tempfile::tempdir().map_err(|e| server_err(e.to_string()))?),
    };
    let pki = config
        .security
        .pki_dir
        .clone()
        .or_else(|| scratch_pki.as_ref().map(|d| d.path().to_path_buf()))
        .unwrap_or_default();
    let stores = Stores::open(&config.store)?;
    // Parts already stored are not news: events are for the parts after this one.
    let station = machine.station.clone();
    let last_part = stores
        .with_blocking(move |s| {
            s.part_ids(&PartQuery {
                station: Some(station),
                limit: Some(1),
                ..PartQuery::default()
            })
        })?
        .last()
        .copied()
        .unwrap_or(0);
    let imports = model::imports()?;

    let rt = tokio::runtime::Builder::new_multi_thread()
        .worker_threads(2)
        .thread_name("gonio-opcua")
        .enable_all()
        .build()
        .map_err(|e| server_err(e.to_string()))?;
    let token = CancellationToken::new();
    let failed = Arc::new(Mutex::new(None::<String>));
    let auth = Arc::new(Auth::new(config.security.users.clone()));

    let mut limits = Limits {
        max_sessions: MAX_SESSIONS,
        ..Limits::default()
    };
    // The stack gives an item that asks for no queue a queue of one: an MES asks for a queue
    // of events (up to this many) to keep every result while it is busy.
    limits.subscriptions.max_monitored_item_queue_size = MAX_QUEUE;
    let mut builder = ServerBuilder::new()
        .application_name(app_name)
        .application_uri(app_uri)
        .product_uri("urn:gonio")
        .build_info(BuildInfo {
            product_uri: "urn:gonio".into(),
            manufacturer_name: machine.manufacturer.as_str().into(),
            product_name: "gonio".into(),
            software_version: machine.software_revision.as_str().into(),
            build_number: machine.software_revision.as_str().into(),
            build_date: opcua::types::DateTime::now(),
        })
        .host(match addr {
            SocketAddr::V4(a) => a.ip().to_string(),
            SocketAddr::V6(a) => format!("[{}]", a.ip()),
        })
        .port(addr.port())
        .discovery_urls(vec![url(addr)])
        .pki_dir(pki)
        .create_sample_keypair(false)
        .trust_client_certs(false)
        .check_cert_time(true)
        .limits(limits)
        .diagnostics_enabled(false)
        .with_authenticator(auth.clone())
        .token(token.clone());
    if let Some((c, k)) = &cert {
        builder = builder.certificate_path(c).private_key_path(k);
    }
    for (id, ep) in endpoints {
        builder = builder.add_endpoint(id, ep);
    }
    {
        let failed = failed.clone();
        builder = builder.with_node_manager(InMemoryNodeManagerBuilder::new(
            move |ctx: opcua::server::node_manager::ServerContext,
                  space: &mut opcua::server::address_space::AddressSpace| {
                node_manager::build(&ctx, space, imports, machine, stores, &failed)
            },
        ));
    }
    let _guard = rt.enter();
    let (server, handle) = builder.build().map_err(server_err)?;
    if let Some(why) = failed.lock().ok().and_then(|mut f| f.take()) {
        return Err(OpcUaError::Model {
            file: "the machine's nodes",
            message: why,
        });
    }
    let nodes = handle
        .node_managers()
        .get_of_type::<GonioNodeManager>()
        .ok_or_else(|| server_err("gonio's node manager is missing".into()))?;
    let shared = nodes
        .inner()
        .shared
        .clone()
        .ok_or_else(|| server_err("gonio's node manager was not built".into()))?;
    auth.allow_methods(
        ResultMethod::ALL
            .iter()
            .map(|m| shared.ids.method(*m))
            .collect(),
    );
    listener
        .set_nonblocking(true)
        .map_err(|e| server_err(e.to_string()))?;
    let listener =
        tokio::net::TcpListener::from_std(listener).map_err(|e| server_err(e.to_string()))?;
    let pump = Pump {
        handle: handle.clone(),
        nodes,
        shared,
        feed,
        token: token.clone(),
        last_part,
    };
    rt.spawn(pump.clone().live());
    rt.spawn(pump.results());
    let (tx, done) = mpsc::channel();
    drop(_guard);
    let thread = std::thread::Builder::new()
        .name("gonio-opcua".into())
        .spawn(move || {
            let r = rt.block_on(server.run_with(listener));
            let _ = tx.send(r);
            // Tasks still running (the pump's) end with the runtime, without waiting.
            rt.shutdown_background();
        })
        .map_err(|e| server_err(e.to_string()))?;
    Ok(Running {
        addr,
        url: url(addr),
        token,
        done: Some(done),
        thread: Some(thread),
        _scratch_pki: scratch_pki,
    })
}
