//! A criterion measurement of the calling thread's on-CPU time (`CLOCK_THREAD_CPUTIME_ID`, the
//! clock behind `/proc/thread-self/schedstat`, read exactly: the file itself is only brought up
//! to date at scheduler ticks while the thread runs), for benches run on a machine shared with
//! other work: time the thread spends waiting for a core is not counted. Cache and memory
//! interference from the other work still is.
//!
//! Benches include this file with `#[path = "../../../bench/criterion_on_cpu.rs"] mod on_cpu;`
//! and choose it with the environment variable `GONIO_BENCH_ON_CPU=1` (see [`criterion`]).

use criterion::Criterion;
use criterion::Throughput;
use criterion::measurement::{Measurement, ValueFormatter, WallTime};

/// On-CPU time of the calling thread, ns.
pub fn thread_cpu_ns() -> u64 {
    let t = rustix::time::clock_gettime(rustix::time::ClockId::ThreadCPUTime);
    t.tv_sec as u64 * 1_000_000_000 + t.tv_nsec as u64
}

/// The calling thread's on-CPU time.
pub struct OnCpu;

struct NsFormatter;

impl ValueFormatter for NsFormatter {
    fn scale_values(&self, ns: f64, values: &mut [f64]) -> &'static str {
        let (f, unit) = if ns < 1e3 {
            (1.0, "ns cpu")
        } else if ns < 1e6 {
            (1e-3, "µs cpu")
        } else if ns < 1e9 {
            (1e-6, "ms cpu")
        } else {
            (1e-9, "s cpu")
        };
        for v in values {
            *v *= f;
        }
        unit
    }
    fn scale_throughputs(&self, _: f64, t: &Throughput, values: &mut [f64]) -> &'static str {
        let n = match *t {
            Throughput::Elements(n) | Throughput::Bytes(n) | Throughput::BytesDecimal(n) => n,
            _ => 1,
        } as f64;
        for v in values {
            *v = n * 1e9 / *v;
        }
        "per cpu-s"
    }
    fn scale_for_machines(&self, _: &mut [f64]) -> &'static str {
        "ns"
    }
}

impl Measurement for OnCpu {
    type Intermediate = u64;
    type Value = u64;
    fn start(&self) -> u64 {
        thread_cpu_ns()
    }
    fn end(&self, i: u64) -> u64 {
        thread_cpu_ns().saturating_sub(i)
    }
    fn add(&self, a: &u64, b: &u64) -> u64 {
        a + b
    }
    fn zero(&self) -> u64 {
        0
    }
    fn to_f64(&self, v: &u64) -> f64 {
        *v as f64
    }
    fn formatter(&self) -> &dyn ValueFormatter {
        &NsFormatter
    }
}

/// Runs `benches` with wall-clock time, or with on-CPU time when `GONIO_BENCH_ON_CPU` is set.
pub fn run(benches: fn(&mut Criterion<OnCpu>), wall: fn(&mut Criterion<WallTime>)) {
    if std::env::var_os("GONIO_BENCH_ON_CPU").is_some() {
        let mut c = Criterion::default()
            .with_measurement(OnCpu)
            .configure_from_args();
        benches(&mut c);
        c.final_summary();
    } else {
        let mut c = Criterion::default().configure_from_args();
        wall(&mut c);
        c.final_summary();
    }
}
