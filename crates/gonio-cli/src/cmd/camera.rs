//! `gonio camera …`: the GenICam cameras Aravis finds (built with `--features genicam`).

use anyhow::Result;

/// What to do with cameras.
#[derive(Debug, clap::Subcommand)]
pub enum Camera {
    /// Every GenICam camera Aravis finds (GigE Vision, USB3 Vision).
    List(ListArgs),
}

/// Arguments of `gonio camera list`.
#[derive(Debug, clap::Args)]
#[command(after_help = "\
One line per camera: id (what `gonio detect --camera` takes), vendor, model, serial, address,
protocol. With --json an array of objects with those fields. GigE Vision discovery waits about
a second for answers on every interface. Needs a build with `--features genicam` (docs/camera.md).

Examples:
  gonio camera list
  gonio camera list --json")]
pub struct ListArgs {
    /// Write a JSON array to standard output instead of the table.
    #[arg(long)]
    pub json: bool,
}

/// Runs `gonio camera …`.
pub fn run(c: Camera) -> Result<()> {
    match c {
        Camera::List(a) => list(a),
    }
}

#[cfg(not(feature = "genicam"))]
fn list(_: ListArgs) -> Result<()> {
    Err(gonio_camera::CameraError::NotBuilt.into())
}

#[cfg(feature = "genicam")]
fn list(a: ListArgs) -> Result<()> {
    #[derive(serde::Serialize)]
    struct Row<'a> {
        id: &'a str,
        vendor: &'a str,
        model: &'a str,
        serial: &'a str,
        address: &'a str,
        protocol: &'a str,
    }
    let cams = gonio_camera::list_cameras();
    let rows: Vec<Row> = cams
        .iter()
        .map(|c| Row {
            id: &c.id,
            vendor: &c.vendor,
            model: &c.model,
            serial: &c.serial,
            address: &c.address,
            protocol: &c.protocol,
        })
        .collect();
    if a.json {
        let mut v = gonio_io::json::to_bytes(&rows)?;
        if v.last() != Some(&b'\n') {
            v.push(b'\n');
        }
        return gonio_cli::term::out_bytes(&v);
    }
    if rows.is_empty() {
        gonio_cli::note!("no camera found");
        return Ok(());
    }
    let mut text = String::new();
    for r in &rows {
        text.push_str(&format!(
            "{}  {} {}  serial {}  {} ({})\n",
            r.id, r.vendor, r.model, r.serial, r.address, r.protocol
        ));
    }
    gonio_cli::term::out(&text)
}
