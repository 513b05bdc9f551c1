//! Part 1 of the demo: 25 gratings mounted on the simulated station (the plant of Yu et al.,
//! 2024, fast fidelity) with the paper's strategy, the learned response and live-baseline
//! feedback (the default of `gonio mount` and `gonio serve`, whose batch the report shows),
//! against the paper's 25 real parts (mean pushes, final eccentricity in µm, time in s).

use crate::table::fixed;
use anyhow::Result;
use gonio_sim::station::{BatchConfig, BatchReport, run_batch};
use gonio_station::controller::Strategy;
use gonio_station::published::YU_2024;
use std::io::Write;

/// Part 1: 25 gratings mounted on the simulated station, its narrative to `w`; returns the
/// default strategy's batch.
///
/// # Errors
/// A write error on `w`, or a batch that fails.
pub fn run(seed: u64, w: &mut dyn Write) -> Result<BatchReport> {
    writeln!(
        w,
        "Mounting: 25 gratings on the simulated station (the plant of Yu et al., 2024, fast fidelity)"
    )?;
    writeln!(
        w,
        "  {:<28} {:>12} {:>12} {:>14} {:>10}",
        "strategy", "mean pushes", "max pushes", "mean final e", "mean time"
    )?;
    let y = &YU_2024;
    writeln!(
        w,
        "  {:<28} {:>12} {:>12} {:>13}µm {:>9}s",
        format!("Yu et al., 2024, {} parts", y.parts),
        y.mean_pushes,
        y.max_pushes,
        y.mean_final_e_um,
        y.mean_time_s
    )?;
    let mut default_batch = None;
    for strategy in [Strategy::Paper, Strategy::Learned, Strategy::Live] {
        let cfg = BatchConfig {
            parts: 25,
            strategy,
            ..BatchConfig::default()
        };
        let report = run_batch(&cfg, seed, &mut |_, _, _| {})?;
        let s = &report.summary;
        let name = match strategy {
            Strategy::Paper => "paper's strategy (simulated)",
            Strategy::Learned => "learned response",
            Strategy::Live => "gonio default (live)",
            Strategy::LeastSquares => "least squares",
        };
        writeln!(
            w,
            "  {:<28} {:>12.2} {:>12} {:>13}µm {:>9}s{}",
            name,
            s.mean_pushes,
            s.max_pushes,
            fixed(s.mean_final_e_um, 2),
            fixed(s.mean_time_s, 1),
            if s.rejected > 0 {
                format!("  ({} rejected)", s.rejected)
            } else {
                String::new()
            }
        )?;
        // The default of `gonio mount` and `gonio serve`.
        if strategy == Strategy::Live {
            default_batch = Some(report);
        }
    }
    writeln!(
        w,
        "  (`gonio mount --sim --strategy …` for per-part records; 25 parts take milliseconds)"
    )?;
    default_batch.ok_or_else(|| anyhow::anyhow!("no batch was run"))
}
