//! `gonio`: precision rotary-encoder metrology from the command line.
//!
//! The binary is glue: it parses arguments, reads and writes files, draws progress bars and maps
//! errors to exit codes. The work is done in the library crates.

mod cmd;
mod db;
mod opcua;
mod plc;
mod station;

use clap::{Parser, Subcommand};
/// The commands' tables (`crate::table`): numbers, names and budgets as text.
use gonio_io::table;

/// Precision rotary-encoder metrology: mount gratings centred, calibrate encoders, with a GUM
/// uncertainty on every result.
#[derive(Debug, Parser)]
#[command(name = "gonio", version, about, long_about = None, after_help = "\
Start with the built-in simulated lab and station:
  gonio demo

Every command explains its inputs with an example: gonio <command> --help")]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// Simulate instruments and write their readings (digital twin).
    #[command(subcommand)]
    Simulate(cmd::simulate::Simulate),
    /// Calibrate an encoder with a polygon and an autocollimator (shift-angle method, Hsieh et al., 2022).
    ShiftAngle(cmd::shift_angle::Args),
    /// Self-calibrate an encoder from several read heads (EDA, SelfA, Fourier least squares).
    Selfcal(cmd::selfcal::Args),
    /// Calibrate an encoder from polygon readings and read-head readings in one least squares.
    Joint(cmd::joint::Args),
    /// Test a rotary axis's accuracy and repeatability of positioning to ISO 230-2 (A, B, E, M, R).
    Axis(cmd::axis::Args),
    /// Read an instrument through a measuring plan, guiding the operator (autocollimator on a serial line).
    #[command(subcommand)]
    Acquire(cmd::acquire::Acquire),
    /// Import an instrument's log (an autocollimator's serial output) as a readings file.
    #[command(subcommand)]
    Import(cmd::import::Import),
    /// Compare two calibration certificates of one encoder at their common angles (differences, En).
    Compare(cmd::compare::Args),
    /// One self-contained HTML report with plots from certificates, comparisons and mounting batches.
    Report(cmd::report::Args),
    /// Check a certificate's metadata and export it as a Digital Calibration Certificate (DCC XML).
    Certificate(cmd::certificate::Args),
    /// Evaluate a GUM uncertainty budget (TOML).
    Budget(cmd::budget::Args),
    /// Run the built-in simulated lab end to end and report how close each method came.
    Demo(cmd::demo::Args),
    /// Eccentricity of a grating from one turn's (θ, c) samples.
    Eccentricity(cmd::eccentricity::Args),
    /// Mount gratings on the automatic mounting station (simulated: --sim).
    Mount(cmd::mount::Args),
    /// Find the alignment ring's column c in camera frames (PNG/TIFF files or raw stdin).
    Detect(cmd::detect::Args),
    /// Query the mounted parts in a results store (SQLite file or PostgreSQL).
    Parts(cmd::parts::Args),
    /// The station's dashboard in the browser: live view, history, calibrations, JSON API.
    Serve(cmd::serve::Args),
    /// GenICam cameras through Aravis (built with --features genicam).
    #[command(subcommand)]
    Camera(cmd::camera::Camera),
    /// Re-run a recorded part's detection and fit (gonio mount --record) and compare with its record.
    Replay(cmd::replay::Args),
}

fn main() {
    let cli = match Cli::try_parse() {
        Ok(cli) => cli,
        // Help and version as clap writes them (`gonio` alone: the help, on standard error).
        Err(e)
            if !e.use_stderr()
                || e.kind() == clap::error::ErrorKind::DisplayHelpOnMissingArgumentOrSubcommand =>
        {
            e.exit()
        }
        // A refused flag: one line, as every other error.
        Err(e) => {
            gonio_cli::term::note(&format!("error: {}", gonio_cli::flag::one_line(&e)));
            std::process::exit(2);
        }
    };
    let result = match cli.command {
        Command::Simulate(s) => cmd::simulate::run(s),
        Command::ShiftAngle(a) => cmd::shift_angle::run(a),
        Command::Selfcal(a) => cmd::selfcal::run(a),
        Command::Joint(a) => cmd::joint::run(a),
        Command::Axis(a) => cmd::axis::run(a),
        Command::Acquire(a) => cmd::acquire::run(a),
        Command::Import(i) => cmd::import::run(i),
        Command::Compare(a) => cmd::compare::run(a),
        Command::Report(a) => cmd::report::run(a),
        Command::Certificate(a) => cmd::certificate::run(a),
        Command::Budget(a) => cmd::budget::run(a),
        Command::Demo(a) => cmd::demo::run(a),
        Command::Eccentricity(a) => cmd::eccentricity::run(a),
        Command::Mount(a) => cmd::mount::run(a),
        Command::Detect(a) => cmd::detect::run(a),
        Command::Parts(a) => cmd::parts::run(a),
        Command::Serve(a) => cmd::serve::run(a),
        Command::Replay(a) => cmd::replay::run(a),
        Command::Camera(c) => cmd::camera::run(c),
    };
    if let Err(e) = result {
        if let Some(i) = e.downcast_ref::<gonio_cli::output::Interrupted>() {
            gonio_cli::term::note(&format!("interrupted: {i}"));
            std::process::exit(128 + i.signal);
        }
        // One line: the chain of causes joined by ": ", echoed input capped.
        gonio_cli::term::note(&format!("error: {}", gonio_io::input::one_line(&e)));
        std::process::exit(2);
    }
}
