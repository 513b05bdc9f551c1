//! The mounting station as an OPC UA server for the line's MES, built on `async-opcua`
//! (the protocol stack, its security policies and sessions are the crate's; this crate is the
//! station's information model and the glue to the station and its results store).
//!
//! The address space follows OPC 40001-1 (Machinery) and OPC 40001-101 (Machinery Result
//! Transfer): under `Objects/Machines/<station name>` an `Identification`
//! (`MachineIdentificationType`), a `Monitoring` folder whose values change as the station
//! runs (phase, current part, last e and u(e) in µm, counters, mean cycle time in s, the PLC
//! link's round trips in ms), and a `ResultManagement` object with `GetLatestResult`,
//! `GetResultById`, `GetResultIdListFiltered`, `ReleaseResultHandle`, a `Results` folder of
//! the latest results and a `ResultReadyEventType` event for every finished part. The
//! companion specifications' NodeSets and gonio's own (`nodesets/`) are built into the binary
//! and loaded at start ([`model`]); docs/opcua.md describes the tree as served.
//!
//! Results are read from the results store (`gonio-store`), so a result finished before the
//! server started, or by another station of a PostgreSQL fleet, is found by `GetResultById`
//! too. The live values come from the station's observer through a [`feed::Feed`]: a
//! bounded, lossy hand-over, so the station never waits for the server or any client.
//!
//! Everything is read-only: no variable is writable, the methods only read results, and the
//! node management services are refused. Security ([`security`]): SecurityPolicy `None` only
//! on a loopback address; otherwise only `Basic256Sha256`, `Aes128_Sha256_RsaOaep` and
//! `Aes256_Sha256_RsaPss` with Sign & Encrypt; users and password hashes (argon2, PHC strings)
//! from a file ([`users`]); anonymous access only on loopback and only when asked for.
//!
//! Errors are [`OpcUaError`]; the library never prints (the stack logs through `tracing`,
//! to nobody unless a subscriber is installed).
//!
//! ```no_run
//! use gonio_opcua::{Config, Machine, feed::Feed, security::Security};
//! let listener = std::net::TcpListener::bind("127.0.0.1:4840").unwrap();
//! let feed = Feed::new();
//! let config = Config {
//!     machine: Machine::new("line-3-station-2", gonio_opcua::StationMode::None),
//!     store: "results.sqlite".into(),
//!     security: Security::loopback_anonymous(),
//! };
//! let server = gonio_opcua::start(listener, config, feed.clone()).unwrap();
//! eprintln!("OPC UA on {}", server.url());
//! ```
#![deny(missing_docs)]

mod auth;
mod codec;
mod event;
pub mod feed;
mod filter;
mod machine;
mod methods;
pub mod model;
mod monitoring;
mod node_manager;
mod pump;
mod result;
pub mod security;
mod server;
mod store;
pub mod users;

pub use result::is_simulated;
pub use server::{Running, start};

use std::path::PathBuf;
use thiserror::Error;

/// What runs the station whose results and live values the server serves.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum StationMode {
    /// No station: only the results store is served (the live values stay idle).
    None,
    /// The simulated station (the digital twin).
    Sim,
    /// A station through its PLC.
    Plc,
}

impl StationMode {
    /// `none`, `sim` or `plc`.
    pub fn name(self) -> &'static str {
        match self {
            StationMode::None => "none",
            StationMode::Sim => "sim",
            StationMode::Plc => "plc",
        }
    }
}

/// The machine the server describes (its `Identification`, and the station whose results it
/// serves).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Machine {
    /// The station's name: the machine's browse name under `Machines`, and the station whose
    /// parts `GetLatestResult`, the `Results` folder and the events report.
    pub station: String,
    /// What runs the station.
    pub mode: StationMode,
    /// `Identification/Manufacturer`.
    pub manufacturer: String,
    /// `Identification/Model`.
    pub model: String,
    /// `Identification/SerialNumber`.
    pub serial_number: String,
    /// `Identification/ProductInstanceUri` (globally unique for the machine).
    pub product_instance_uri: String,
    /// `Identification/SoftwareRevision`.
    pub software_revision: String,
}

impl Machine {
    /// A machine for `station` with gonio's defaults: manufacturer `gonio`, the model after
    /// the mode, the station's name as its serial number, `urn:gonio:station:<name>` as its
    /// product instance URI and this crate's version as its software revision.
    pub fn new(station: &str, mode: StationMode) -> Machine {
        Machine {
            station: station.to_string(),
            mode,
            manufacturer: "gonio".into(),
            model: match mode {
                StationMode::Sim => "gonio mounting station (digital twin)".into(),
                StationMode::Plc | StationMode::None => "gonio mounting station".into(),
            },
            serial_number: station.to_string(),
            product_instance_uri: format!("urn:gonio:station:{}", uri_safe(station)),
            software_revision: env!("CARGO_PKG_VERSION").into(),
        }
    }

    /// The server's application URI.
    pub(crate) fn application_uri(&self) -> String {
        format!("urn:gonio:opcua:{}", uri_safe(&self.station))
    }
}

/// `s` with every character outside `A–Z a–z 0–9 - . _ ~` percent-encoded (a URN's part).
fn uri_safe(s: &str) -> String {
    let mut out = String::with_capacity(s.len());
    for b in s.bytes() {
        if b.is_ascii_alphanumeric() || matches!(b, b'-' | b'.' | b'_' | b'~') {
            out.push(b as char);
        } else {
            out.push_str(&format!("%{b:02X}"));
        }
    }
    out
}

/// What the server needs to start.
#[derive(Debug, Clone)]
pub struct Config {
    /// The machine it describes.
    pub machine: Machine,
    /// The results store: a SQLite path or a `postgres://` URL (it must exist).
    pub store: String,
    /// Endpoints, certificates and users.
    pub security: security::Security,
}

/// An error of the OPC UA server.
#[derive(Debug, Error)]
#[non_exhaustive]
pub enum OpcUaError {
    /// The results store failed.
    #[error("results store: {0}")]
    Store(#[from] gonio_store::StoreError),
    /// A companion specification's NodeSet did not load.
    #[error("information model {file}: {message}")]
    Model {
        /// The NodeSet file.
        file: &'static str,
        /// Why.
        message: String,
    },
    /// The security set-up cannot be used (an address, a policy, a missing flag).
    #[error("{message}")]
    Security {
        /// What is wrong, naming the setting.
        message: String,
    },
    /// A certificate or key file that cannot be used.
    #[error("{path}: {message}")]
    Certificate {
        /// The file.
        path: PathBuf,
        /// Why.
        message: String,
    },
    /// The users file: one line naming the file, line and column.
    #[error("{path}:{line}:{column}: {message}")]
    Users {
        /// The file.
        path: PathBuf,
        /// 1-based line.
        line: usize,
        /// 1-based column.
        column: usize,
        /// What is wrong.
        message: String,
    },
    /// The server could not be built or run.
    #[error("server: {message}")]
    Server {
        /// Why.
        message: String,
    },
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn station_names_become_uri_safe() {
        assert_eq!(uri_safe("line-3_s.2"), "line-3_s.2");
        assert_eq!(uri_safe("line 3/ä"), "line%203%2F%C3%A4");
        let m = Machine::new("line 3", StationMode::Plc);
        assert_eq!(m.product_instance_uri, "urn:gonio:station:line%203");
        assert_eq!(m.application_uri(), "urn:gonio:opcua:line%203");
        assert_eq!(m.software_revision, env!("CARGO_PKG_VERSION"));
    }
}
