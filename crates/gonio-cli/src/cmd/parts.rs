//! `gonio parts`: query the mounted parts in a results store.

use crate::db;
use crate::table::fixed;
use anyhow::{Result, anyhow};
use gonio_cli::output::Outputs;
use gonio_store::{PartQuery, PartSummary};
use std::path::PathBuf;

/// Arguments of `gonio parts`.
#[derive(Debug, clap::Args)]
#[command(after_help = "\
Without --json or --csv, prints a table. --json prints a JSON array of part records: part (the
id), serial, station, simulated (true for a part of the digital twin), batch, batch_index,
recipe, recipe_hash, strategy, software_version, started_at and ended_at (UTC), initial_e_um,
final_e_um, pushes, time_s, result, verdict (pass or reject), reject_reason, remeasured_turns,
focus_um, phase_times, device_error, turns (each with its samples (θ, c), fit and quality
verdict), push_log, learned, and for simulated parts true_initial_e_um and true_final_e_um.
Numbers not determined are null. --csv writes one row per part (no turns or pushes).

Examples:
  gonio parts --db results.sqlite
  gonio parts --db results.sqlite --since 2026-05-20 --verdict reject --json
  gonio parts --db postgres://gonio@/results?host=/run/postgresql --csv --out parts.csv")]
pub struct Args {
    /// The results store: a SQLite file or a postgres:// URL.
    #[arg(long, value_name = "PATH|postgres://…")]
    pub db: String,
    /// Only parts started at or after this time: YYYY-MM-DD, YYYY-MM-DDTHH:MM or
    /// YYYY-MM-DDTHH:MM:SS (UTC), or RFC 3339 with an offset.
    #[arg(long, value_name = "TIME")]
    pub since: Option<String>,
    /// Only parts with this verdict: pass, reject, or a result (rejected_ring_lost,
    /// measurement_untrusted, push_inconsistent, rejected_device_error, …).
    #[arg(long)]
    pub verdict: Option<String>,
    /// Only this serial number.
    #[arg(long)]
    pub serial: Option<String>,
    /// Only this batch (its id).
    #[arg(long, value_parser = gonio_cli::flag::whole::<i64>(BATCH_ID))]
    pub batch: Option<i64>,
    /// Only the most recent N parts.
    #[arg(long, value_name = "N", value_parser = gonio_cli::flag::whole::<usize>(LIMIT))]
    pub limit: Option<usize>,
    /// Print the records as a JSON array.
    #[arg(long, conflicts_with = "csv")]
    pub json: bool,
    /// Print one CSV row per part.
    #[arg(long)]
    pub csv: bool,
    /// Write the JSON or CSV here instead of standard output (atomically).
    #[arg(long, value_name = "FILE")]
    pub out: Option<PathBuf>,
}

/// `--batch`: a batch's id in the store.
const BATCH_ID: gonio_core::bound::Bound = gonio_core::bound::Bound::new(1.0, 9.2e18, "");
/// `--limit`: parts listed.
const LIMIT: gonio_core::bound::Bound = gonio_core::bound::Bound::new(1.0, 1e9, "parts");

/// The CSV columns (one row per part).
const CSV_HEADER: [&str; 17] = [
    "part",
    "serial",
    "station",
    "batch",
    "batch_index",
    "recipe",
    "strategy",
    "started_at",
    "ended_at",
    "initial_e_um",
    "final_e_um",
    "pushes",
    "time_s",
    "result",
    "verdict",
    "reject_reason",
    "remeasured_turns",
];

fn num(x: Option<f64>) -> String {
    x.filter(|x| x.is_finite())
        .map_or_else(String::new, |x| format!("{x}"))
}

fn csv_text(rows: &[PartSummary]) -> Result<String> {
    let mut w = csv::Writer::from_writer(Vec::new());
    w.write_record(CSV_HEADER)?;
    for p in rows {
        w.write_record([
            p.part.to_string(),
            p.serial.clone(),
            p.station.clone(),
            p.batch.to_string(),
            p.batch_index.to_string(),
            p.recipe.clone(),
            p.strategy.clone(),
            p.started_at.clone(),
            p.ended_at.clone(),
            num(p.initial_e_um),
            num(p.final_e_um),
            p.pushes.to_string(),
            num(p.time_s),
            p.result.clone(),
            p.verdict.name().to_string(),
            p.reject_reason.clone().unwrap_or_default(),
            p.remeasured_turns.to_string(),
        ])?;
    }
    let bytes = w.into_inner().map_err(|e| anyhow!("csv: {e}"))?;
    Ok(String::from_utf8(bytes)?)
}

fn table(rows: &[PartSummary]) -> String {
    use std::fmt::Write as _;
    let mut s = format!(
        "{:>6} {:<16} {:<20} {:>12} {:>11} {:>6} {:>7}  result\n",
        "part", "serial", "started (UTC)", "initial e/µm", "final e/µm", "pushes", "time/s"
    );
    for p in rows {
        let _ = writeln!(
            s,
            "{:>6} {:<16} {:<20} {:>12} {:>11} {:>6} {:>7}  {}",
            p.part,
            p.serial,
            p.started_at.get(..19).unwrap_or(&p.started_at),
            fixed(p.initial_e_um, 1),
            fixed(p.final_e_um, 2),
            p.pushes,
            fixed(p.time_s, 1),
            p.result
        );
        if let Some(why) = &p.reject_reason {
            let _ = writeln!(s, "{:>6} why: {why}", "");
        }
    }
    s
}

/// Parts read from the store at a time for `--json`.
const PAGE_PARTS: usize = 64;

/// Runs `gonio parts`.
pub fn run(a: Args) -> Result<()> {
    let since = match &a.since {
        Some(t) => Some(gonio_store::time::parse_since(t).map_err(|e| anyhow!("--since: {e}"))?),
        None => None,
    };
    let q = PartQuery {
        since,
        verdict: a.verdict.clone(),
        serial: a.serial.clone(),
        batch: a.batch,
        limit: a.limit,
        ..PartQuery::default()
    };
    let mut store = db::open_existing(&a.db)?;
    let location = gonio_store::display_location(&a.db);
    let err = |e: gonio_store::StoreError| anyhow!("{location}: {e}");
    let out = a.out.clone().unwrap_or_else(|| PathBuf::from("-"));
    let mut outs = Outputs::new();
    crate::db::reserve(outs.inputs(), &a.db);
    let id = outs.file("--out", &out)?;
    if a.json {
        // Streamed a page of parts at a time: memory holds a page, never the whole store. The
        // bytes are those of the whole array written at once (pretty, two spaces). Standard
        // output is spooled to a temporary file until the last page is read, so that a store
        // failing half-way writes nothing there either.
        outs.spool(id)?;
        let shown = out.display().to_string();
        let mut failed: Option<anyhow::Error> = None;
        let mut n = 0usize;
        outs.write(id, b"[")?;
        store
            .for_each_page(&q, PAGE_PARTS, &mut |page| {
                for p in &page {
                    let r = gonio_io::json::to_bytes(p)
                        .map_err(|e| {
                            anyhow!("{shown}: nothing was written: [{n}] (part {}): {e}", p.part)
                        })
                        .and_then(|b| {
                            let mut text = Vec::with_capacity(b.len() + 64);
                            text.extend_from_slice(if n == 0 { &b"\n"[..] } else { &b",\n"[..] });
                            for line in b.trim_ascii_end().split(|&c| c == b'\n') {
                                text.extend_from_slice(b"  ");
                                text.extend_from_slice(line);
                                text.push(b'\n');
                            }
                            text.pop();
                            outs.write(id, &text)
                        });
                    if let Err(e) = r {
                        failed = Some(e);
                        return false;
                    }
                    n += 1;
                }
                true
            })
            .map_err(err)?;
        if let Some(e) = failed {
            return Err(e);
        }
        outs.write(id, if n == 0 { &b"]\n"[..] } else { &b"\n]\n"[..] })?;
        outs.commit()
    } else if a.csv {
        let rows = store.part_summaries(&q).map_err(err)?;
        outs.write(id, csv_text(&rows)?.as_bytes())?;
        outs.commit()
    } else {
        let rows = store.part_summaries(&q).map_err(err)?;
        let stats = store.stats(&q).map_err(err)?;
        let mut text = table(&rows);
        if stats.parts == 0 {
            text.push_str("\nno parts match\n");
        } else {
            text.push_str(&format!(
                "\n{} parts: {} pass, {} reject; mean {} s, {} pushes (max {}), final e {} µm\n",
                stats.parts,
                stats.pass,
                stats.reject,
                fixed(stats.mean_time_s, 1),
                fixed(stats.mean_pushes, 2),
                stats.max_pushes.unwrap_or(0),
                fixed(stats.mean_final_e_um, 2),
            ));
        }
        outs.write(id, text.as_bytes())?;
        outs.commit()
    }
}
