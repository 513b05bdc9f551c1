//! Angle logs (`frame,theta_deg[,time_s]`) for `gonio detect --angles`, and the angle of a
//! frame however it is known ([`FrameAngles`]: a log, a constant speed, or not at all).

use super::csv::CsvTable;
use anyhow::{Result, bail};
use std::collections::HashMap;

/// Largest frame index in an angle log.
pub const MAX_FRAME_INDEX: i64 = 100_000_000;

/// θ (and time) of every frame of an angle log.
#[derive(Debug)]
pub struct AngleLog {
    /// The file's name.
    pub name: String,
    by_frame: HashMap<usize, (f64, Option<f64>)>,
}

impl AngleLog {
    /// θ (degrees) and time (s) of frame `k`.
    pub fn at(&self, k: usize) -> Option<(f64, Option<f64>)> {
        self.by_frame.get(&k).copied()
    }

    /// The number of frames with an angle.
    pub fn len(&self) -> usize {
        self.by_frame.len()
    }

    /// Whether the log has no frame.
    pub fn is_empty(&self) -> bool {
        self.by_frame.is_empty()
    }

    /// The first frame of `0..n` without an angle.
    pub fn first_missing(&self, n: usize) -> Option<usize> {
        (0..n).find(|k| !self.by_frame.contains_key(k))
    }
}

/// The table angle and time of each frame: from an angle log, from a constant speed, or unknown.
#[derive(Debug)]
pub enum FrameAngles {
    /// Not known: `theta_deg` and `time_s` are null.
    None,
    /// From an angle log (`--angles`).
    Table(AngleLog),
    /// A constant speed from a start angle at a frame rate.
    Speed {
        /// The angle of frame 0, degrees.
        start_deg: f64,
        /// The table's speed, degrees per second.
        speed_deg_s: f64,
        /// Frames per second.
        fps: f64,
    },
}

impl FrameAngles {
    /// Frame `k`'s angle (degrees) and time (s), each `None` when not known.
    ///
    /// # Errors
    /// An angle log that has no row for frame `k` (`NAME: no angle for frame K: …`).
    pub fn at(&self, k: usize) -> Result<(Option<f64>, Option<f64>)> {
        match self {
            FrameAngles::None => Ok((None, None)),
            FrameAngles::Speed {
                start_deg,
                speed_deg_s,
                fps,
            } => {
                let t = k as f64 / fps;
                Ok((Some(start_deg + speed_deg_s * t), Some(t)))
            }
            FrameAngles::Table(log) => match log.at(k) {
                Some((th, t)) => Ok((Some(th), t)),
                None => bail!(
                    "{}: no angle for frame {k}: the angle file covers {} frames",
                    log.name,
                    log.len()
                ),
            },
        }
    }
}

/// Reads an angle log from a table; each frame at most once, indices 0 to
/// [`MAX_FRAME_INDEX`] (memory grows with the rows, not with the indices).
///
/// # Errors
/// Located: a missing column, a bad number, a frame index out of range or repeated.
pub fn from_table(t: &CsvTable) -> Result<AngleLog> {
    let expected = "frame,theta_deg[,time_s]";
    let fc = t.require("frame", expected)?;
    let tc = t.require("theta_deg", expected)?;
    let sc = t.column("time_s");
    let mut by_frame = HashMap::with_capacity(t.rows.len());
    for (line, f) in &t.rows {
        let k = t.int_at(*line, f, fc)?;
        if !(0..=MAX_FRAME_INDEX).contains(&k) {
            return Err(t.error_at(
                *line,
                fc,
                format!("expected a frame index from 0 to {MAX_FRAME_INDEX}, found {k}"),
            ));
        }
        let th = t.f64_at(*line, f, tc)?;
        let ts = sc.map(|c| t.f64_at(*line, f, c)).transpose()?;
        if by_frame.insert(k as usize, (th, ts)).is_some() {
            return Err(t.error_at(*line, fc, format!("frame {k} appears twice")));
        }
    }
    if by_frame.is_empty() {
        bail!("{}:{}: no frames after the header", t.name, t.header_line);
    }
    Ok(AngleLog {
        name: t.name.clone(),
        by_frame,
    })
}

/// Parses angle-log text; `name` names it in errors.
///
/// # Errors
/// As [`from_table`].
pub fn parse(name: &str, text: &str) -> Result<AngleLog> {
    from_table(&CsvTable::parse(name, text)?)
}
