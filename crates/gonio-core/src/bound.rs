//! Bounds of numeric settings, with their units: every number a file or a flag gives is checked
//! against a [`Bound`] where it is read, and a refusal names the bound it broke
//! (`timing.command_timeout_s = 1e300: at most 3600 s`).
//!
//! [`Num`] prints a number the way a user writes it: the shortest text that reads back as the
//! same `f64`, in scientific form when it is very large or very small (`1e300`, `1e-300`), never
//! three hundred zeros. [`duration_s`] and [`saturating_duration_s`] are the only ways a float
//! becomes a [`Duration`] (`Duration::from_secs_f64` panics on a negative, non-finite or huge
//! value).
//!
//! Errors: [`OutOfBound`], whose text is the bound alone (`at most 3600 s`), for the caller to
//! put after the setting's name and value.
//!
//! ```
//! use gonio_core::bound::{Bound, Num};
//! const TIMEOUT_S: Bound = Bound::new(0.0, 3600.0, "s").lo_excluded();
//! assert_eq!(TIMEOUT_S.check(30.0).unwrap(), 30.0);
//! let e = TIMEOUT_S.check(1e300).unwrap_err();
//! assert_eq!(format!("command_timeout_s = {}: {e}", Num(1e300)), "command_timeout_s = 1e300: at most 3600 s");
//! assert_eq!(TIMEOUT_S.check(0.0).unwrap_err().to_string(), "above 0 s");
//! assert_eq!(TIMEOUT_S.check(f64::NAN).unwrap_err().to_string(), "not a finite number: expected above 0 s, at most 3600 s");
//! ```

use std::fmt;
use std::time::Duration;

/// The range a numeric setting may take, with its unit: both ends finite, each included or
/// not. Integers are checked through [`Bound::check_int`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Bound {
    lo: f64,
    lo_open: bool,
    hi: f64,
    hi_open: bool,
    unit: &'static str,
}

/// Which end of its [`Bound`] a value broke.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[non_exhaustive]
pub enum Broke {
    /// NaN or infinite.
    NotFinite,
    /// Below the lower end (or on it, when the lower end is excluded).
    Low,
    /// Above the upper end (or on it, when the upper end is excluded).
    High,
}

/// A value outside its [`Bound`]. Its text names the end it broke, with the unit: `at most
/// 3600 s`, `at least 1 ms`, `above 0 µm`, `below 1`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OutOfBound {
    /// The value given.
    pub value: f64,
    /// The bound it broke.
    pub bound: Bound,
    /// Which end.
    pub broke: Broke,
}

impl std::error::Error for OutOfBound {}

impl fmt::Display for OutOfBound {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let b = &self.bound;
        match self.broke {
            Broke::NotFinite => write!(f, "not a finite number: expected {b}"),
            Broke::Low => b.lo_text(f),
            Broke::High => b.hi_text(f),
        }
    }
}

impl Bound {
    /// The closed range `lo ..= hi` in `unit` (`""` for a plain count or ratio; a unit starting
    /// with `°`, `′` or `″` follows the number without a space).
    pub const fn new(lo: f64, hi: f64, unit: &'static str) -> Bound {
        Bound {
            lo,
            lo_open: false,
            hi,
            hi_open: false,
            unit,
        }
    }

    /// The same range without its lower end (`above 0 s`).
    pub const fn lo_excluded(self) -> Bound {
        Bound {
            lo_open: true,
            ..self
        }
    }

    /// The same range without its upper end (`below 1`).
    pub const fn hi_excluded(self) -> Bound {
        Bound {
            hi_open: true,
            ..self
        }
    }

    /// The lower end.
    pub const fn lo(&self) -> f64 {
        self.lo
    }

    /// The upper end.
    pub const fn hi(&self) -> f64 {
        self.hi
    }

    /// The unit.
    pub const fn unit(&self) -> &'static str {
        self.unit
    }

    /// Whether `v` lies inside (a NaN or an infinity never does).
    pub fn contains(&self, v: f64) -> bool {
        self.check(v).is_ok()
    }

    /// `v`, if it lies inside.
    ///
    /// # Errors
    /// [`OutOfBound`] naming the end it broke.
    pub fn check(&self, v: f64) -> Result<f64, OutOfBound> {
        let broke = if !v.is_finite() {
            Broke::NotFinite
        } else if v < self.lo || (self.lo_open && v == self.lo) {
            Broke::Low
        } else if v > self.hi || (self.hi_open && v == self.hi) {
            Broke::High
        } else {
            return Ok(v);
        };
        Err(OutOfBound {
            value: v,
            bound: *self,
            broke,
        })
    }

    /// A whole number, if it lies inside. The comparison is exact for every `i128` (ends beyond
    /// 2⁵³ are rounded to the nearest `f64`).
    ///
    /// # Errors
    /// [`OutOfBound`] naming the end it broke (its `value` rounded to an `f64`).
    pub fn check_int<T: Copy + TryInto<i128>>(&self, v: T) -> Result<T, OutOfBound> {
        // Every integer type up to 64 bits fits in an i128.
        let i: i128 = v.try_into().unwrap_or(i128::MAX);
        let (lo, hi) = (self.lo.ceil() as i128, self.hi.floor() as i128);
        let low = i < lo || (self.lo_open && (i as f64) <= self.lo);
        let high = i > hi || (self.hi_open && (i as f64) >= self.hi);
        if !low && !high {
            return Ok(v);
        }
        Err(OutOfBound {
            value: i as f64,
            bound: *self,
            broke: if low { Broke::Low } else { Broke::High },
        })
    }

    fn with_unit(&self, f: &mut fmt::Formatter<'_>, v: f64) -> fmt::Result {
        let tight = self.unit.is_empty() || self.unit.starts_with(['°', '′', '″']);
        let sep = if tight { "" } else { " " };
        write!(f, "{}{sep}{}", Num(v), self.unit)
    }

    fn lo_text(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(if self.lo_open { "above " } else { "at least " })?;
        self.with_unit(f, self.lo)
    }

    fn hi_text(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(if self.hi_open { "below " } else { "at most " })?;
        self.with_unit(f, self.hi)
    }
}

impl fmt::Display for Bound {
    /// `0 to 3600 s`, or with an excluded end `above 0 s, at most 3600 s`.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.lo_open || self.hi_open {
            self.lo_text(f)?;
            f.write_str(", ")?;
            self.hi_text(f)
        } else {
            write!(f, "{} to ", Num(self.lo))?;
            self.with_unit(f, self.hi)
        }
    }
}

/// A number as a user writes it: the shortest decimal text that reads back as the same `f64`,
/// in scientific form (`1e300`, `2.5e-7`) when its magnitude is 10¹⁶ or more or below 10⁻⁴.
///
/// ```
/// use gonio_core::bound::Num;
/// assert_eq!(Num(1e-300).to_string(), "1e-300");
/// assert_eq!(Num(0.001).to_string(), "0.001");
/// assert_eq!(Num(3600.0).to_string(), "3600");
/// assert_eq!(Num(1.5e20).to_string(), "1.5e20");
/// assert_eq!(Num(-0.25).to_string(), "-0.25");
/// assert_eq!(Num(f64::INFINITY).to_string(), "inf");
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Num(pub f64);

impl fmt::Display for Num {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let v = self.0;
        let m = v.abs();
        if v.is_finite() && m != 0.0 && !(1e-4..1e16).contains(&m) {
            write!(f, "{v:e}")
        } else {
            write!(f, "{v}")
        }
    }
}

/// A value's text for a message with a number written the short way: the text of a float
/// printed with `{}` (`1000…000`, three hundred digits for 1e300) becomes [`Num`]'s (`1e300`);
/// any other text is kept as it is. For error constructors that take a value as text.
///
/// ```
/// use gonio_core::bound::tidy;
/// assert_eq!(tidy(&1e300.to_string()), "1e300");
/// assert_eq!(tidy(&1e-300.to_string()), "1e-300");
/// assert_eq!(tidy("0.25"), "0.25");
/// assert_eq!(tidy("[1440, 540]"), "[1440, 540]");
/// ```
pub fn tidy(text: &str) -> String {
    match text.parse::<f64>() {
        Ok(v) if v.is_finite() => {
            let short = Num(v).to_string();
            if short.len() < text.len() {
                short
            } else {
                text.to_string()
            }
        }
        _ => text.to_string(),
    }
}

/// Seconds as a [`Duration`], checked against `bound` first (whose ends must lie in 0 … 10¹⁸ s).
///
/// # Errors
/// [`OutOfBound`] when `secs` is outside `bound`.
///
/// ```
/// use gonio_core::bound::{Bound, duration_s};
/// let b = Bound::new(0.0, 60.0, "s");
/// assert_eq!(duration_s(1.5, &b).unwrap().as_millis(), 1500);
/// assert_eq!(duration_s(1e300, &b).unwrap_err().to_string(), "at most 60 s");
/// ```
pub fn duration_s(secs: f64, bound: &Bound) -> Result<Duration, OutOfBound> {
    let s = bound.check(secs)?;
    Ok(saturating_duration_s(s))
}

/// Seconds computed from checked settings as a [`Duration`], never panicking: NaN and negative
/// values give zero, values beyond what a `Duration` holds give [`Duration::MAX`].
///
/// ```
/// use gonio_core::bound::saturating_duration_s;
/// use std::time::Duration;
/// assert_eq!(saturating_duration_s(0.25), Duration::from_millis(250));
/// assert_eq!(saturating_duration_s(-1.0), Duration::ZERO);
/// assert_eq!(saturating_duration_s(f64::NAN), Duration::ZERO);
/// assert_eq!(saturating_duration_s(1e300), Duration::MAX);
/// ```
pub fn saturating_duration_s(secs: f64) -> Duration {
    if secs.is_nan() || secs <= 0.0 {
        return Duration::ZERO;
    }
    Duration::try_from_secs_f64(secs).unwrap_or(Duration::MAX)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn each_end_is_named_with_its_unit() {
        let b = Bound::new(1.0, 256.0, "");
        assert_eq!(b.check(0.0).unwrap_err().to_string(), "at least 1");
        assert_eq!(b.check(257.0).unwrap_err().to_string(), "at most 256");
        let deg = Bound::new(0.0, 720.0, "°").lo_excluded();
        assert_eq!(deg.check(800.0).unwrap_err().to_string(), "at most 720°");
        assert_eq!(deg.check(0.0).unwrap_err().to_string(), "above 0°");
        let frac = Bound::new(0.0, 1.0, "").hi_excluded();
        assert_eq!(frac.check(1.0).unwrap_err().to_string(), "below 1");
        assert!(frac.contains(0.0) && frac.contains(0.999));
        let tiny = Bound::new(1e-3, 1e6, "simulated s per s");
        assert_eq!(
            tiny.check(1e-300).unwrap_err().to_string(),
            "at least 0.001 simulated s per s"
        );
        assert_eq!(
            tiny.check(f64::INFINITY).unwrap_err().to_string(),
            "not a finite number: expected 0.001 to 1000000 simulated s per s"
        );
    }

    #[test]
    fn whole_numbers_are_compared_exactly() {
        let threads = Bound::new(1.0, 256.0, "threads");
        assert_eq!(threads.check_int(256u64).unwrap(), 256);
        assert_eq!(
            threads.check_int(4096u64).unwrap_err().to_string(),
            "at most 256 threads"
        );
        assert_eq!(threads.check_int(-1i64).unwrap_err().broke, Broke::Low);
        assert_eq!(threads.check_int(u64::MAX).unwrap_err().broke, Broke::High);
        let open = Bound::new(0.0, 10.0, "").lo_excluded();
        assert!(open.check_int(0u8).is_err() && open.check_int(1usize).is_ok());
    }

    #[test]
    fn numbers_print_as_written_or_in_scientific_form() {
        for (v, s) in [
            (1e300, "1e300"),
            (1e-300, "1e-300"),
            (0.0, "0"),
            (1e-4, "0.0001"),
            (9.5e-5, "9.5e-5"),
            (1e15, "1000000000000000"),
            (1e16, "1e16"),
            (30.0, "30"),
            (0.1 + 0.2, "0.30000000000000004"),
        ] {
            assert_eq!(Num(v).to_string(), s);
            assert_eq!(Num(v).to_string().parse::<f64>().unwrap(), v);
        }
    }

    #[test]
    fn durations_never_panic() {
        let b = Bound::new(0.0, 3600.0, "s");
        for v in [f64::NAN, -1.0, 1e20, f64::INFINITY] {
            assert!(duration_s(v, &b).is_err(), "{v}");
        }
        assert_eq!(saturating_duration_s(f64::INFINITY), Duration::MAX);
    }
}
