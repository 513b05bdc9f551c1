//! Times in the store: UTC, RFC 3339 with microseconds (`2026-05-20T14:03:07.123456Z`), a form
//! that sorts as text in time order, so both databases compare it the same way.
//!
//! ```
//! use gonio_store::time::parse_since;
//! assert_eq!(parse_since("2026-05-20").unwrap(), "2026-05-20T00:00:00.000000Z");
//! assert_eq!(parse_since("2026-05-20T16:03:07+02:00").unwrap(), "2026-05-20T14:03:07.000000Z");
//! assert!(parse_since("yesterday").is_err());
//! ```

use crate::StoreError;
use time::format_description::well_known::Rfc3339;
use time::macros::format_description;
use time::{Date, OffsetDateTime, PrimitiveDateTime, UtcOffset};

/// The current time in the store's form.
pub fn now_utc() -> String {
    format(OffsetDateTime::now_utc())
}

fn format(t: OffsetDateTime) -> String {
    let t = t.to_offset(UtcOffset::UTC);
    let f =
        format_description!("[year]-[month]-[day]T[hour]:[minute]:[second].[subsecond digits:6]Z");
    t.format(&f).unwrap_or_else(|_| t.to_string())
}

/// Reads a time given by a user (`--since`): a date `YYYY-MM-DD` (midnight UTC), a UTC time
/// `YYYY-MM-DDTHH:MM[:SS]` (a trailing `Z` allowed), or RFC 3339 with an offset. Returns the
/// store's form.
///
/// # Errors
/// [`StoreError::Invalid`] naming what is accepted.
pub fn parse_since(s: &str) -> Result<String, StoreError> {
    let s = s.trim();
    if let Ok(t) = OffsetDateTime::parse(s, &Rfc3339) {
        return Ok(format(t));
    }
    let bare = s.strip_suffix('Z').unwrap_or(s);
    let with_secs = format_description!("[year]-[month]-[day]T[hour]:[minute]:[second]");
    let no_secs = format_description!("[year]-[month]-[day]T[hour]:[minute]");
    if let Ok(t) = PrimitiveDateTime::parse(bare, &with_secs)
        .or_else(|_| PrimitiveDateTime::parse(bare, &no_secs))
    {
        return Ok(format(t.assume_utc()));
    }
    if let Ok(d) = Date::parse(bare, &format_description!("[year]-[month]-[day]")) {
        return Ok(format(d.midnight().assume_utc()));
    }
    Err(StoreError::Invalid {
        what: "time",
        value: s.to_string(),
        expected: "a date YYYY-MM-DD, a UTC time YYYY-MM-DDTHH:MM[:SS][Z], or RFC 3339 with an offset",
    })
}
