//! `gonio mount`'s table: a part a row as it ends, and the batch's mean phase times
//! (docs/station-timing.md).
//!
//! ```
//! assert!(gonio_io::table::mount::HEADER.starts_with("serial"));
//! assert_eq!(gonio_io::table::mount::phase_line(std::iter::empty()), None);
//! ```

use super::fixed;
use gonio_station::PartRecord;

/// The table's heading line.
pub const HEADER: &str =
    "serial         initial e/µm   final e/µm  pushes  remeasured   time/s  result";

/// One part's row (and why it was rejected, on a line of its own).
pub fn row(r: &PartRecord) -> String {
    let mut s = format!(
        "{:<14} {:>12} {:>12} {:>7} {:>11} {:>8}  {}",
        r.serial,
        fixed(r.initial_e_um, 1),
        fixed(r.final_e_um, 2),
        r.pushes,
        r.remeasured_turns,
        fixed(r.time_s, 1),
        r.result.name()
    );
    if let Some(why) = &r.reject_reason {
        s.push_str(&format!("\n{:<14} why: {why}", ""));
    }
    s
}

/// The mean time a part spent in each phase (docs/station-timing.md), and how its focus was
/// found; `None` without parts.
pub fn phase_line<'a>(parts: impl Iterator<Item = &'a PartRecord>) -> Option<String> {
    let (mut n, mut checks, mut sweeps) = (0usize, 0u32, 0u32);
    let mut sum = [0.0; 7];
    for r in parts {
        let t = &r.phase_times;
        n += 1;
        checks += r.focus_checks;
        sweeps += r.focus_sweeps;
        for (s, v) in sum.iter_mut().zip([
            Some(t.focus_s),
            Some(t.measure_s),
            Some(t.push_s),
            t.align_s,
            t.approach_s,
            t.stroke_s,
            t.retract_s,
        ]) {
            *s += v.unwrap_or(0.0);
        }
    }
    if n == 0 {
        return None;
    }
    let m = sum.map(|s| s / n as f64);
    Some(format!(
        "phases, mean a part: focus {:.2} s (carried focus checked {checks} times, swept {sweeps}), measure {:.2} s, push {:.2} s (align {:.2}, approach {:.2}, stroke {:.2}, retract {:.2})",
        m[0], m[1], m[2], m[3], m[4], m[5], m[6]
    ))
}
