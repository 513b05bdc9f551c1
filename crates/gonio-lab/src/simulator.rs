//! A simulated ELCOMAT-type autocollimator looking at a polygon on a simulated encoder's table,
//! answering the serial protocol on a pseudo-terminal (`gonio simulate autocollimator --pty`).
//!
//! The operator sets the bench with [`SimulatedAutocollimator::set`] (shift S, start face j,
//! step i); every request `a` (or `r`) is answered with
//!
//! ```text
//! X = α(θ_i) + Σ_{t<i} β_(j+t) + U_(S,j) + drift·n + noise,   θ_i = (i−1)·360°/N + S
//! ```
//!
//! quantised to the resolution, arcsec: α from an [`EncoderModel`], β the polygon's pitch
//! deviations (Σβ = 0), U a setup error per run, n the number of answers so far; the same
//! model as `gonio_sim::shift_angle`.
//!
//! With a rotary axis under the polygon ([`SimulatedAutocollimator::with_axis`]) the operator
//! may instead move the axis to a target of an ISO 230-2 test ([`SimulatedAutocollimator::approach`]):
//! X = x + Σ_{t≤f} β_t + U, with x where the axis stopped less the target
//! ([`gonio_sim::axis::AxisModel`]) and f the face at the autocollimator. A fraction of answers is flagged with status `013` (`113`
//! for relative readings) instead of `003` (`103`). Relative readings are the absolute ones less
//! a fixed zero of 1000″. Everything random comes from the seed: the same seed and requests give
//! the same bytes.
//!
//! ```
//! use gonio_lab::simulator::{Position, SimConfig, SimulatedAutocollimator};
//! let enc = gonio_sim::EncoderModel::default_with_seed(1);
//! let mut ac = SimulatedAutocollimator::new(enc, SimConfig { faces: 12, ..SimConfig::default() }).unwrap();
//! ac.set(Position { shift_deg: 5.0, start_face: 1, step: 3 });
//! let answer = ac.answer(b'a').unwrap();
//! assert!(answer.starts_with("4 0") && answer.ends_with('\r'));
//! ```

use gonio_calib::axis::Direction;
use gonio_core::Degrees;
use gonio_core::closure::{cyclic_sum, remove_mean};
use gonio_sim::EncoderModel;
use gonio_sim::axis::AxisModel;
use gonio_sim::shift_angle::TrueAlpha;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal, Uniform};
use std::io::{Read, Write};
use std::os::fd::OwnedFd;
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};

/// Relative readings are absolute ones less this zero, arcsec.
pub const RELATIVE_ZERO_ARCSEC: f64 = 1000.0;

/// The simulated bench.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SimConfig {
    /// Polygon faces N.
    pub faces: usize,
    /// Seed of the polygon, setup errors, noise and flagged answers.
    pub seed: u64,
    /// Noise of one answer (standard deviation), arcsec.
    pub sigma_arcsec: f64,
    /// Resolution (quantisation), arcsec; the answers carry its decimals.
    pub resolution_arcsec: f64,
    /// Standard deviation of the polygon's pitch deviations, arcsec.
    pub pitch_sigma_arcsec: f64,
    /// Standard deviation of each run's setup error, arcsec.
    pub setup_sigma_arcsec: f64,
    /// Drift per answer, arcsec.
    pub drift_arcsec_per_reading: f64,
    /// Fraction of answers flagged with a bad status.
    pub flagged_fraction: f64,
}

impl Default for SimConfig {
    /// 24 faces, σ 0.05″, resolution 0.001″, pitch σ 0.3″, setup σ 1″, no drift, 2 % flagged.
    fn default() -> Self {
        SimConfig {
            faces: 24,
            seed: 0,
            sigma_arcsec: 0.05,
            resolution_arcsec: 0.001,
            pitch_sigma_arcsec: 0.3,
            setup_sigma_arcsec: 1.0,
            drift_arcsec_per_reading: 0.0,
            flagged_fraction: 0.02,
        }
    }
}

/// A simulated bench parameter out of range.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{name} = {value}: expected {expected}")]
#[non_exhaustive]
pub struct SimConfigError {
    /// The parameter.
    pub name: &'static str,
    /// Its value.
    pub value: f64,
    /// What is allowed.
    pub expected: &'static str,
}

/// Where the operator set the bench.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Position {
    /// Shift S, degrees.
    pub shift_deg: f64,
    /// Start face j (1-based).
    pub start_face: usize,
    /// Step i (1-based; N + 1 is the closure, at step 1's angle).
    pub step: usize,
}

/// Where the operator moved a rotary axis under test.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Approach {
    /// Target, degrees.
    pub target_deg: f64,
    /// The sense of the approach.
    pub direction: Direction,
    /// Run (1-based).
    pub run: u32,
    /// The polygon face at the autocollimator (1-based).
    pub face: usize,
}

/// The simulated instrument.
#[derive(Debug)]
pub struct SimulatedAutocollimator {
    cfg: SimConfig,
    encoder: EncoderModel,
    /// The rotary axis under the polygon, and where it stopped (x, arcsec) when the operator
    /// last moved it.
    axis: Option<(AxisModel, Option<f64>)>,
    beta: Vec<f64>,
    noise: ChaCha8Rng,
    flags: ChaCha8Rng,
    position: Position,
    answers: u64,
}

fn stream(seed: u64, n: u64) -> ChaCha8Rng {
    let mut r = ChaCha8Rng::seed_from_u64(seed);
    r.set_stream(n);
    r
}

impl SimulatedAutocollimator {
    /// A bench with the polygon drawn from the seed, set at shift 0, start face 1, step 1.
    ///
    /// # Errors
    /// [`SimConfigError`] for fewer than 3 faces, or a σ, resolution, drift or fraction out of
    /// range.
    pub fn new(encoder: EncoderModel, cfg: SimConfig) -> Result<Self, SimConfigError> {
        let bad = |name, value, expected| {
            Err(SimConfigError {
                name,
                value,
                expected,
            })
        };
        if !(3..=gonio_calib::shift_angle::MAX_FACES).contains(&cfg.faces) {
            return bad(
                "faces",
                cfg.faces as f64,
                "3 or more (up to the solver's limit)",
            );
        }
        for (name, v) in [
            ("sigma", cfg.sigma_arcsec),
            ("pitch sigma", cfg.pitch_sigma_arcsec),
            ("setup sigma", cfg.setup_sigma_arcsec),
        ] {
            if !(v.is_finite() && v >= 0.0) {
                return bad(name, v, "a finite value ≥ 0 arcsec");
            }
        }
        if !(cfg.resolution_arcsec.is_finite() && cfg.resolution_arcsec >= 1e-6) {
            return bad(
                "resolution",
                cfg.resolution_arcsec,
                "at least 0.000001 arcsec",
            );
        }
        if !cfg.drift_arcsec_per_reading.is_finite() {
            return bad("drift", cfg.drift_arcsec_per_reading, "a finite value");
        }
        if !(0.0..1.0).contains(&cfg.flagged_fraction) {
            return bad("flagged fraction", cfg.flagged_fraction, "0 ≤ f < 1");
        }
        let d = Normal::new(0.0, cfg.pitch_sigma_arcsec).expect("σ checked");
        let mut r = stream(cfg.seed, 1);
        let mut beta: Vec<f64> = (0..cfg.faces).map(|_| d.sample(&mut r)).collect();
        remove_mean(&mut beta);
        Ok(SimulatedAutocollimator {
            cfg,
            encoder,
            axis: None,
            beta,
            noise: stream(cfg.seed, 3),
            flags: stream(cfg.seed, 5),
            position: Position {
                shift_deg: 0.0,
                start_face: 1,
                step: 1,
            },
            answers: 0,
        })
    }

    /// Sets the bench: the table at shift S, the polygon at step i of the run started at face
    /// j. A face or step out of range is taken modulo N.
    pub fn set(&mut self, p: Position) {
        self.position = p;
        if let Some((_, x)) = &mut self.axis {
            *x = None;
        }
    }

    /// The bench with a rotary axis under the polygon (see the module's documentation).
    ///
    /// # Errors
    /// [`SimConfigError`] for an invalid axis model.
    pub fn with_axis(mut self, axis: AxisModel) -> Result<Self, SimConfigError> {
        axis.validate().map_err(|_| SimConfigError {
            name: "axis",
            value: f64::NAN,
            expected: "a valid axis model (finite, within ±3600″)",
        })?;
        self.axis = Some((axis, None));
        Ok(self)
    }

    /// Moves the axis under test to a target from a direction, in a run, with `face` at the
    /// autocollimator; `false` (nothing moved) without an axis.
    pub fn approach(&mut self, a: Approach) -> bool {
        let Some((model, x)) = &mut self.axis else {
            return false;
        };
        *x = Some(model.deviation_arcsec(a.target_deg, a.direction, a.run));
        self.position = Position {
            shift_deg: 0.0,
            start_face: 1,
            step: a.face,
        };
        true
    }

    /// The bench's position.
    pub fn position(&self) -> Position {
        self.position
    }

    /// The setup error U of the run (shift S, start face j), arcsec: the same whenever the run
    /// is set up again.
    fn setup(&self, shift_deg: f64, start_face: usize) -> f64 {
        let key = (shift_deg * 1e6).round() as i64 as u64;
        let mut r = ChaCha8Rng::seed_from_u64(
            self.cfg.seed ^ key.wrapping_mul(0x9e37_79b9_7f4a_7c15) ^ (start_face as u64) << 48,
        );
        r.set_stream(2);
        Normal::new(0.0, self.cfg.setup_sigma_arcsec)
            .expect("σ checked")
            .sample(&mut r)
    }

    /// The reading without noise and drift at the current position, arcsec.
    pub fn exact_arcsec(&self) -> f64 {
        let n = self.cfg.faces;
        let p = self.position;
        let i = (p.step + n - 1) % n + 1;
        let j = (p.start_face + n - 1) % n + 1;
        let table = match &self.axis {
            Some((_, Some(x))) => *x,
            _ => {
                let theta = Degrees((i - 1) as f64 * 360.0 / n as f64 + p.shift_deg);
                self.encoder.error_at(theta).0
            }
        };
        table + cyclic_sum(&self.beta, j, i) + self.setup(p.shift_deg, j)
    }

    /// The polygon's pitch deviations β_1…β_N, arcsec.
    pub fn pitch_deviations(&self) -> &[f64] {
        &self.beta
    }

    /// The answer line (with its CR) to one request byte: `a` absolute, `r` relative; `None`
    /// for any other byte (the instrument ignores it).
    pub fn answer(&mut self, request: u8) -> Option<String> {
        let (t, good, flagged, zero) = match request {
            b'a' => ("4", "003", "013", 0.0),
            b'r' => ("2", "103", "113", RELATIVE_ZERO_ARCSEC),
            _ => return None,
        };
        let noise = if self.cfg.sigma_arcsec > 0.0 {
            Normal::new(0.0, self.cfg.sigma_arcsec)
                .expect("σ checked")
                .sample(&mut self.noise)
        } else {
            0.0
        };
        let flag = Uniform::new(0.0, 1.0)
            .expect("valid range")
            .sample(&mut self.flags)
            < self.cfg.flagged_fraction;
        let x =
            self.exact_arcsec() + self.cfg.drift_arcsec_per_reading * self.answers as f64 + noise
                - zero;
        self.answers += 1;
        let res = self.cfg.resolution_arcsec;
        let d = (-res.log10()).ceil().max(0.0) as usize;
        let q = |v: f64| (v / res).round() * res;
        let y = -0.2 + 0.1 * noise;
        let status = if flag { flagged } else { good };
        Some(format!("{t} {status} {:+.d$} {:+.d$}\r", q(x), q(y)))
    }

    /// The true α at every step of each shift, after the shift's closure (the mean over its N
    /// angles removed): what a calibration can recover, as `gonio simulate shift-angle` writes
    /// it in `truth.json`.
    pub fn truth(&self, shifts_deg: &[f64]) -> Vec<TrueAlpha> {
        let n = self.cfg.faces;
        let mut out = Vec::with_capacity(shifts_deg.len() * n);
        for &s in shifts_deg {
            let angles: Vec<f64> = (0..n)
                .map(|i| Degrees(s + i as f64 * 360.0 / n as f64).normalized().0)
                .collect();
            let model: Vec<f64> = angles
                .iter()
                .map(|&a| self.encoder.error_at(Degrees(a)).0)
                .collect();
            let mut closed = model.clone();
            remove_mean(&mut closed);
            for i in 0..n {
                out.push(TrueAlpha {
                    shift_deg: s,
                    step: i + 1,
                    angle_deg: angles[i],
                    value_arcsec: closed[i],
                    model_arcsec: model[i],
                });
            }
        }
        out
    }
}

/// A pseudo-terminal pair: the simulator holds the master, a program opens the slave's path as
/// its serial port.
#[derive(Debug)]
pub struct Pty {
    master: OwnedFd,
    /// Held open so that the master reads nothing (not an error) while no program has the port.
    _slave: OwnedFd,
    path: PathBuf,
}

impl Pty {
    /// Opens a new pair, the slave in raw mode (no echo, no line editing).
    ///
    /// # Errors
    /// The system's pseudo-terminal calls failed.
    pub fn open() -> std::io::Result<Pty> {
        use rustix::pty::{OpenptFlags, grantpt, openpt, ptsname, unlockpt};
        let master = openpt(OpenptFlags::RDWR | OpenptFlags::NOCTTY | OpenptFlags::CLOEXEC)?;
        grantpt(&master)?;
        unlockpt(&master)?;
        let name = ptsname(&master, Vec::new())?;
        let path = PathBuf::from(name.to_string_lossy().into_owned());
        let slave = rustix::fs::open(
            &path,
            rustix::fs::OFlags::RDWR | rustix::fs::OFlags::NOCTTY | rustix::fs::OFlags::CLOEXEC,
            rustix::fs::Mode::empty(),
        )?;
        let mut t = rustix::termios::tcgetattr(&slave)?;
        t.make_raw();
        rustix::termios::tcsetattr(&slave, rustix::termios::OptionalActions::Now, &t)?;
        Ok(Pty {
            master,
            _slave: slave,
            path,
        })
    }

    /// The slave's path (`/dev/pts/N`): the serial port to give the program.
    pub fn path(&self) -> &std::path::Path {
        &self.path
    }

    /// Answers requests on the master until `stop` is set: every `a` or `r` byte is answered
    /// by `instrument` (CR, LF and other bytes are ignored). Returns the number of answers.
    ///
    /// # Errors
    /// Reading or writing the master failed.
    pub fn serve(
        &self,
        instrument: &Arc<Mutex<SimulatedAutocollimator>>,
        stop: &AtomicBool,
    ) -> std::io::Result<u64> {
        use rustix::event::{PollFd, PollFlags, Timespec, poll};
        let mut file = std::fs::File::from(self.master.try_clone()?);
        let mut buf = [0u8; 256];
        let mut answers = 0;
        let wait = Timespec {
            tv_sec: 0,
            tv_nsec: 100_000_000,
        };
        while !stop.load(Ordering::Relaxed) {
            let mut fds = [PollFd::new(&self.master, PollFlags::IN)];
            let n = match poll(&mut fds, Some(&wait)) {
                Ok(n) => n,
                Err(rustix::io::Errno::INTR) => continue,
                Err(e) => return Err(e.into()),
            };
            if n == 0 {
                continue;
            }
            let got = match file.read(&mut buf) {
                Ok(0) => continue,
                Ok(g) => g,
                Err(e) if e.kind() == std::io::ErrorKind::Interrupted => continue,
                Err(e) => return Err(e),
            };
            for &b in &buf[..got] {
                let reply = instrument
                    .lock()
                    .unwrap_or_else(|e| e.into_inner())
                    .answer(b);
                if let Some(line) = reply {
                    file.write_all(line.as_bytes())?;
                    answers += 1;
                }
            }
        }
        Ok(answers)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sim(seed: u64, flagged: f64) -> SimulatedAutocollimator {
        SimulatedAutocollimator::new(
            EncoderModel::default_with_seed(1),
            SimConfig {
                faces: 12,
                seed,
                flagged_fraction: flagged,
                ..SimConfig::default()
            },
        )
        .unwrap()
    }

    #[test]
    fn same_seed_same_bytes_and_the_runs_setup_error_returns() {
        let (mut a, mut b) = (sim(4, 0.1), sim(4, 0.1));
        let p = Position {
            shift_deg: 10.0,
            start_face: 3,
            step: 5,
        };
        a.set(p);
        b.set(p);
        let wa: Vec<String> = (0..50).map(|_| a.answer(b'a').unwrap()).collect();
        let wb: Vec<String> = (0..50).map(|_| b.answer(b'a').unwrap()).collect();
        assert_eq!(wa, wb);
        assert!(wa.iter().any(|l| l.starts_with("4 013")));
        assert!(wa.iter().filter(|l| l.starts_with("4 003")).count() > 35);
        // The same position set again reads the same (U belongs to the run).
        let e = a.exact_arcsec();
        a.set(Position { step: 1, ..p });
        a.set(p);
        assert_eq!(a.exact_arcsec(), e);
        // The closure (step N + 1) reads as step 1.
        a.set(Position { step: 13, ..p });
        let c = a.exact_arcsec();
        a.set(Position { step: 1, ..p });
        assert!((a.exact_arcsec() - c).abs() < 1e-12);
        assert_eq!(a.answer(b'x'), None);
        assert!(a.answer(b'r').unwrap().starts_with("2 1"));
    }

    #[test]
    fn an_axis_under_the_polygon_reads_its_deviation_plus_the_face() {
        let axis = AxisModel::default_with_seed(2);
        let mut a = sim(4, 0.0).with_axis(axis.clone()).unwrap();
        let go = |face, run| Approach {
            target_deg: 30.0 * (face - 1) as f64,
            direction: Direction::Down,
            run,
            face,
        };
        assert!(a.approach(go(3, 1)));
        let x3 = a.exact_arcsec();
        a.approach(go(4, 1));
        let x4 = a.exact_arcsec();
        // One face on: the axis's deviation there and β_4 more.
        let want = axis.deviation_arcsec(90.0, Direction::Down, 1)
            - axis.deviation_arcsec(60.0, Direction::Down, 1)
            + a.pitch_deviations()[3];
        assert!((x4 - x3 - want).abs() < 1e-12, "{} vs {want}", x4 - x3);
        // The same approach stops at the same place; another run elsewhere.
        a.approach(go(3, 1));
        assert_eq!(a.exact_arcsec(), x3);
        a.approach(go(3, 2));
        assert_ne!(a.exact_arcsec(), x3);
        // Without an axis nothing moves.
        assert!(!sim(4, 0.0).approach(go(3, 1)));
    }
}
