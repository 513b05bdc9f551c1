//! The record of a mounted part for a replay (`gonio mount --record DIR`, `gonio replay DIR`):
//! one directory per part, `DIR/part-0003/`, holding
//!
//! - `part.json` (`gonio.replay/1`): the part's serial and place in its batch, the station's
//!   name and whether it is the digital twin, the recipe, the strategy, the optics, the frames'
//!   size, and the station's record of the part (turns, pushes, verdict);
//! - per measuring turn `turn-N.raw`: the turn's frames as the camera gave them, 8-bit grey,
//!   width × height bytes each, back to back (the raw stream format of `gonio detect --raw`);
//! - per turn `turn-N.json`: when each frame was taken (on the station's clock) and what the
//!   detector found live, each frame's id and time as the camera gave them, the servo's angle
//!   log of the turn (a real station's: the angles its PLC latched), the turn's start, kind and
//!   focus.
//!
//! Numbers are written so that they read back bit for bit (JSON with round-trip floats).

use crate::formats::json_error;
use crate::input::Inputs;
use anyhow::{Context, Result, anyhow, bail};
use gonio_station::hal::{CameraFrame, DeviceError, DeviceErrorKind};
use gonio_station::replay::{CameraStamp, RecordedTurn};
use gonio_station::{PartRecord, Recipe, Strategy};
use gonio_vision::{FrameHeader, FrameSource, FrameStamp, Optics, RawFrames, RawFramesError};
use serde::{Deserialize, Serialize};
use std::io::Read;
use std::path::{Path, PathBuf};

/// The format name in `part.json`.
pub const FORMAT: &str = "gonio.replay/1";

/// One turn's files.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TurnFiles {
    /// The frames (raw), relative to the part's directory.
    pub raw: String,
    /// The stamps, live results and angle log ([`RecordedTurn`]).
    pub data: String,
    /// Frames in the raw file.
    pub frames: usize,
}

/// `part.json`.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PartFile {
    /// [`FORMAT`].
    pub format: String,
    /// The part's serial.
    pub serial: String,
    /// 0-based position of the part in its batch.
    pub batch_index: usize,
    /// The seed of a simulated station.
    pub seed: Option<u64>,
    /// The station's name (`None`: the record does not say).
    #[serde(default)]
    pub station: Option<String>,
    /// Whether the part is the digital twin's (`None`: the record does not say).
    #[serde(default)]
    pub simulated: Option<bool>,
    /// The software that recorded it.
    pub software_version: String,
    /// The recipe it was mounted with.
    pub recipe: Recipe,
    /// The push strategy (its fit method).
    pub strategy: Strategy,
    /// The camera's optics (the detector's parameters).
    pub optics: Optics,
    /// Frame width, px.
    pub width: usize,
    /// Frame height, px.
    pub height: usize,
    /// Every measuring turn, in order.
    pub turns: Vec<TurnFiles>,
    /// The station's record of the part.
    pub record: PartRecord,
}

/// The directory of part `index` (0-based) in a record directory.
pub fn part_dir(dir: &Path, index: usize) -> PathBuf {
    dir.join(format!("part-{:04}", index + 1))
}

/// The part directories under `dir` (or `dir` itself when it holds a `part.json`), in order.
///
/// # Errors
/// `dir` cannot be read or holds no recorded part.
pub fn part_dirs(dir: &Path) -> Result<Vec<PathBuf>> {
    if dir.join("part.json").is_file() {
        return Ok(vec![dir.to_path_buf()]);
    }
    let mut v: Vec<PathBuf> = std::fs::read_dir(dir)
        .with_context(|| format!("{}: cannot read the record directory", dir.display()))?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.join("part.json").is_file())
        .collect();
    v.sort();
    if v.is_empty() {
        bail!(
            "{}: no recorded part (expected part-NNNN/part.json, written by gonio mount --record)",
            dir.display()
        );
    }
    Ok(v)
}

/// Reads `part.json` of a part directory.
///
/// # Errors
/// A one-line error naming the file, line and column.
pub fn read_part(inputs: &Inputs, dir: &Path) -> Result<PartFile> {
    let p = dir.join("part.json");
    let text = inputs.read_text(&p)?;
    let f: PartFile = serde_json::from_str(&text)
        .map_err(|e| json_error(&p.display().to_string(), &e, "a gonio.replay/1 part record"))?;
    if f.format != FORMAT {
        bail!(
            "{}: format {:?}: expected {FORMAT:?}",
            p.display(),
            f.format
        );
    }
    Ok(f)
}

/// The file `name` of a part record in `dir`: a plain relative path that stays inside `dir`
/// (no absolute path, no `..`, no symbolic link leading out), so a record never makes replay
/// read a file elsewhere.
///
/// # Errors
/// `name` leaves the record's directory, naming the field's value.
pub fn inside(dir: &Path, name: &str) -> Result<PathBuf> {
    use std::path::Component;
    let rel = Path::new(name);
    if name.is_empty()
        || !rel
            .components()
            .all(|c| matches!(c, Component::Normal(_) | Component::CurDir))
    {
        bail!(
            "{}: file {name:?}: expected a file name inside the record's directory (no absolute path, no ..)",
            dir.join("part.json").display()
        );
    }
    let p = dir.join(rel);
    if let (Ok(base), Ok(real)) = (std::fs::canonicalize(dir), std::fs::canonicalize(&p))
        && !real.starts_with(&base)
    {
        bail!(
            "{}: file {name:?} leads outside the record's directory (to {}): refused",
            dir.join("part.json").display(),
            real.display()
        );
    }
    Ok(p)
}

/// Reads a turn's data file.
///
/// # Errors
/// A one-line error naming the file, line and column.
pub fn read_turn(inputs: &Inputs, dir: &Path, t: &TurnFiles) -> Result<RecordedTurn> {
    let p = inside(dir, &t.data)?;
    let text = inputs.read_text(&p)?;
    let r: RecordedTurn = serde_json::from_str(&text).map_err(|e| {
        json_error(
            &p.display().to_string(),
            &e,
            "a recorded turn: t_start_s, kind, focus_um, frames, log",
        )
    })?;
    if r.frames.len() != t.frames {
        bail!(
            "{}: {} frames, part.json says {}",
            p.display(),
            r.frames.len(),
            t.frames
        );
    }
    Ok(r)
}

/// Why a recorded frame cannot be read.
#[derive(Debug)]
pub struct RecordedFramesError(String);

impl std::fmt::Display for RecordedFramesError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for RecordedFramesError {}

impl DeviceError for RecordedFramesError {
    fn kind(&self) -> DeviceErrorKind {
        DeviceErrorKind::Other
    }
}

/// A turn's raw frames, each stamped with the time it was taken (from the turn's data): what
/// the camera's detector runs on again in a replay. Frames are numbered as the camera numbered
/// them when the record has its frame ids (counted from the turn's first), so that the tracked
/// detector sees the same gaps as it did live; else 0, 1, 2, …
pub struct RecordedFrames<R> {
    raw: RawFrames<R>,
    path: PathBuf,
    stamps: Vec<(f64, f64)>,
    ids: Vec<u64>,
}

impl<R: Read> RecordedFrames<R> {
    /// Frames of `width` × `height` from `reader` (the file `path`), stamped by `frames`,
    /// numbered by `camera`'s frame ids when it has one per frame.
    pub fn new(
        reader: R,
        path: &Path,
        width: usize,
        height: usize,
        frames: &[CameraFrame],
        camera: &[CameraStamp],
    ) -> Self {
        let ids = if camera.len() == frames.len()
            && camera.windows(2).all(|w| w[0].frame_id < w[1].frame_id)
        {
            let first = camera.first().map_or(0, |c| c.frame_id);
            camera.iter().map(|c| c.frame_id - first).collect()
        } else {
            Vec::new()
        };
        RecordedFrames {
            raw: RawFrames::new(reader, width, height),
            path: path.to_path_buf(),
            stamps: frames.iter().map(|f| (f.start_s, f.exposure_s)).collect(),
            ids,
        }
    }
}

impl<R: Read> FrameSource for RecordedFrames<R> {
    type Error = RecordedFramesError;
    fn next_frame(
        &mut self,
        pixels: &mut Vec<u8>,
    ) -> Result<Option<FrameHeader>, RecordedFramesError> {
        let err = |e: RawFramesError| RecordedFramesError(format!("{}: {e}", self.path.display()));
        let Some(h) = self.raw.next_frame(pixels).map_err(err)? else {
            return Ok(None);
        };
        let i = h.stamp.index as usize;
        let &(start_s, exposure_s) = self.stamps.get(i).ok_or_else(|| {
            RecordedFramesError(format!(
                "{}: frame {} has no stamp ({} recorded)",
                self.path.display(),
                i,
                self.stamps.len()
            ))
        })?;
        Ok(Some(FrameHeader {
            stamp: FrameStamp {
                index: self.ids.get(i).copied().unwrap_or(h.stamp.index),
                start_s: Some(start_s),
                exposure_s: Some(exposure_s),
                ..h.stamp
            },
            ..h
        }))
    }
}

/// Opens a turn's raw frames, checking their size against the recorded frame count.
///
/// # Errors
/// The file is missing or not `frames` × width × height bytes.
pub fn open_raw(
    dir: &Path,
    part: &PartFile,
    t: &TurnFiles,
    rec: &RecordedTurn,
) -> Result<RecordedFrames<std::io::BufReader<std::fs::File>>> {
    let p = inside(dir, &t.raw)?;
    let f = std::fs::File::open(&p).with_context(|| format!("{}: cannot open", p.display()))?;
    let len = f.metadata().map(|m| m.len()).unwrap_or(0);
    let want = (t.frames * part.width * part.height) as u64;
    if len != want {
        return Err(anyhow!(
            "{}: {len} bytes: expected {} frames of {}x{} ({want} bytes)",
            p.display(),
            t.frames,
            part.width,
            part.height
        ));
    }
    Ok(RecordedFrames::new(
        std::io::BufReader::with_capacity(1 << 20, f),
        &p,
        part.width,
        part.height,
        &rec.frames,
        &rec.camera,
    ))
}
