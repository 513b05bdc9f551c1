//! The results store for the commands: opening it by path or URL with a one-line error, and
//! the software version written into every record.

use anyhow::{Result, anyhow};
use gonio_store::Store;

pub use gonio_store::new_store::NewStore;
pub use gonio_store::writer::software_version;

/// Opens the store at `location` (a SQLite path or a `postgres://` URL), migrating it.
///
/// # Errors
/// The store cannot be opened (`results store LOCATION: …`).
pub fn open(location: &str) -> Result<Box<dyn Store>> {
    gonio_store::open(location).map_err(|e| {
        anyhow!(
            "results store {}: {e}",
            gonio_store::display_location(location)
        )
    })
}

/// Opens the existing store at `location` for a command that only reads (`parts`, `serve`
/// without a station): a SQLite path that does not exist is an error naming it, never a new
/// empty store.
pub fn open_existing(location: &str) -> Result<Box<dyn Store>> {
    gonio_store::open_existing(location).map_err(|e| match e {
        gonio_store::StoreError::Missing { .. } => anyhow!("--db {e}"),
        e => anyhow!(
            "results store {}: {e}",
            gonio_store::display_location(location)
        ),
    })
}

/// Reserves the results store of a command (`--db`, a SQLite path) in the command's inputs:
/// none of its outputs may name it ([`gonio_io::input::Inputs::reserve`]). A `postgres://`
/// URL names no file. Called before the outputs are named.
pub fn reserve(inputs: &gonio_io::input::Inputs, location: &str) {
    if !gonio_store::is_postgres(location) {
        inputs.reserve(
            std::path::Path::new(location),
            &format!("results store (--db {location})"),
        );
    }
}

/// Stores a calibration certificate whole in the store at `location`, saying so on standard
/// error; `source` names where it came from (the readings).
pub fn store_certificate(
    location: &str,
    cert: &gonio_calib::certificate::Certificate,
    source: &str,
) -> Result<i64> {
    let loc = gonio_store::display_location(location);
    let id = open(location)?
        .insert_calibration(cert, source, &software_version())
        .map_err(|e| anyhow!("results store {loc}: {e}"))?;
    gonio_cli::note!("stored as calibration {id} in {loc}");
    Ok(id)
}

/// Where a calibration command sends its certificate: `--json` and `--db`, flattened into
/// `shift-angle`, `selfcal` and `joint` (the same flags and help in each).
#[derive(Debug, clap::Args)]
pub struct CertificateTargets {
    /// Write the certificate (gonio.certificate/1 JSON) here (`-` for standard output).
    #[arg(long)]
    pub json: Option<std::path::PathBuf>,
    /// Store the certificate whole in this results store (a SQLite file, created if missing, or
    /// a postgres:// URL), indexed by item, method, date, largest |α| and largest U; the
    /// dashboard (`gonio serve`) lists it.
    #[arg(long, value_name = "PATH|postgres://…")]
    pub db: Option<String>,
}
