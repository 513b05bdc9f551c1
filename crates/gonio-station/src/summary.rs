//! A batch's summary, the same sums whether its parts came from the twin or through a PLC:
//! counts, means over the parts where a value is defined (`None`, JSON `null`, where none is),
//! and for the twin's parts the mean of their true final eccentricity. Times in s,
//! eccentricities in µm.
//!
//! [`SummaryBuilder`] takes the parts one by one (a long batch need not keep them) and gives
//! the same bits as summing them at once: the same sums in the same order.
//!
//! ```
//! use gonio_station::record::PartRecord;
//! use gonio_station::summary::SummaryBuilder;
//! let mut s = SummaryBuilder::default();
//! let mut p = PartRecord::new("PLC-0001", "default", "live");
//! p.time_s = Some(14.0);
//! s.add(&p, None);
//! p.time_s = None; // the clock failed
//! s.add(&p, None);
//! let sum = s.finish();
//! assert_eq!((sum.parts, sum.mean_time_s), (2, Some(14.0)));
//! assert_eq!(sum.mean_true_final_e_um, None); // real parts: no truth
//! ```

use crate::record::{PartRecord, PartResult};
use serde::{Deserialize, Serialize};

/// The batch's summary.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct BatchSummary {
    /// Parts mounted.
    pub parts: usize,
    /// Mean time per part, s, over the parts whose time is known (`null`: none).
    pub mean_time_s: Option<f64>,
    /// Mean final eccentricity as measured by the station, µm, over the parts a trusted turn
    /// measured (`null`: none was).
    pub mean_final_e_um: Option<f64>,
    /// Mean true final eccentricity of the twin's parts, µm (absent for real parts).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub mean_true_final_e_um: Option<f64>,
    /// Mean pushes per part.
    pub mean_pushes: f64,
    /// Most pushes on one part.
    pub max_pushes: u32,
    /// Parts rejected.
    pub rejected: usize,
    /// Parts rejected because their turns failed the quality gate (`measurement_untrusted`).
    pub untrusted: usize,
    /// Parts rejected because a verify turn disagreed with the push model (`push_inconsistent`).
    pub push_inconsistent: usize,
    /// Parts ended by a device error.
    pub device_errors: usize,
    /// Turns measured again over the batch.
    pub remeasured_turns: u32,
    /// Total station time of the parts whose time is known, s.
    pub total_time_s: f64,
    /// Mean autofocus time per part, s (`null`: no part).
    #[serde(default)]
    pub mean_focus_s: Option<f64>,
    /// Mean measuring time per part, s (`null`: no part).
    #[serde(default)]
    pub mean_measure_s: Option<f64>,
    /// Mean push time per part, s (`null`: no part).
    #[serde(default)]
    pub mean_push_s: Option<f64>,
}

/// A batch's summary built part by part.
#[derive(Debug, Clone)]
pub struct SummaryBuilder {
    parts: usize,
    time_sum_s: f64,
    timed: usize,
    final_sum_um: f64,
    measured: usize,
    true_final_sum_um: f64,
    with_truth: usize,
    pushes_sum: f64,
    max_pushes: u32,
    rejected: usize,
    untrusted: usize,
    push_inconsistent: usize,
    device_errors: usize,
    remeasured_turns: u32,
    phase_sums_s: [f64; 3],
}

impl Default for SummaryBuilder {
    fn default() -> Self {
        // −0.0 is the neutral element of `Iterator::sum` for floats: an empty sum stays what
        // the standard library's sum gives.
        SummaryBuilder {
            parts: 0,
            time_sum_s: -0.0,
            timed: 0,
            final_sum_um: -0.0,
            measured: 0,
            true_final_sum_um: -0.0,
            with_truth: 0,
            pushes_sum: -0.0,
            max_pushes: 0,
            rejected: 0,
            untrusted: 0,
            push_inconsistent: 0,
            device_errors: 0,
            remeasured_turns: 0,
            phase_sums_s: [-0.0; 3],
        }
    }
}

impl SummaryBuilder {
    /// Counts one more part: its record and, for the twin's parts, its true final
    /// eccentricity, µm.
    pub fn add(&mut self, r: &PartRecord, true_final_e_um: Option<f64>) {
        self.parts += 1;
        if let Some(t) = r.time_s {
            self.time_sum_s += t;
            self.timed += 1;
        }
        if let Some(e) = r.final_e_um {
            self.final_sum_um += e;
            self.measured += 1;
        }
        if let Some(e) = true_final_e_um {
            self.true_final_sum_um += e;
            self.with_truth += 1;
        }
        self.pushes_sum += f64::from(r.pushes);
        self.max_pushes = self.max_pushes.max(r.pushes);
        match r.result {
            PartResult::Accepted => {}
            other => {
                self.rejected += 1;
                match other {
                    PartResult::MeasurementUntrusted => self.untrusted += 1,
                    PartResult::PushInconsistent => self.push_inconsistent += 1,
                    PartResult::RejectedDeviceError => self.device_errors += 1,
                    _ => {}
                }
            }
        }
        self.remeasured_turns += r.remeasured_turns;
        let p = &r.phase_times;
        for (sum, t) in self
            .phase_sums_s
            .iter_mut()
            .zip([p.focus_s, p.measure_s, p.push_s])
        {
            *sum += t;
        }
    }

    /// The summary of the parts counted so far.
    pub fn finish(&self) -> BatchSummary {
        let n = self.parts.max(1) as f64;
        let mean_of = |sum: f64, k: usize| (k > 0).then(|| sum / k as f64);
        let [focus, measure, push] = self.phase_sums_s;
        BatchSummary {
            parts: self.parts,
            mean_time_s: mean_of(self.time_sum_s, self.timed),
            mean_final_e_um: mean_of(self.final_sum_um, self.measured),
            mean_true_final_e_um: mean_of(self.true_final_sum_um, self.with_truth),
            mean_pushes: self.pushes_sum / n,
            max_pushes: self.max_pushes,
            rejected: self.rejected,
            untrusted: self.untrusted,
            push_inconsistent: self.push_inconsistent,
            device_errors: self.device_errors,
            remeasured_turns: self.remeasured_turns,
            total_time_s: self.time_sum_s,
            mean_focus_s: mean_of(focus, self.parts),
            mean_measure_s: mean_of(measure, self.parts),
            mean_push_s: mean_of(push, self.parts),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn means_count_only_the_parts_where_a_value_is_defined() {
        let mut s = SummaryBuilder::default();
        let mut a = PartRecord::new("A", "default", "live");
        a.time_s = Some(10.0);
        a.final_e_um = Some(2.0);
        a.pushes = 3;
        a.phase_times.measure_s = 4.0;
        let mut b = PartRecord::new("B", "default", "live");
        b.result = PartResult::RejectedDeviceError;
        b.phase_times.measure_s = 1.0;
        s.add(&a, Some(1.5));
        s.add(&b, Some(2.5));
        let r = s.finish();
        assert_eq!(r.mean_time_s, Some(10.0), "b's time is unknown: not a 0");
        assert_eq!(r.mean_final_e_um, Some(2.0));
        assert_eq!(r.mean_true_final_e_um, Some(2.0));
        assert_eq!((r.mean_pushes, r.max_pushes), (1.5, 3));
        assert_eq!((r.rejected, r.device_errors), (1, 1));
        assert_eq!(r.mean_measure_s, Some(2.5));
        assert_eq!(r.total_time_s, 10.0);
        let empty = SummaryBuilder::default().finish();
        assert_eq!((empty.mean_time_s, empty.mean_focus_s), (None, None));
        let json = serde_json::to_value(SummaryBuilder::default().finish()).unwrap();
        assert!(json.get("mean_true_final_e_um").is_none(), "{json}");
    }
}
