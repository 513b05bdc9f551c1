//! Whole-frame, straightforward reference implementations of every stage: the specification the
//! streaming stages are tested against, bit for bit (and a readable model for a hardware port).
//!
//! Each function loops over the whole image and, for morphology, over every pixel of the
//! structuring element: slow, obviously right.
//!
//! ```
//! use gonio_vision::reference::{Image, dilate};
//! use gonio_vision::morphology::Disk;
//! let mut img = Image::new(5, 5, 0u8);
//! img.set(2, 2, 7);
//! let d = dilate(&img, &Disk::new(1));
//! assert_eq!(d.get(1, 1), 7);
//! assert_eq!(d.get(0, 0), 0);
//! ```

// Index loops over kernels and neighbourhoods are the readable form here.
#![allow(clippy::needless_range_loop)]

use crate::features::{FrameResult, RawStats, baseline_features, saturated_runs};
use crate::fill::fill_pixel;
use crate::label::{Component, EdgeList, EdgePixel};
use crate::morphology::Disk;
use crate::optics::Params;
use crate::segment::{EdgeRow, FILLED, NONE, SegmentParams, segment_pixel};

/// A row-major image.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Image<T> {
    /// Width.
    pub width: usize,
    /// Height.
    pub height: usize,
    /// Pixels, row-major.
    pub data: Vec<T>,
}

impl<T: Copy> Image<T> {
    /// An image filled with `v`.
    pub fn new(width: usize, height: usize, v: T) -> Self {
        Image {
            width,
            height,
            data: vec![v; width * height],
        }
    }
    /// Wraps row-major pixels (`data.len()` must be width × height).
    pub fn from_vec(width: usize, height: usize, data: Vec<T>) -> Self {
        assert_eq!(data.len(), width * height, "image size");
        Image {
            width,
            height,
            data,
        }
    }
    /// Pixel (x, y).
    pub fn get(&self, x: usize, y: usize) -> T {
        self.data[y * self.width + x]
    }
    /// Sets pixel (x, y).
    pub fn set(&mut self, x: usize, y: usize, v: T) {
        self.data[y * self.width + x] = v;
    }
    /// Pixel at signed coordinates, clamped to the border (replication).
    pub fn clamped(&self, x: isize, y: isize) -> T {
        let x = x.clamp(0, self.width as isize - 1) as usize;
        let y = y.clamp(0, self.height as isize - 1) as usize;
        self.get(x, y)
    }
    /// Pixel at signed coordinates, or `outside` beyond the border.
    pub fn or(&self, x: isize, y: isize, outside: T) -> T {
        if x < 0 || y < 0 || x >= self.width as isize || y >= self.height as isize {
            outside
        } else {
            self.get(x as usize, y as usize)
        }
    }
}

fn morph(img: &Image<u8>, disk: &Disk, max: bool) -> Image<u8> {
    let r = disk.radius() as isize;
    let mut out = Image::new(img.width, img.height, 0);
    for y in 0..img.height {
        for x in 0..img.width {
            let mut v = if max { 0u8 } else { 255 };
            for dy in -r..=r {
                for dx in -r..=r {
                    if !disk.contains(dx, dy) {
                        continue;
                    }
                    let (xx, yy) = (x as isize + dx, y as isize + dy);
                    if xx < 0 || yy < 0 || xx >= img.width as isize || yy >= img.height as isize {
                        continue;
                    }
                    let p = img.get(xx as usize, yy as usize);
                    v = if max { v.max(p) } else { v.min(p) };
                }
            }
            out.set(x, y, v);
        }
    }
    out
}

/// Dilation by a disk, pixels outside the image ignored.
pub fn dilate(img: &Image<u8>, disk: &Disk) -> Image<u8> {
    morph(img, disk, true)
}

/// Erosion by a disk, pixels outside the image ignored.
pub fn erode(img: &Image<u8>, disk: &Disk) -> Image<u8> {
    morph(img, disk, false)
}

/// Black top-hat: erode(dilate(I)) − I.
pub fn black_tophat(img: &Image<u8>, disk: &Disk) -> Image<u8> {
    let c = erode(&dilate(img, disk), disk);
    let data = c
        .data
        .iter()
        .zip(&img.data)
        .map(|(&a, &b)| a.saturating_sub(b))
        .collect();
    Image::from_vec(img.width, img.height, data)
}

/// Opening: dilate(erode(I)).
pub fn opening(img: &Image<u8>, disk: &Disk) -> Image<u8> {
    dilate(&erode(img, disk), disk)
}

/// 5×5 binomial blur, replicated borders, `(Σ w·p + 128) >> 8`.
pub fn gaussian5(img: &Image<u8>) -> Image<u8> {
    let k = [1u32, 4, 6, 4, 1];
    let mut out = Image::new(img.width, img.height, 0);
    for y in 0..img.height as isize {
        for x in 0..img.width as isize {
            let mut s = 0u32;
            for dy in -2..=2isize {
                for dx in -2..=2isize {
                    s += k[(dy + 2) as usize]
                        * k[(dx + 2) as usize]
                        * img.clamped(x + dx, y + dy) as u32;
                }
            }
            out.set(x as usize, y as usize, ((s + 128) >> 8) as u8);
        }
    }
    out
}

/// Sobel Gx, Gy and |Gx| + |Gy|, replicated borders.
pub fn sobel(img: &Image<u8>) -> (Image<i16>, Image<i16>, Image<u16>) {
    let (w, h) = (img.width, img.height);
    let mut gx = Image::new(w, h, 0i16);
    let mut gy = Image::new(w, h, 0i16);
    let mut mag = Image::new(w, h, 0u16);
    let kx = [[-1i16, 0, 1], [-2, 0, 2], [-1, 0, 1]];
    for y in 0..h as isize {
        for x in 0..w as isize {
            let (mut sx, mut sy) = (0i16, 0i16);
            for j in 0..3 {
                for i in 0..3 {
                    let p = img.clamped(x + i as isize - 1, y + j as isize - 1) as i16;
                    sx += kx[j][i] * p;
                    sy += kx[i][j] * p;
                }
            }
            gx.set(x as usize, y as usize, sx);
            gy.set(x as usize, y as usize, sy);
            mag.set(
                x as usize,
                y as usize,
                sx.unsigned_abs() + sy.unsigned_abs(),
            );
        }
    }
    (gx, gy, mag)
}

/// A whole-frame edge image: class, direction, sub-pixel offset.
pub type Edges = (Image<u8>, Image<u8>, Image<i8>);

/// NMS, dual threshold and baseline filter over the whole frame (magnitude 0 outside).
pub fn segment(gx: &Image<i16>, gy: &Image<i16>, mag: &Image<u16>, p: SegmentParams) -> Edges {
    let (w, h) = (mag.width, mag.height);
    let mut class = Image::new(w, h, 0u8);
    let mut dir = Image::new(w, h, 0u8);
    let mut sub = Image::new(w, h, 0i8);
    for y in 0..h {
        for x in 0..w {
            let mut m = [[0u16; 3]; 3];
            for (j, row) in m.iter_mut().enumerate() {
                for (i, v) in row.iter_mut().enumerate() {
                    *v = mag.or(x as isize + i as isize - 1, y as isize + j as isize - 1, 0);
                }
            }
            let (c, d, s) = segment_pixel(gx.get(x, y), gy.get(x, y), m, p);
            class.set(x, y, c);
            dir.set(x, y, d);
            sub.set(x, y, s);
        }
    }
    (class, dir, sub)
}

/// Edge filling over the whole frame (nothing outside).
pub fn fill(e: &Edges) -> Edges {
    let (class, dir, sub) = e;
    let mut out = e.clone();
    for y in 0..class.height {
        for x in 0..class.width {
            let mut c = [[0u8; 3]; 3];
            let mut d = [[0u8; 3]; 3];
            for j in 0..3 {
                for i in 0..3 {
                    let (xx, yy) = (x as isize + i as isize - 1, y as isize + j as isize - 1);
                    c[j][i] = class.or(xx, yy, NONE);
                    d[j][i] = dir.or(xx, yy, 0);
                }
            }
            if let Some((nc, nd, ns)) = fill_pixel(&c, &d) {
                out.0.set(x, y, nc);
                out.1.set(x, y, nd);
                out.2.set(x, y, ns);
            }
        }
    }
    let _ = sub;
    out
}

/// 8-connected components by flood fill (a stack), with their sums (gradient magnitudes from
/// `mag`, counted for pixels with a position of their own); returned sorted by `first_index`.
/// Also returns the label image (0 = background, components numbered 1… in raster order of
/// their first pixel).
pub fn label(e: &Edges, mag: &Image<u16>) -> (Vec<Component>, Image<u32>) {
    let (class, dir, sub) = e;
    let (w, h) = (class.width, class.height);
    let mut lab = Image::new(w, h, 0u32);
    let mut comps = Vec::new();
    let mut stack = Vec::new();
    for y0 in 0..h {
        for x0 in 0..w {
            if class.get(x0, y0) == NONE || lab.get(x0, y0) != 0 {
                continue;
            }
            let id = comps.len() as u32 + 1;
            let mut c = Component {
                min_col: u32::MAX,
                min_row: u32::MAX,
                first_index: u64::MAX,
                ..Default::default()
            };
            lab.set(x0, y0, id);
            stack.push((x0, y0));
            while let Some((x, y)) = stack.pop() {
                let s = sub.get(x, y);
                c.add_pixel(
                    y as u32,
                    x as u32,
                    w,
                    class.get(x, y),
                    dir.get(x, y),
                    s,
                    if s == FILLED { 0 } else { mag.get(x, y) },
                );
                for dy in -1..=1isize {
                    for dx in -1..=1isize {
                        let (xx, yy) = (x as isize + dx, y as isize + dy);
                        if class.or(xx, yy, NONE) != NONE && lab.get(xx as usize, yy as usize) == 0
                        {
                            lab.set(xx as usize, yy as usize, id);
                            stack.push((xx as usize, yy as usize));
                        }
                    }
                }
            }
            comps.push(c);
        }
    }
    comps.sort_by_key(|c| c.first_index);
    (comps, lab)
}

/// Every positioned edge pixel in raster order with its component's first index (`components`
/// sorted by first index and `labels` as [`label`] returns them).
pub fn edge_list(
    filled: &Edges,
    mag: &Image<u16>,
    components: &[Component],
    labels: &Image<u32>,
    p: &Params,
) -> EdgeList {
    let (fc, fd, fs) = filled;
    let (w, h) = (fc.width, fc.height);
    let mut pixels = Vec::new();
    for y in 0..h {
        for x in 0..w {
            let s = fs.get(x, y);
            if fc.get(x, y) == NONE || s == FILLED {
                continue;
            }
            pixels.push(EdgePixel {
                row: y as u16,
                col: x as u16,
                class: fc.get(x, y),
                dir: fd.get(x, y),
                sub: s,
                mag: mag.get(x, y),
                comp: components[labels.get(x, y) as usize - 1].first_index as u32,
            });
        }
    }
    EdgeList::from_resolved(pixels, h, p.max_edge_pixels)
}

/// The reference detector's stage images and result.
#[derive(Debug, Clone)]
pub struct ReferenceRun {
    /// Input as processed (inverted for a bright ring).
    pub input: Image<u8>,
    /// Black top-hat.
    pub tophat: Image<u8>,
    /// Opening.
    pub opened: Image<u8>,
    /// Blur.
    pub blurred: Image<u8>,
    /// Sobel Gx.
    pub gx: Image<i16>,
    /// Sobel Gy.
    pub gy: Image<i16>,
    /// |G|.
    pub mag: Image<u16>,
    /// Segmented edges.
    pub edges: Edges,
    /// Filled edges.
    pub filled: Edges,
    /// Components sorted by first pixel.
    pub components: Vec<Component>,
    /// Label image.
    pub labels: Image<u32>,
    /// The frame's result.
    pub result: FrameResult,
}

/// Runs every reference stage on a whole frame.
pub fn run(frame: &Image<u8>, p: &Params) -> ReferenceRun {
    let input = if p.invert {
        Image::from_vec(
            frame.width,
            frame.height,
            frame.data.iter().map(|&v| 255 - v).collect(),
        )
    } else {
        frame.clone()
    };
    let tophat = black_tophat(&input, &Disk::new(p.close_radius_px));
    let opened = opening(&tophat, &Disk::new(p.open_radius_px));
    let blurred = gaussian5(&opened);
    let (gx, gy, mag) = sobel(&blurred);
    let sp = SegmentParams {
        low: p.grad_low,
        high: p.grad_high,
        tan_q10: p.tan_tolerance_q10,
    };
    let edges = segment(&gx, &gy, &mag, sp);
    let filled = fill(&edges);
    let (components, labels) = label(&filled, &mag);
    // Raw statistics.
    let (w, h) = (frame.width, frame.height);
    let saturated_px = frame.data.iter().filter(|&&v| v == 255).count() as u64;
    let mut saturated = Vec::new();
    for (y, row) in frame.data.chunks_exact(w).enumerate() {
        saturated_runs(row, y, &mut saturated);
    }
    let (mut g1, mut g2) = (0u64, 0u64);
    for y in 1..h - 1 {
        for x in 1..w - 1 {
            let dx = frame.get(x + 1, y).abs_diff(frame.get(x - 1, y)) as u64;
            let dy = frame.get(x, y + 1).abs_diff(frame.get(x, y - 1)) as u64;
            g1 += dx + dy;
            g2 += dx * dx + dy * dy;
        }
    }
    let n = ((w - 2) * (h - 2)) as f64;
    let stats = RawStats {
        saturated_px,
        focus: g2 as f64 / n / 4.0,
        mean_gradient: g1 as f64 / n / 2.0,
    };
    let cands: Vec<Component> = components
        .iter()
        .copied()
        .filter(|c| c.is_candidate(p.min_fragment_rows))
        .collect();
    let mut edge_list = edge_list(&filled, &mag, &components, &labels, p);
    let result = baseline_features(
        &cands,
        components.len(),
        &mut edge_list,
        &saturated,
        stats,
        p,
    );
    ReferenceRun {
        input,
        tophat,
        opened,
        blurred,
        gx,
        gy,
        mag,
        edges,
        filled,
        components,
        labels,
        result,
    }
}

/// Converts a streaming edge row set to the reference's representation (tests).
pub fn edges_from_rows(rows: &[EdgeRow], width: usize) -> Edges {
    let h = rows.len();
    let mut c = Vec::with_capacity(width * h);
    let mut d = Vec::with_capacity(width * h);
    let mut s = Vec::with_capacity(width * h);
    for r in rows {
        c.extend_from_slice(&r.class);
        d.extend_from_slice(&r.dir);
        s.extend_from_slice(&r.sub);
    }
    (
        Image::from_vec(width, h, c),
        Image::from_vec(width, h, d),
        Image::from_vec(width, h, s),
    )
}
