//! The detector's stage images as files (`gonio detect --dump-stages DIR`): each stage of the
//! last frame as a 8- or 16-bit grey PNG (names `00_input.png` … `12_labels.png`), and a JSON
//! document ([`JSON_NAME`]) with the detector's parameters, the components, the result and a
//! legend of the files. Nothing is written here: the caller puts the files where it wants.
//!
//! Errors: the detector recorded no stage images ([`gonio_vision::Detector`] made without
//! stage recording), an image that cannot be encoded.

use anyhow::{Result, anyhow};
use gonio_vision::reference::{Image, label};
use gonio_vision::{Detector, FrameResult};
use serde::Serialize;

/// The JSON document's file name.
pub const JSON_NAME: &str = "13_components_and_result.json";

/// One stage image.
#[derive(Debug, Clone)]
pub struct StageImage {
    /// File name, e.g. `01_tophat.png`.
    pub name: &'static str,
    /// The PNG's bytes.
    pub png: Vec<u8>,
}

/// The stage images and their document.
#[derive(Debug, Clone)]
pub struct StageDump {
    /// The images, in stage order.
    pub images: Vec<StageImage>,
    /// Parameters, components, result and the files' legend ([`JSON_NAME`]).
    pub json: serde_json::Value,
}

/// One stage image (8- or 16-bit grey) as a PNG file of the dump.
fn save_png<P: image::Primitive>(
    out: &mut Vec<StageImage>,
    name: &'static str,
    w: usize,
    h: usize,
    data: Vec<P>,
) -> Result<()>
where
    [P]: image::EncodableLayout,
    image::Luma<P>: image::Pixel<Subpixel = P> + image::PixelWithColorType,
{
    let img = image::ImageBuffer::<image::Luma<P>, Vec<P>>::from_raw(w as u32, h as u32, data)
        .ok_or_else(|| anyhow!("{name}: image size"))?;
    let mut bytes = Vec::new();
    img.write_to(
        &mut std::io::Cursor::new(&mut bytes),
        image::ImageFormat::Png,
    )?;
    out.push(StageImage { name, png: bytes });
    Ok(())
}

/// The stage images of the detector's last frame (`det` must have been made with stage
/// recording on) and the JSON document of its parameters, components and result.
///
/// # Errors
/// The detector recorded no stage images; an image cannot be encoded.
pub fn stage_dump(det: &Detector, res: &FrameResult) -> Result<StageDump> {
    let mut out = Vec::new();
    let d = det
        .dump()
        .ok_or_else(|| anyhow!("no stage images recorded"))?;
    let (w, h) = (d.width, d.height);
    let off = |v: &[i16]| {
        v.iter()
            .map(|&x| (x as i32 + 32768) as u16)
            .collect::<Vec<u16>>()
    };
    save_png(&mut out, "00_input.png", w, h, d.input.clone())?;
    save_png(&mut out, "01_tophat.png", w, h, d.tophat.clone())?;
    save_png(&mut out, "02_opened.png", w, h, d.opened.clone())?;
    save_png(&mut out, "03_blurred.png", w, h, d.blurred.clone())?;
    save_png(&mut out, "04_gx_plus32768.png", w, h, off(&d.gx))?;
    save_png(&mut out, "05_gy_plus32768.png", w, h, off(&d.gy))?;
    save_png(&mut out, "06_magnitude.png", w, h, d.mag.clone())?;
    save_png(&mut out, "07_edges_class.png", w, h, d.edges.class.clone())?;
    save_png(&mut out, "08_edges_dir256.png", w, h, d.edges.dir.clone())?;
    save_png(
        &mut out,
        "09_edges_sub32_plus128.png",
        w,
        h,
        d.edges
            .sub
            .iter()
            .map(|&s| (s as i16 + 128) as u8)
            .collect(),
    )?;
    save_png(
        &mut out,
        "10_filled_class.png",
        w,
        h,
        d.filled.class.clone(),
    )?;
    save_png(&mut out, "11_filled_dir256.png", w, h, d.filled.dir.clone())?;
    let edges = (
        Image::from_vec(w, h, d.filled.class.clone()),
        Image::from_vec(w, h, d.filled.dir.clone()),
        Image::from_vec(w, h, d.filled.sub.clone()),
    );
    let (_, labels) = label(&edges, &Image::from_vec(w, h, d.filled.mag.clone()));
    save_png(
        &mut out,
        "12_labels.png",
        w,
        h,
        labels.data.iter().map(|&l| l.min(65535) as u16).collect(),
    )?;
    #[derive(Serialize)]
    struct Comp {
        pixels: u64,
        strong: u64,
        weak: u64,
        first_index: u64,
        rows: (u32, u32),
        cols: (u32, u32),
        sum_row: i64,
        sum_col32: i64,
        sum_dev: i64,
    }
    let comps: Vec<Comp> = d
        .components
        .iter()
        .map(|c| Comp {
            pixels: c.pixels,
            strong: c.strong,
            weak: c.weak,
            first_index: c.first_index,
            rows: (c.min_row, c.max_row),
            cols: (c.min_col, c.max_col),
            sum_row: c.sum_row,
            sum_col32: c.sum_col32,
            sum_dev: c.sum_dev,
        })
        .collect();
    let json = serde_json::json!({
        "params": det.params(),
        "components": comps,
        "result": res,
        "files": {
            "00_input.png": "input (inverted for a bright ring), u8",
            "01_tophat.png": "black top-hat, u8",
            "02_opened.png": "opening, u8",
            "03_blurred.png": "5x5 binomial blur, u8",
            "04_gx_plus32768.png": "Sobel Gx + 32768, u16",
            "05_gy_plus32768.png": "Sobel Gy + 32768, u16",
            "06_magnitude.png": "|Gx| + |Gy|, u16",
            "07_edges_class.png": "0 none, 1 weak, 2 strong (after NMS, thresholds, baseline filter)",
            "08_edges_dir256.png": "gradient direction, 256 per turn",
            "09_edges_sub32_plus128.png": "sub-pixel x offset in 1/32 px + 128 (0 = filled)",
            "10_filled_class.png": "classes after edge filling",
            "11_filled_dir256.png": "directions after edge filling",
            "12_labels.png": "component id (raster order of first pixel), u16"
        }
    });
    Ok(StageDump { images: out, json })
}
