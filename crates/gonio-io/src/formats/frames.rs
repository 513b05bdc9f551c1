//! Camera frames and their settings on disk: the optics TOML and the scene TOML, image files
//! (PNG, TIFF; 8-bit grey) read with their size checked against the optics before decoding (also
//! as a [`FrameSource`]), raw frame sizes, and the processing window cut out of a sensor-sized
//! frame.

use crate::input::{self, Inputs};
use anyhow::{Context, Result, anyhow, bail};
use gonio_sim::frames::GratingScene;
use gonio_vision::{FrameHeader, FrameSource, FrameStamp, Optics, VisionError};
use std::path::{Path, PathBuf};

/// Loads an optics TOML file (or the default: the station of Yu et al., 2024); a value out of
/// range is named with its key and line.
///
/// # Errors
/// As [`parse_optics`], and the file cannot be read.
pub fn load_optics(inputs: &Inputs, path: Option<&Path>) -> Result<Optics> {
    let Some(p) = path else {
        return Ok(Optics::default());
    };
    inputs.load(p, parse_optics)
}

/// Parses optics text; `name` names it in errors.
///
/// # Errors
/// Syntax, unknown keys, wrong types; a value out of range (`NAME:LINE:COL: ring_width_um = …:
/// expected …`).
pub fn parse_optics(name: &str, text: &str) -> Result<Optics> {
    let o: Optics = super::parse_toml(name, text)?;
    o.params().map_err(|e| match &e {
        VisionError::Optics {
            name: key,
            found,
            expected,
        } => match super::key_position(text, key) {
            Some((l, c)) => anyhow!("{name}:{l}:{c}: {key} = {found}: expected {expected}"),
            None => anyhow!(
                "{name}: {key} = {found} (the default: the file does not set it): expected {expected}"
            ),
        },
        _ => anyhow!("{name}: {e}"),
    })?;
    Ok(o)
}

/// Loads a scene TOML file (every field of `GratingScene`, all optional), range-checked with the
/// key named.
///
/// # Errors
/// As [`parse_scene`], and the file cannot be read.
pub fn load_scene(inputs: &Inputs, path: &Path) -> Result<GratingScene> {
    inputs.load(path, parse_scene)
}

/// Parses scene text; `name` names it in errors. The values are checked as the renderer checks
/// them (with the default optics), so that a bad value is refused before any frame is drawn.
///
/// # Errors
/// Syntax, unknown keys, wrong types, values out of range (`NAME:LINE:COL: key = …`).
pub fn parse_scene(name: &str, text: &str) -> Result<GratingScene> {
    let scene: GratingScene = super::parse_toml(name, text)?;
    if let Err(e) = gonio_sim::frames::GratingRenderer::new(&Optics::default(), scene.clone()) {
        return Err(match &e {
            gonio_sim::SimError::Parameter { name: key, .. } => {
                match super::key_position(text, key) {
                    Some((l, c)) => anyhow!("{name}:{l}:{c}: {e}"),
                    None => anyhow!("{name}: {e}"),
                }
            }
            _ => anyhow!("{name}: {e}"),
        });
    }
    Ok(scene)
}

/// Lists the frame files: files as given, directories expanded to their PNG/TIFF files in name
/// order.
///
/// # Errors
/// A directory cannot be read or has no image.
pub fn list_frames(inputs: &[PathBuf]) -> Result<Vec<PathBuf>> {
    let mut out = Vec::new();
    for p in inputs {
        if p.is_dir() {
            let mut v: Vec<PathBuf> = std::fs::read_dir(p)
                .with_context(|| format!("cannot read directory {}", p.display()))?
                .filter_map(|e| e.ok().map(|e| e.path()))
                .filter(|f| {
                    f.extension().and_then(|e| e.to_str()).is_some_and(|e| {
                        matches!(e.to_ascii_lowercase().as_str(), "png" | "tif" | "tiff")
                    })
                })
                .collect();
            v.sort();
            if v.is_empty() {
                bail!("{}: no PNG or TIFF files in this directory", p.display());
            }
            out.extend(v);
        } else {
            out.push(p.clone());
        }
    }
    Ok(out)
}

/// Decodes one 8-bit grey image (PNG or TIFF) from bytes; `name` names it in errors. The size in
/// the header is checked against `max_w` × `max_h` before any pixel is decoded; 16-bit and float
/// images are refused.
///
/// # Errors
/// Not a readable image, too large, or not 8-bit.
pub fn decode_grey8(
    name: &str,
    bytes: &[u8],
    max_w: usize,
    max_h: usize,
) -> Result<(usize, usize, Vec<u8>)> {
    use image::DynamicImage as D;
    if tiff_has_pages_after_the_first(bytes) {
        bail!(
            "{name}: a TIFF of several pages: gonio reads one frame per file and would drop the others; split it into one file a page (e.g. `tiffsplit {name} page-`)"
        );
    }
    let reader = || -> Result<image::ImageReader<std::io::Cursor<&[u8]>>> {
        let mut r = image::ImageReader::new(std::io::Cursor::new(bytes))
            .with_guessed_format()
            .with_context(|| format!("cannot read {name}"))?;
        let mut limits = image::Limits::default();
        limits.max_image_width = Some(max_w as u32);
        limits.max_image_height = Some(max_h as u32);
        limits.max_alloc = Some((4 * max_w * max_h) as u64 + (1 << 20));
        r.limits(limits);
        Ok(r)
    };
    let (w, h) = reader()?
        .into_dimensions()
        .map_err(|e| anyhow!("{name}: not a readable PNG/TIFF image: {e}"))?;
    if w as usize > max_w || h as usize > max_h {
        bail!("{name}: frame is {w}×{h}: larger than the sensor {max_w}×{max_h} (see --optics)");
    }
    let img = reader()?
        .decode()
        .map_err(|e| anyhow!("{name}: not a readable PNG/TIFF image: {e}"))?;
    let (w, h) = (img.width() as usize, img.height() as usize);
    let data = match img {
        D::ImageLuma8(g) => g.into_raw(),
        D::ImageLumaA8(_) | D::ImageRgb8(_) | D::ImageRgba8(_) => img.to_luma8().into_raw(),
        other => bail!(
            "{name}: {:?} image: expected 8-bit grey (16-bit and float frames are not accepted; convert \
             with e.g. `convert in.png -depth 8 out.png`)",
            other.color()
        ),
    };
    Ok((w, h, data))
}

/// Whether `bytes` is a TIFF (classic or BigTIFF, either byte order) whose first image file
/// directory links to another (a second page). Not a TIFF, or a truncated one: `false` (the
/// decoder then says what is wrong).
pub fn tiff_has_pages_after_the_first(bytes: &[u8]) -> bool {
    let le = match bytes.get(..2) {
        Some(b"II") => true,
        Some(b"MM") => false,
        _ => return false,
    };
    let uint = |at: usize, n: usize| -> Option<u64> {
        let b = bytes.get(at..at.checked_add(n)?)?;
        Some(if le {
            b.iter().rev().fold(0u64, |a, &x| a << 8 | u64::from(x))
        } else {
            b.iter().fold(0u64, |a, &x| a << 8 | u64::from(x))
        })
    };
    let next = match uint(2, 2) {
        // Classic TIFF: 4-byte offsets, 2-byte entry count, 12-byte entries.
        Some(42) => (|| {
            let ifd = usize::try_from(uint(4, 4)?).ok()?;
            let n = usize::try_from(uint(ifd, 2)?).ok()?;
            uint(ifd.checked_add(2)?.checked_add(n.checked_mul(12)?)?, 4)
        })(),
        // BigTIFF: 8-byte offsets, 8-byte entry count, 20-byte entries.
        Some(43) => (|| {
            let ifd = usize::try_from(uint(8, 8)?).ok()?;
            let n = usize::try_from(uint(ifd, 8)?).ok()?;
            uint(ifd.checked_add(8)?.checked_add(n.checked_mul(20)?)?, 8)
        })(),
        _ => None,
    };
    next.is_some_and(|o| o != 0)
}

/// Reads one frame file (at most the optics' sensor size). It records nothing: the command that
/// lists the frames records them ([`input::Inputs::record`]).
///
/// # Errors
/// As [`decode_grey8`], and the file cannot be read.
pub fn read_grey8(path: &Path, optics: &Optics) -> Result<(usize, usize, Vec<u8>)> {
    let (sw, sh) = (
        optics.sensor_width_px as usize,
        optics.sensor_height_px as usize,
    );
    // A compressed frame is smaller than its pixels, plus headers.
    let bytes = input::read_file(path, 2 * sw * sh + (16 << 20))?;
    decode_grey8(&path.display().to_string(), &bytes, sw, sh)
}

/// Cuts the processing window out of a frame of window or sensor size.
///
/// # Errors
/// The frame is neither.
pub fn to_window(o: &Optics, name: &str, w: usize, h: usize, data: Vec<u8>) -> Result<Vec<u8>> {
    let (ww, wh) = (o.window_width_px as usize, o.window_height_px as usize);
    let (sw, sh) = (o.sensor_width_px as usize, o.sensor_height_px as usize);
    if data.len() != w * h {
        bail!("{name}: {} bytes for a {w}×{h} frame", data.len());
    }
    if (w, h) == (ww, wh) {
        return Ok(data);
    }
    if (w, h) == (sw, sh) {
        let (x0, y0) = ((sw - ww) / 2, (sh - wh) / 2);
        let mut out = Vec::with_capacity(ww * wh);
        for y in y0..y0 + wh {
            out.extend_from_slice(&data[y * sw + x0..y * sw + x0 + ww]);
        }
        return Ok(out);
    }
    bail!(
        "{name}: frame is {w}×{h}: expected the window {ww}×{wh} or the sensor {sw}×{sh} (see --optics)"
    )
}

/// Parses a raw frame size `WIDTHxHEIGHT` and checks it is the optics' window or sensor size.
///
/// # Errors
/// Not a size, or not one of those two.
pub fn parse_raw_size(s: &str, o: &Optics) -> Result<(usize, usize)> {
    let err = || {
        anyhow!(
            "--raw {:?}: expected WIDTHxHEIGHT, e.g. 1440x540",
            gonio_core::text::short(s)
        )
    };
    let (a, b) = s.split_once(['x', 'X', '×']).ok_or_else(err)?;
    let w: usize = a.trim().parse().map_err(|_| err())?;
    let h: usize = b.trim().parse().map_err(|_| err())?;
    let (ww, wh) = (o.window_width_px as usize, o.window_height_px as usize);
    let (sw, sh) = (o.sensor_width_px as usize, o.sensor_height_px as usize);
    if (w, h) != (ww, wh) && (w, h) != (sw, sh) {
        bail!(
            "--raw {w}x{h}: expected the window {ww}x{wh} or the sensor {sw}x{sh} (see --optics)"
        );
    }
    Ok((w, h))
}

/// Image files, in order, as a frame source (stamps carry the index; angles come from the
/// caller's angle log); each file is refused before decoding when larger than the sensor.
#[derive(Debug)]
pub struct FileFrames {
    files: Vec<PathBuf>,
    next: usize,
    optics: Optics,
}

impl FileFrames {
    /// The files, read in this order, for these optics.
    pub fn new(files: Vec<PathBuf>, optics: &Optics) -> Self {
        FileFrames {
            files,
            next: 0,
            optics: optics.clone(),
        }
    }

    /// The file of frame `index`.
    pub fn path(&self, index: u64) -> Option<&Path> {
        self.files.get(index as usize).map(|p| p.as_path())
    }
}

/// A frame file that could not be read (the message names the file).
#[derive(Debug)]
pub struct FileFrameError(pub anyhow::Error);

impl std::fmt::Display for FileFrameError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}", input::one_line(&self.0))
    }
}

impl std::error::Error for FileFrameError {}

impl FrameSource for FileFrames {
    type Error = FileFrameError;
    fn next_frame(&mut self, pixels: &mut Vec<u8>) -> Result<Option<FrameHeader>, FileFrameError> {
        let Some(p) = self.files.get(self.next) else {
            return Ok(None);
        };
        let (width, height, data) = read_grey8(p, &self.optics).map_err(FileFrameError)?;
        pixels.clear();
        pixels.extend_from_slice(&data);
        let stamp = FrameStamp {
            index: self.next as u64,
            ..FrameStamp::default()
        };
        self.next += 1;
        Ok(Some(FrameHeader {
            width,
            height,
            stamp,
        }))
    }
}
