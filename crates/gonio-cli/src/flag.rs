//! Numeric flags bounded where clap reads them: `value_parser = flag::real(B)` for a number,
//! `flag::whole::<T>(B)` for a count, `B` a [`gonio_core::bound::Bound`] with its unit. A
//! refused value is quoted as the user wrote it and the message names the bound:
//! `error: invalid value '1e-300' for '--speed <SPEED>': at least 0.001 simulated s per s`.
//! [`one_line`] makes every clap error such one line (exit code 2), as gonio's other errors.
//!
//! ```
//! use clap::Parser;
//! use gonio_core::bound::Bound;
//! #[derive(Parser)]
//! struct Args {
//!     #[arg(long, value_parser = gonio_cli::flag::real(Bound::new(0.0, 60.0, "s").lo_excluded()))]
//!     timeout_s: f64,
//! }
//! assert_eq!(Args::try_parse_from(["x", "--timeout-s", "2.5"]).unwrap().timeout_s, 2.5);
//! let e = Args::try_parse_from(["x", "--timeout-s", "1e300"]).err().unwrap();
//! assert_eq!(
//!     gonio_cli::flag::one_line(&e),
//!     "invalid value '1e300' for '--timeout-s <TIMEOUT_S>': at most 60 s"
//! );
//! ```

use clap::builder::TypedValueParser;
use gonio_core::bound::Bound;

/// An angle: a start angle, an eccentricity's angle, °.
pub const ANGLE_DEG: Bound = Bound::new(-1e6, 1e6, "°");
/// A table's speed, °/s (either direction; 10⁶ °/s is 2800 turns a second).
pub const SPEED_DEG_S: Bound = Bound::new(-1e6, 1e6, "°/s");
/// A frame rate, frames per second.
pub const FPS: Bound = Bound::new(0.0, 1e6, "frames/s").lo_excluded();
/// A grating's eccentricity, µm (either sign: the angle then turns by 180°).
pub const ECCENTRICITY_UM: Bound = Bound::new(-1e6, 1e6, "µm");
/// A run's length in seconds (`--duration-s`): up to 11.5 days.
pub const DURATION_S: Bound = Bound::new(0.0, 1e6, "s").lo_excluded();

/// A reading's standard deviation σ, arcsec (given, not estimated).
pub const SIGMA_ARCSEC: Bound = Bound::new(0.0, 3600.0, "″").lo_excluded();
/// A polygon's faces (`gonio_calib::shift_angle::MAX_FACES`).
pub const FACES: Bound = Bound::new(3.0, gonio_calib::shift_angle::MAX_FACES as f64, "faces");
/// The largest harmonic order of a table or a fit.
pub const MAX_ORDER: Bound = Bound::new(0.0, gonio_calib::selfcal::MAX_ORDER as f64, "");

/// A simulated instrument's σ (noise, pitch deviations, setup errors, graduation), arcsec: 0
/// for none.
pub const SIM_SIGMA_ARCSEC: Bound = Bound::new(0.0, 3600.0, "″");
/// A simulated instrument's resolution, arcsec: 0 for none.
pub const RESOLUTION_ARCSEC: Bound = Bound::new(0.0, 3600.0, "″");
/// A fraction (of readings, of answers, of packets).
pub const FRACTION: Bound = Bound::new(0.0, 1.0, "");
/// Faces of a simulated polygon or an autocollimator's polygon.
pub const SIM_FACES: Bound = FACES;

/// A number within `bound` (`nan`, `inf` and numbers beyond `f64`'s range are refused).
pub fn real(bound: Bound) -> impl TypedValueParser<Value = f64> {
    move |s: &str| -> Result<f64, String> {
        let v: f64 = s
            .trim()
            .parse()
            .map_err(|_| format!("expected a number ({bound})"))?;
        bound.check(v).map_err(|e| e.to_string())
    }
}

/// A whole number of type `T` within `bound`.
pub fn whole<T>(bound: Bound) -> impl TypedValueParser<Value = T>
where
    T: TryFrom<i128> + TryInto<i128> + Copy + Clone + Send + Sync + 'static,
{
    move |s: &str| -> Result<T, String> {
        let expected = || format!("expected a whole number ({bound})");
        let i: i128 = s.trim().parse().map_err(|_| expected())?;
        let v = T::try_from(i).map_err(|_| {
            // Beyond the type: say which end, as for any other value out of bounds.
            let end = if i < 0 {
                bound.check(f64::MIN)
            } else {
                bound.check(f64::MAX)
            };
            end.map_or_else(|e| e.to_string(), |_| expected())
        })?;
        bound.check_int(v).map_err(|e| e.to_string())
    }
}

/// A clap error as one line, without the `error: ` prefix: its message, then any tip, joined by
/// `; ` (clap's usage and `For more information` lines dropped: `--help` has them).
pub fn one_line(e: &clap::Error) -> String {
    let text = e.render().to_string();
    let parts: Vec<&str> = text
        .lines()
        .map(str::trim)
        .filter(|l| {
            !l.is_empty() && !l.starts_with("Usage:") && !l.starts_with("For more information")
        })
        .collect();
    let joined = parts.join("; ");
    joined
        .strip_prefix("error: ")
        .unwrap_or(&joined)
        .to_string()
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::Parser;

    const THREADS: Bound = Bound::new(1.0, 256.0, "");

    #[derive(Debug, Parser)]
    struct Args {
        #[arg(long, value_parser = whole::<u16>(THREADS))]
        threads: Option<u16>,
        #[arg(long, allow_hyphen_values = true, value_parser = real(Bound::new(-1e6, 1e6, "µm")))]
        defocus: Option<f64>,
    }

    fn refused(args: &[&str]) -> String {
        let mut v = vec!["gonio"];
        v.extend_from_slice(args);
        one_line(&Args::try_parse_from(v).unwrap_err())
    }

    #[test]
    fn values_are_quoted_as_written_and_the_bound_is_named() {
        assert_eq!(
            refused(&["--threads", "4096"]),
            "invalid value '4096' for '--threads <THREADS>': at most 256"
        );
        assert_eq!(
            refused(&["--threads=-1"]),
            "invalid value '-1' for '--threads <THREADS>': at least 1"
        );
        assert!(refused(&["--threads", "99999999999999999999"]).ends_with("at most 256"));
        assert!(refused(&["--threads", "2.5"]).ends_with("expected a whole number (1 to 256)"));
        assert_eq!(
            refused(&["--defocus", "1e300"]),
            "invalid value '1e300' for '--defocus <DEFOCUS>': at most 1000000 µm"
        );
        assert!(refused(&["--defocus", "nan"]).contains("not a finite number"));
        assert!(refused(&["--defocus", "1e400"]).contains("not a finite number"));
        let a = Args::try_parse_from(["gonio", "--defocus", "-20", "--threads", "256"]).unwrap();
        assert_eq!((a.defocus, a.threads), (Some(-20.0), Some(256)));
    }

    #[test]
    fn clap_errors_are_one_line_with_their_tip() {
        let e = refused(&["--thread", "2"]);
        assert!(!e.contains('\n'), "{e}");
        assert!(
            e.starts_with("unexpected argument '--thread' found; tip:"),
            "{e}"
        );
    }
}
