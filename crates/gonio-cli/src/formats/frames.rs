//! Camera frames and their settings on disk: image files (PNG, TIFF; 8-bit grey) as a
//! [`FrameSource`], the optics TOML and the scene TOML.

use crate::io;
use anyhow::{Context, Result, anyhow, bail};
use gonio_sim::frames::GratingScene;
use gonio_vision::{FrameHeader, FrameSource, FrameStamp, Optics};
use std::path::{Path, PathBuf};

/// Loads an optics TOML file (or the default: the seed's station).
pub fn load_optics(path: Option<&Path>) -> Result<Optics> {
    let Some(p) = path else {
        return Ok(Optics::default());
    };
    let o: Optics = io::read_toml(p)?;
    o.params().with_context(|| p.display().to_string())?;
    Ok(o)
}

/// Loads a scene TOML file (every field of `GratingScene`, all optional).
pub fn load_scene(path: &Path) -> Result<GratingScene> {
    io::read_toml(path)
}

/// Lists the frame files: files as given, directories expanded to their PNG/TIFF files in name
/// order.
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

/// Reads one 8-bit grey image into `pixels`; 16-bit and float images are refused.
pub fn read_grey8(path: &Path, pixels: &mut Vec<u8>) -> Result<(usize, usize)> {
    use image::DynamicImage as D;
    let img = image::ImageReader::open(path)
        .with_context(|| format!("cannot open {}", path.display()))?
        .with_guessed_format()
        .with_context(|| format!("cannot read {}", path.display()))?
        .decode()
        .map_err(|e| anyhow!("{}: not a readable PNG/TIFF image: {e}", path.display()))?;
    let (w, h) = (img.width() as usize, img.height() as usize);
    pixels.clear();
    match img {
        D::ImageLuma8(g) => pixels.extend_from_slice(g.as_raw()),
        D::ImageLumaA8(_) | D::ImageRgb8(_) | D::ImageRgba8(_) => {
            pixels.extend_from_slice(img.to_luma8().as_raw())
        }
        other => bail!(
            "{}: {:?} image: expected 8-bit grey (16-bit and float frames are not accepted; convert \
             with e.g. `convert in.png -depth 8 out.png`)",
            path.display(),
            other.color()
        ),
    }
    Ok((w, h))
}

/// Image files, in order, as a frame source (stamps carry the index; angles come from the
/// caller's angle log).
#[derive(Debug)]
pub struct FileFrames {
    files: Vec<PathBuf>,
    next: usize,
}

impl FileFrames {
    /// The files, read in this order.
    pub fn new(files: Vec<PathBuf>) -> Self {
        FileFrames { files, next: 0 }
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
        write!(f, "{}", io::one_line(&self.0))
    }
}

impl std::error::Error for FileFrameError {}

impl FrameSource for FileFrames {
    type Error = FileFrameError;
    fn next_frame(&mut self, pixels: &mut Vec<u8>) -> Result<Option<FrameHeader>, FileFrameError> {
        let Some(p) = self.files.get(self.next) else {
            return Ok(None);
        };
        let (width, height) = read_grey8(p, pixels).map_err(FileFrameError)?;
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
