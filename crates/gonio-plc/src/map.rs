//! The register map: where every value lives in the PLC's Modbus registers, its scaling, the
//! link's timing and the push rod's geometry, as data (`examples/plc/modbus-map.toml`, loaded
//! with `gonio mount --plc-map`). `docs/plc-interface.md` documents every register.
//!
//! Addresses are 0-based protocol addresses (register 40001 of a PLC manual is holding
//! register 0). A 32-bit value takes two registers and a 64-bit value four, the most
//! significant word first. Holding registers (function codes 3, 6 and 16) are written by gonio,
//! input registers (function code 4) by the PLC.
//!
//! Units: angles are sent as integers of `1 / scale.angle_per_deg` degrees (default 0.0001°),
//! speeds of `1 / scale.speed_per_deg_s` °/s, lengths of `1 / scale.length_per_um` µm (1 nm).
//!
//! Every number is bounded where it is read, and a value outside its bound is refused naming the
//! bound (`timing.command_timeout_s = 1e300: at most 3600 s`), so that no timing or length from
//! the file can stall the link or overflow a `Duration`.
//!
//! Errors: [`MapError`], naming the line and column of a bad key or value.
//!
//! ```
//! use gonio_plc::map::RegisterMap;
//! let m = RegisterMap::from_toml("[timing]\nwatchdog_ms = 1500\n").unwrap();
//! assert_eq!(m.timing.watchdog_ms, 1500);
//! assert_eq!(m.input.latch_ring, RegisterMap::default().input.latch_ring);
//! ```

use gonio_core::bound::{Bound, Num};
use serde::{Deserialize, Serialize};
use thiserror::Error;

/// Registers of one latch-ring entry: trigger count (u32), mid-exposure time (u64 µs) and
/// servo angle (i32).
pub const LATCH_ENTRY_REGS: u16 = 8;
/// Registers of one angle-sample entry: time (u64 µs) and servo angle (i32).
pub const SAMPLE_ENTRY_REGS: u16 = 6;
/// Registers of the status block read by every poll (input registers `status` on).
pub const STATUS_BLOCK_REGS: u16 = 22;

/// An error of a register map.
#[derive(Debug, Error, Clone, PartialEq)]
#[non_exhaustive]
pub enum MapError {
    /// The TOML is not valid or has unknown keys or wrong types.
    #[error("line {line}, column {column}: {message}")]
    Syntax {
        /// 1-based line.
        line: usize,
        /// 1-based column.
        column: usize,
        /// What was wrong.
        message: String,
    },
    /// A value is out of its range or two regions overlap.
    #[error("{key} = {value}: {expected}")]
    Value {
        /// The key, with its section.
        key: String,
        /// The value given, as written in the file when it was read from one.
        value: String,
        /// What is allowed (`at most 3600 s`, `expected no overlap with …`).
        expected: String,
        /// 1-based line and column of the value in the text it was read from (0 when not read
        /// from a text).
        line: usize,
        /// See `line`.
        column: usize,
    },
}

/// Holding registers: written by gonio.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Holding {
    /// The command word ([`Command`](crate::link::Command)).
    pub command: u16,
    /// The sequence counter: a command is taken when this changes.
    pub sequence: u16,
    /// First argument, i32 (two registers).
    pub arg0: u16,
    /// Second argument, i32 (two registers).
    pub arg1: u16,
    /// gonio's heartbeat counter (the PLC's watchdog watches it change).
    pub heartbeat: u16,
}

impl Default for Holding {
    fn default() -> Self {
        Holding {
            command: 0,
            sequence: 1,
            arg0: 2,
            arg1: 4,
            heartbeat: 6,
        }
    }
}

/// Input registers: written by the PLC.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Input {
    /// First register of the status block ([`STATUS_BLOCK_REGS`] registers: status word,
    /// acknowledged sequence, fault code, PLC heartbeat, PLC time, servo angle, focus, rod,
    /// trigger count, part number, sample count, servo speed).
    pub status: u16,
    /// First register of the latch ring.
    pub latch_ring: u16,
    /// Entries of the latch ring.
    pub latch_ring_len: u16,
    /// First register of the angle-sample ring (the fallback without a trigger line).
    pub sample_ring: u16,
    /// Entries of the angle-sample ring.
    pub sample_ring_len: u16,
}

impl Default for Input {
    fn default() -> Self {
        Input {
            status: 0,
            latch_ring: 100,
            latch_ring_len: 128,
            sample_ring: 1200,
            sample_ring_len: 128,
        }
    }
}

/// Integer scaling of the values on the wire.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Scale {
    /// Counts per degree of angle.
    pub angle_per_deg: f64,
    /// Counts per °/s of speed.
    pub speed_per_deg_s: f64,
    /// Counts per µm of length (focus, rod).
    pub length_per_um: f64,
}

impl Default for Scale {
    fn default() -> Self {
        Scale {
            angle_per_deg: 10_000.0,
            speed_per_deg_s: 1_000.0,
            length_per_um: 1_000.0,
        }
    }
}

/// The link's timing.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Timing {
    /// The PLC's watchdog on gonio's heartbeat, and gonio's on the PLC's, ms.
    pub watchdog_ms: u64,
    /// gonio writes its heartbeat at least this often while it talks to the PLC, ms.
    pub heartbeat_ms: u64,
    /// Longest wait for one reply, ms.
    pub reply_timeout_ms: u64,
    /// Longest a command may stay busy, s.
    pub command_timeout_s: f64,
    /// Longest wait for the next camera frame, ms.
    pub frame_timeout_ms: u64,
    /// Status poll period while a command is busy, ms.
    pub poll_ms: u64,
    /// After an abort (a device error, an interrupt, the batch's end), the safe-state commands
    /// (retract, stop, trigger off) together wait at most this long, ms.
    pub safe_state_ms: u64,
}

impl Default for Timing {
    fn default() -> Self {
        Timing {
            watchdog_ms: 2000,
            heartbeat_ms: 200,
            reply_timeout_ms: 1000,
            command_timeout_s: 30.0,
            frame_timeout_ms: 1000,
            poll_ms: 5,
            safe_state_ms: 5000,
        }
    }
}

/// The push rod's geometry and its approach to contact.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Rod {
    /// Rod travel from home to the edge of a centred grating, µm.
    pub gap_centred_um: f64,
    /// The ring's column with the grating centred, px (the edge is nearer the rod by
    /// `(c − centre_column_px) · µm/px`).
    pub centre_column_px: f64,
    /// The fast move stops this far before the expected edge, µm.
    pub margin_um: f64,
    /// Creep speed of a fast approach, µm/s.
    pub creep_fast_um_per_s: f64,
    /// Creep speed of a slow approach, µm/s.
    pub creep_slow_um_per_s: f64,
    /// The PLC stops the rod and faults at this travel without contact, µm.
    pub travel_limit_um: f64,
    /// Frames averaged for the baseline column before the approach.
    pub baseline_frames: usize,
    /// Contact when the column leaves the baseline by this many standard deviations …
    pub contact_sigmas: f64,
    /// … and at least this many px …
    pub contact_min_px: f64,
    /// … in this many frames in a row.
    pub contact_frames: usize,
}

impl Default for Rod {
    fn default() -> Self {
        Rod {
            gap_centred_um: 600.0,
            centre_column_px: 720.0,
            margin_um: 20.0,
            creep_fast_um_per_s: 100.0,
            creep_slow_um_per_s: 25.0,
            travel_limit_um: 1000.0,
            baseline_frames: 10,
            contact_sigmas: 6.0,
            contact_min_px: 0.6,
            contact_frames: 2,
        }
    }
}

/// How a frame gets its angle.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Pairing {
    /// The PLC triggers the camera and latches the angle per trigger (default).
    #[default]
    Latched,
    /// No trigger line: the frame's timestamp interpolated in the PLC's angle samples.
    Interpolated,
}

/// The whole register map.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct RegisterMap {
    /// Modbus unit identifier.
    pub unit: u8,
    /// How frames get their angles.
    pub pairing: Pairing,
    /// Holding registers.
    pub holding: Holding,
    /// Input registers.
    pub input: Input,
    /// Scaling.
    pub scale: Scale,
    /// Timing.
    pub timing: Timing,
    /// Push rod.
    pub rod: Rod,
}

impl Default for RegisterMap {
    fn default() -> Self {
        RegisterMap {
            unit: 1,
            pairing: Pairing::Latched,
            holding: Holding::default(),
            input: Input::default(),
            scale: Scale::default(),
            timing: Timing::default(),
            rod: Rod::default(),
        }
    }
}

impl MapError {
    /// 1-based line and column of the key or value the error is about, when known.
    pub fn position(&self) -> Option<(usize, usize)> {
        match *self {
            MapError::Syntax { line, column, .. } | MapError::Value { line, column, .. }
                if line > 0 =>
            {
                Some((line, column))
            }
            _ => None,
        }
    }
}

fn bad(key: &str, value: impl std::fmt::Display, expected: &str) -> MapError {
    MapError::Value {
        key: key.into(),
        value: value.to_string(),
        expected: format!("expected {expected}"),
        line: 0,
        column: 0,
    }
}

/// `v` within `bound`, or the error naming `key` and the bound.
fn within(key: &str, v: f64, bound: Bound) -> Result<(), MapError> {
    bound.check(v).map(|_| ()).map_err(|e| MapError::Value {
        key: key.into(),
        value: Num(v).to_string(),
        expected: e.to_string(),
        line: 0,
        column: 0,
    })
}

/// The bounds of the map's numbers: far beyond any real station's, short of values that would
/// stall the link for hours or overflow a time.
pub mod bounds {
    use gonio_core::bound::Bound;

    /// `timing.watchdog_ms`.
    pub const WATCHDOG_MS: Bound = Bound::new(10.0, 600_000.0, "ms");
    /// `timing.heartbeat_ms` (and at most half the watchdog).
    pub const HEARTBEAT_MS: Bound = Bound::new(1.0, 300_000.0, "ms");
    /// `timing.reply_timeout_ms` and `timing.frame_timeout_ms`.
    pub const TIMEOUT_MS: Bound = Bound::new(1.0, 600_000.0, "ms");
    /// `timing.poll_ms`.
    pub const POLL_MS: Bound = Bound::new(1.0, 10_000.0, "ms");
    /// `timing.safe_state_ms`: a minute, for the slowest retract.
    pub const SAFE_STATE_MS: Bound = Bound::new(1.0, 60_000.0, "ms");
    /// `timing.command_timeout_s`: an hour, for the slowest move.
    pub const COMMAND_TIMEOUT_S: Bound = Bound::new(0.0, 3600.0, "s").lo_excluded();
    /// `scale.*`: counts per unit on the wire.
    pub const COUNTS_PER_UNIT: Bound = Bound::new(0.0, 1e9, "counts per unit").lo_excluded();
    /// `rod.gap_centred_um` and `rod.travel_limit_um`: up to a metre.
    pub const TRAVEL_UM: Bound = Bound::new(0.0, 1e6, "µm").lo_excluded();
    /// `rod.margin_um`.
    pub const MARGIN_UM: Bound = Bound::new(0.0, 1e6, "µm");
    /// `rod.creep_fast_um_per_s` and `rod.creep_slow_um_per_s`.
    pub const CREEP_UM_PER_S: Bound = Bound::new(0.0, 1e6, "µm/s").lo_excluded();
    /// `rod.centre_column_px`: a column of any sensor.
    pub const COLUMN_PX: Bound = Bound::new(-1e5, 1e5, "px");
    /// `rod.contact_sigmas`.
    pub const CONTACT_SIGMAS: Bound = Bound::new(0.0, 1000.0, "σ").lo_excluded();
    /// `rod.contact_min_px`.
    pub const CONTACT_MIN_PX: Bound = Bound::new(0.0, 1e4, "px");
    /// `rod.baseline_frames`.
    pub const BASELINE_FRAMES: Bound = Bound::new(3.0, 10_000.0, "frames");
    /// `rod.contact_frames`.
    pub const CONTACT_FRAMES: Bound = Bound::new(1.0, 10_000.0, "frames");
}

/// 1-based line and column, and the text, of the value of a dotted key (`timing.poll_ms`) in a
/// TOML text, if the text sets it.
fn value_in(text: &str, key: &str) -> Option<(usize, usize, String)> {
    let doc = toml::de::DeTable::parse(text).ok()?;
    let mut table = doc.get_ref();
    let parts: Vec<&str> = key.split('.').collect();
    for (i, part) in parts.iter().enumerate() {
        let (_, v) = table.iter().find(|(k, _)| k.get_ref().as_ref() == *part)?;
        if i + 1 == parts.len() {
            let span = v.span();
            let (line, column) = gonio_core::text::line_col(text, span.start);
            let raw = text.get(span).unwrap_or_default().trim().to_string();
            return Some((line, column, raw));
        }
        match v.get_ref() {
            toml::de::DeValue::Table(t) => table = t,
            _ => return None,
        }
    }
    None
}

impl RegisterMap {
    /// Parses a map from TOML; keys not given keep their defaults.
    ///
    /// # Errors
    /// [`MapError::Syntax`] with the line and column; [`MapError::Value`] from
    /// [`RegisterMap::validate`], with the line and column of the value and the value as written.
    pub fn from_toml(text: &str) -> Result<Self, MapError> {
        let m: RegisterMap = toml::from_str(text).map_err(|e| {
            let (line, column) = e
                .span()
                .map(|s| {
                    let before = &text[..s.start.min(text.len())];
                    let line = before.matches('\n').count() + 1;
                    let column = before.len() - before.rfind('\n').map_or(0, |i| i + 1) + 1;
                    (line, column)
                })
                .unwrap_or((0, 0));
            MapError::Syntax {
                line,
                column,
                message: e.message().to_string(),
            }
        })?;
        m.validate().map_err(|e| match e {
            MapError::Value {
                key,
                value,
                expected,
                ..
            } => match value_in(text, &key) {
                Some((line, column, raw)) => MapError::Value {
                    key,
                    value: if raw.is_empty() { value } else { raw },
                    expected,
                    line,
                    column,
                },
                None => MapError::Value {
                    key,
                    value,
                    expected,
                    line: 0,
                    column: 0,
                },
            },
            other => other,
        })?;
        Ok(m)
    }

    /// Checks ranges and that no two register regions overlap.
    ///
    /// # Errors
    /// [`MapError::Value`] naming the key.
    pub fn validate(&self) -> Result<(), MapError> {
        let h = &self.holding;
        let mut hold: Vec<(&str, u32, u32)> = vec![
            ("holding.command", h.command as u32, 1),
            ("holding.sequence", h.sequence as u32, 1),
            ("holding.arg0", h.arg0 as u32, 2),
            ("holding.arg1", h.arg1 as u32, 2),
            ("holding.heartbeat", h.heartbeat as u32, 1),
        ];
        let i = &self.input;
        let mut inp: Vec<(&str, u32, u32)> = vec![
            ("input.status", i.status as u32, STATUS_BLOCK_REGS as u32),
            (
                "input.latch_ring",
                i.latch_ring as u32,
                i.latch_ring_len as u32 * LATCH_ENTRY_REGS as u32,
            ),
            (
                "input.sample_ring",
                i.sample_ring as u32,
                i.sample_ring_len as u32 * SAMPLE_ENTRY_REGS as u32,
            ),
        ];
        for set in [&mut hold, &mut inp] {
            for &(k, a, n) in set.iter() {
                if a + n > 65_536 {
                    return Err(bad(k, a, "a region that ends below register 65536"));
                }
            }
            set.sort_by_key(|r| r.1);
            for w in set.windows(2) {
                if w[0].1 + w[0].2 > w[1].1 {
                    return Err(bad(
                        w[1].0,
                        w[1].1,
                        &format!(
                            "no overlap with {} (registers {}–{})",
                            w[0].0,
                            w[0].1,
                            w[0].1 + w[0].2 - 1
                        ),
                    ));
                }
            }
        }
        if i.latch_ring_len < 16 {
            return Err(bad(
                "input.latch_ring_len",
                i.latch_ring_len,
                "at least 16 entries",
            ));
        }
        if i.sample_ring_len < 16 {
            return Err(bad(
                "input.sample_ring_len",
                i.sample_ring_len,
                "at least 16 entries",
            ));
        }
        use bounds::*;
        let s = &self.scale;
        let t = &self.timing;
        let r = &self.rod;
        for (k, v, b) in [
            ("scale.angle_per_deg", s.angle_per_deg, COUNTS_PER_UNIT),
            ("scale.speed_per_deg_s", s.speed_per_deg_s, COUNTS_PER_UNIT),
            ("scale.length_per_um", s.length_per_um, COUNTS_PER_UNIT),
            ("timing.watchdog_ms", t.watchdog_ms as f64, WATCHDOG_MS),
            ("timing.heartbeat_ms", t.heartbeat_ms as f64, HEARTBEAT_MS),
            (
                "timing.reply_timeout_ms",
                t.reply_timeout_ms as f64,
                TIMEOUT_MS,
            ),
            (
                "timing.command_timeout_s",
                t.command_timeout_s,
                COMMAND_TIMEOUT_S,
            ),
            (
                "timing.frame_timeout_ms",
                t.frame_timeout_ms as f64,
                TIMEOUT_MS,
            ),
            ("timing.poll_ms", t.poll_ms as f64, POLL_MS),
            (
                "timing.safe_state_ms",
                t.safe_state_ms as f64,
                SAFE_STATE_MS,
            ),
            ("rod.gap_centred_um", r.gap_centred_um, TRAVEL_UM),
            ("rod.centre_column_px", r.centre_column_px, COLUMN_PX),
            ("rod.margin_um", r.margin_um, MARGIN_UM),
            (
                "rod.creep_fast_um_per_s",
                r.creep_fast_um_per_s,
                CREEP_UM_PER_S,
            ),
            (
                "rod.creep_slow_um_per_s",
                r.creep_slow_um_per_s,
                CREEP_UM_PER_S,
            ),
            ("rod.travel_limit_um", r.travel_limit_um, TRAVEL_UM),
            (
                "rod.baseline_frames",
                r.baseline_frames as f64,
                BASELINE_FRAMES,
            ),
            ("rod.contact_sigmas", r.contact_sigmas, CONTACT_SIGMAS),
            ("rod.contact_min_px", r.contact_min_px, CONTACT_MIN_PX),
            (
                "rod.contact_frames",
                r.contact_frames as f64,
                CONTACT_FRAMES,
            ),
        ] {
            within(k, v, b)?;
        }
        if t.heartbeat_ms * 2 > t.watchdog_ms {
            return Err(bad(
                "timing.heartbeat_ms",
                t.heartbeat_ms,
                "at most half of timing.watchdog_ms",
            ));
        }
        Ok(())
    }

    /// Degrees to wire counts.
    pub fn angle_counts(&self, deg: f64) -> i32 {
        (deg * self.scale.angle_per_deg)
            .round()
            .clamp(i32::MIN as f64, i32::MAX as f64) as i32
    }

    /// Wire counts to degrees.
    pub fn angle_deg(&self, counts: i32) -> f64 {
        counts as f64 / self.scale.angle_per_deg
    }

    /// µm to wire counts.
    pub fn length_counts(&self, um: f64) -> i32 {
        (um * self.scale.length_per_um)
            .round()
            .clamp(i32::MIN as f64, i32::MAX as f64) as i32
    }

    /// Wire counts to µm.
    pub fn length_um(&self, counts: i32) -> f64 {
        counts as f64 / self.scale.length_per_um
    }

    /// °/s to wire counts.
    pub fn speed_counts(&self, deg_per_s: f64) -> i32 {
        (deg_per_s * self.scale.speed_per_deg_s)
            .round()
            .clamp(i32::MIN as f64, i32::MAX as f64) as i32
    }

    /// Wire counts to °/s.
    pub fn speed_deg_per_s(&self, counts: i32) -> f64 {
        counts as f64 / self.scale.speed_per_deg_s
    }
}

/// Splits an i32 into two registers, high word first.
pub fn i32_words(v: i32) -> [u16; 2] {
    let u = v as u32;
    [(u >> 16) as u16, u as u16]
}

/// Joins two registers (high word first) into an i32.
pub fn words_i32(w: &[u16]) -> i32 {
    ((w[0] as u32) << 16 | w[1] as u32) as i32
}

/// Joins two registers (high word first) into a u32.
pub fn words_u32(w: &[u16]) -> u32 {
    (w[0] as u32) << 16 | w[1] as u32
}

/// Splits a u32 into two registers, high word first.
pub fn u32_words(v: u32) -> [u16; 2] {
    [(v >> 16) as u16, v as u16]
}

/// Joins four registers (most significant first) into a u64.
pub fn words_u64(w: &[u16]) -> u64 {
    w[..4].iter().fold(0u64, |a, &x| a << 16 | x as u64)
}

/// Splits a u64 into four registers, most significant first.
pub fn u64_words(v: u64) -> [u16; 4] {
    [
        (v >> 48) as u16,
        (v >> 32) as u16,
        (v >> 16) as u16,
        v as u16,
    ]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn words_round_trip() {
        for v in [0, 1, -1, i32::MIN, i32::MAX, 3_600_000, -123_456_789] {
            assert_eq!(words_i32(&i32_words(v)), v);
        }
        for v in [0u64, 1, u64::MAX, 0x0123_4567_89ab_cdef] {
            assert_eq!(words_u64(&u64_words(v)), v);
        }
    }

    #[test]
    fn example_map_is_the_default() {
        let text = include_str!("../../../examples/plc/modbus-map.toml");
        assert_eq!(
            RegisterMap::from_toml(text).unwrap(),
            RegisterMap::default()
        );
    }

    #[test]
    fn every_number_is_bounded_and_located_where_it_is_written() {
        let e = RegisterMap::from_toml("unit = 1\n\n[timing]\ncommand_timeout_s = 1e300\n")
            .unwrap_err();
        assert_eq!(
            e.to_string(),
            "timing.command_timeout_s = 1e300: at most 3600 s"
        );
        assert_eq!(e.position(), Some((4, 21)));
        for (text, key, why) in [
            (
                "[timing]\ncommand_timeout_s = 1e20\n",
                "command_timeout_s = 1e20",
                "at most 3600 s",
            ),
            (
                "[timing]\ncommand_timeout_s = 0.0\n",
                "command_timeout_s = 0.0",
                "above 0 s",
            ),
            (
                "[timing]\nreply_timeout_ms = 9223372036854775807\n",
                "reply_timeout_ms",
                "at most 600000 ms",
            ),
            ("[timing]\npoll_ms = 0\n", "poll_ms = 0", "at least 1 ms"),
            (
                "[timing]\nsafe_state_ms = 3600000\n",
                "safe_state_ms = 3600000",
                "at most 60000 ms",
            ),
            (
                "[timing]\nsafe_state_ms = 0\n",
                "safe_state_ms = 0",
                "at least 1 ms",
            ),
            (
                "[timing]\nwatchdog_ms = 100000000\n",
                "watchdog_ms",
                "at most 600000 ms",
            ),
            (
                "[scale]\nangle_per_deg = 1e300\n",
                "angle_per_deg = 1e300",
                "at most 1000000000",
            ),
            (
                "[rod]\ncentre_column_px = -1e300\n",
                "centre_column_px = -1e300",
                "at least -100000 px",
            ),
            (
                "[rod]\ncontact_frames = 100000000\n",
                "contact_frames",
                "at most 10000 frames",
            ),
        ] {
            let e = RegisterMap::from_toml(text).unwrap_err();
            let msg = e.to_string();
            assert!(msg.contains(key) && msg.contains(why), "{text}: {msg}");
            assert_eq!(e.position().map(|p| p.0), Some(2), "{text}: {msg}");
        }
        // The largest values allowed are accepted.
        let m = RegisterMap::from_toml("[timing]\ncommand_timeout_s = 3600\n").unwrap();
        assert_eq!(m.timing.command_timeout_s, 3600.0);
    }

    #[test]
    fn overlap_and_unknown_keys_are_named() {
        let e = RegisterMap::from_toml("[holding]\narg1 = 3\n").unwrap_err();
        assert!(e.to_string().contains("holding.arg1"), "{e}");
        let e = RegisterMap::from_toml("[input]\nlatch = 3\n").unwrap_err();
        assert!(matches!(e, MapError::Syntax { line: 2, .. }), "{e:?}");
        let e = RegisterMap::from_toml("[input]\nlatch_ring = 10\n").unwrap_err();
        assert!(e.to_string().contains("input.latch_ring"), "{e}");
    }
}
