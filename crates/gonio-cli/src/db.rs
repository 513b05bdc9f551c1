//! The results store for the commands: opening it by path or URL with a one-line error, and
//! the software version written into every record.

use anyhow::{Result, anyhow};
use gonio_store::Store;

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

/// A SQLite store a command is about to create, removed again (with its journal files) unless
/// the command [`NewStore::keep`]s it: a command that fails while setting up (a station whose
/// devices do not answer) leaves no empty store behind. A store that already existed, or a
/// `postgres://` URL, is never touched.
#[derive(Debug)]
pub struct NewStore(Option<std::path::PathBuf>);

impl NewStore {
    /// Notes whether `location` is a SQLite file that does not exist yet (before opening it).
    pub fn before_open(location: &str) -> Self {
        let path = std::path::Path::new(location);
        NewStore(
            (!gonio_store::is_postgres(location) && !path.exists()).then(|| path.to_path_buf()),
        )
    }

    /// The command is set up: the store stays, whatever happens next.
    pub fn keep(mut self) {
        self.0 = None;
    }
}

impl Drop for NewStore {
    fn drop(&mut self) {
        if let Some(path) = self.0.take() {
            for suffix in ["", "-journal", "-wal", "-shm"] {
                let mut p = path.clone().into_os_string();
                p.push(suffix);
                let _ = std::fs::remove_file(p);
            }
        }
    }
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
