//! The band: the detector's own stages run over a window of columns of a frame, their edges
//! and components moved into the whole frame's columns, and the ring selected among them with
//! the whole frame's parameters ([`Band::select`]).
//!
//! Every stage up to the edge filling reads a fixed number of columns on either side of the
//! pixel it makes ([`stage_reach_px`]: the closing's two disks, the opening's two, the blur,
//! Sobel, the non-maximum suppression, the filling), and treats the frame's side the same
//! wherever it is. So on the band's columns farther than that reach from a side it cuts (its
//! *exact* columns) the edge pixels are the whole frame's, bit for bit; where the band reaches
//! the frame's own side nothing is cut. A component on the exact columns that does not touch
//! a cut side's first exact column is the whole frame's component (its 8-neighbours are all
//! exact); one that does may run on beyond the band, or have taken in pixels of the cut
//! margin, so it is left out and reported when it reaches into the columns searched
//! ([`BandFrame::cut_in_search`]). The kept components' column sums and the pixels' columns
//! are moved by the band's first column in exact integer arithmetic ([`shifted`]): the
//! selection sees the integers the whole frame's labeller would give it, and computes the same
//! values from them.
//!
//! Units: columns and rows are the whole frame's pixels. Allocates a detector when the band's
//! width changes; the edge list handed to the selection keeps its storage from frame to frame.

use crate::focus::FrameFocus;
use crate::label::{Component, EdgeList, EdgePixel};
use crate::optics::Params;
use crate::pipeline::{Detector, FrameParts, RawSums};
use crate::select::{Selection, select};

use super::strips::Strips;

/// Columns on either side of a pixel that the stages up to the edge filling read, px: the
/// closing (dilation and erosion by the 2d + 1 disk), the opening (two ≈ d/2 disks), the 5×5
/// blur, Sobel, the non-maximum suppression and the filling (one each).
pub fn stage_reach_px(p: &Params) -> usize {
    2 * p.close_radius_px + 2 * p.open_radius_px + EDGE_STAGES_REACH_PX
}

/// Pixels on either side (columns or rows) that the stages after the morphology read, px: the
/// 5×5 blur, Sobel, the non-maximum suppression and the filling.
pub(crate) const EDGE_STAGES_REACH_PX: usize = 2 + 1 + 1 + 1;

/// Where a band lies in the frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct Placement {
    /// The frame column of the band's first column.
    pub x0: usize,
    /// The band's width, px.
    pub width: usize,
    /// The first and last exact column (frame columns).
    pub exact: (usize, usize),
}

impl Placement {
    /// The band whose exact columns hold frame columns `first ..= last` (`first` may lie left
    /// of the frame, `last` right of it): those plus the stages' reach on both sides, its width
    /// rounded up to a multiple of 64 (the stages work in 64-byte steps) and moved inside the
    /// frame; `None` when that is the whole frame's width or more.
    pub(crate) fn of(first: f64, last: f64, p: &Params) -> Option<Placement> {
        let reach = stage_reach_px(p);
        let span = (last.ceil() - first.floor()).max(0.0) as usize + 1;
        let width = (span + 2 * reach).div_ceil(64) * 64;
        if width >= p.width || !(first.is_finite() && last.is_finite()) {
            return None;
        }
        let w = p.width;
        let x0 = (first.floor() as i64 - reach as i64).clamp(0, (w - width) as i64) as usize;
        let e0 = if x0 > 0 { x0 + reach } else { 0 };
        let e1 = if x0 + width < w {
            x0 + width - 1 - reach
        } else {
            w - 1
        };
        Some(Placement {
            x0,
            width,
            exact: (e0, e1),
        })
    }

    /// Whether the band's left and right sides cut the frame (rather than lie on its sides).
    fn cuts(&self, frame_width: usize) -> (bool, bool) {
        (self.x0 > 0, self.x0 + self.width < frame_width)
    }

    /// True for a column on or beyond a cut side's first exact column.
    fn at_cut(&self, col: usize, frame_width: usize) -> bool {
        let (left, right) = self.cuts(frame_width);
        (left && col <= self.exact.0) || (right && col >= self.exact.1)
    }

    /// The exact columns' count.
    pub(crate) fn exact_width(&self) -> usize {
        self.exact.1 + 1 - self.exact.0
    }

    /// A band pixel's `first_index` (row · band width + column) in the frame's numbering.
    fn frame_index(&self, band_index: u64, frame_width: usize) -> u64 {
        let bw = self.width as u64;
        (band_index / bw) * frame_width as u64 + band_index % bw + self.x0 as u64
    }
}

/// The band's result for one frame, in the whole frame's columns.
#[derive(Debug)]
pub(crate) struct BandFrame {
    /// The ring's selection among the band's components.
    pub selection: Selection,
    /// Where the band lay.
    pub place: Placement,
    /// Connected components wholly on the band's exact columns, not touching a cut side's
    /// first exact column (the whole frame's components there).
    pub components: usize,
    /// The positioned edge pixels on the band's exact columns (the whole frame's there).
    pub pixels: usize,
    /// A component left out because a cut side of the band touches it reaches into the
    /// columns searched: the band cannot tell what it is in the whole frame.
    pub cut_in_search: bool,
}

/// Detectors for bands of this many widths are kept (a band is wider before the ring's motion
/// is known than after).
const WIDTHS: usize = 3;

/// The detector's stages over a window of columns (see the module documentation).
#[derive(Debug, Clone, Default)]
pub(crate) struct Band {
    /// Detectors as wide as the bands lately used, the latest last.
    dets: Vec<Detector>,
    /// The stages over strips of a band's rows side by side ([`Strips`]), for the widths lately
    /// used.
    strips: Vec<Strips>,
    cands: Vec<Component>,
    /// The band's edge pixels in the frame's columns, for the selection (kept from frame to
    /// frame).
    edges: EdgeList,
    /// The frame indices of the components a cut side touches, sorted.
    cut: Vec<u32>,
}

impl Band {
    /// Where in `dets` the detector for bands `width` columns wide is ([`kept`]).
    fn detector_for(&mut self, width: usize, p: &Params) -> usize {
        let make = || Some(Detector::from_params(Params { width, ..p.clone() }));
        kept(&mut self.dets, |d| d.params().width == width, make)
            .expect("a detector can always be made")
    }

    /// Where in `strips` the stages for bands `width` columns wide are ([`kept`]); `None` when
    /// the window is too short for strips ([`Strips::new`]).
    fn strips_for(&mut self, width: usize, p: &Params) -> Option<usize> {
        kept(
            &mut self.strips,
            |s| s.width() == width,
            || Strips::new(width, p),
        )
    }

    /// Runs the stages over the band of `frame` (the whole window, `p`'s size) whose exact
    /// columns hold the searched columns `search` widened by `guard` px on both sides, and
    /// selects the ring among its components with the saturated runs of the whole frame. The
    /// whole frame's raw statistics are taken into `raw` (with `focus`, the detector's own
    /// code) in the same pass over the rows, each row's before its band goes into the stages:
    /// one pass over the frame, the band's pixels read while in the L1 cache. `None` (`raw`
    /// then not that frame's) when the band would be the whole frame or its edge pixels
    /// overflow the whole frame's list.
    pub(crate) fn select(
        &mut self,
        frame: &[u8],
        search: (f64, f64),
        guard: f64,
        stats: (&mut RawSums, &mut FrameFocus),
        p: &Params,
    ) -> Option<BandFrame> {
        self.select_laid_out(frame, search, guard, stats, p, true)
    }

    /// [`Band::select`], in strips ([`Strips`]) only if `in_strips` (and where they can be:
    /// both sides cut, the window tall enough).
    fn select_laid_out(
        &mut self,
        frame: &[u8],
        search: (f64, f64),
        guard: f64,
        (raw, focus): (&mut RawSums, &mut FrameFocus),
        p: &Params,
        in_strips: bool,
    ) -> Option<BandFrame> {
        let (w, h) = (p.width, p.height);
        let place = Placement::of(search.0 - guard, search.1 + guard, p)?;
        let (x0, bw) = (place.x0, place.width);
        // The stages after the morphology over strips of the band's rows side by side where
        // both its sides are cut (a frame side must be a row's end), else the band's rows as
        // they are.
        let strips = (in_strips && place.cuts(w) == (true, true))
            .then(|| self.strips_for(bw, p))
            .flatten();
        let parts = match strips {
            Some(i) => {
                let st = &mut self.strips[i];
                band_rows(frame, &place, p, (raw, focus), |y, row| {
                    st.push(y, row);
                    Some(())
                })?;
                FrameParts::of(st.finish())
            }
            None => {
                let k = self.detector_for(bw, p);
                let det = &mut self.dets[k];
                band_rows(frame, &place, p, (raw, focus), |_, row| {
                    det.push_stages(row).ok()
                })?;
                det.finish_parts().ok()?
            }
        };
        let (e0, e1) = place.exact;
        let in_search = |lo: usize, hi: usize| hi as f64 >= search.0 && lo as f64 <= search.1;
        let mut cut_in_search = false;
        // Components a cut side touches: from their column ranges (candidates; a filled pixel
        // has no entry in the pixel list, but is in the range) and from their pixels.
        self.cut.clear();
        self.cands.clear();
        for c in parts.cands {
            let (lo, hi) = (c.min_col as usize + x0, c.max_col as usize + x0);
            if place.at_cut(lo, w) || place.at_cut(hi, w) {
                self.cut.push(place.frame_index(c.first_index, w) as u32);
                cut_in_search |= in_search(lo.max(e0), hi.min(e1));
            } else {
                self.cands.push(shifted(c, &place, w));
            }
        }
        let pixels = parts.edges.pixels()?;
        let n_pixels = pixels.len();
        for e in pixels {
            if place.at_cut(e.col as usize + x0, w) {
                self.cut
                    .push(place.frame_index(u64::from(e.comp), w) as u32);
            }
        }
        self.cut.sort_unstable();
        self.cut.dedup();
        let out = self.edges.refill();
        for e in pixels {
            let col = e.col as usize + x0;
            if col < e0 || col > e1 {
                continue;
            }
            let comp = place.frame_index(u64::from(e.comp), w) as u32;
            if !cut_in_search && in_search(col, col) && self.cut.binary_search(&comp).is_ok() {
                cut_in_search = true;
            }
            out.push(EdgePixel {
                col: col as u16,
                comp,
                ..*e
            });
        }
        let exact_pixels = out.len();
        // The components a cut side touches (or beyond it) are those with a positioned pixel
        // there or a candidate's range reaching there: a filled pixel has a positioned
        // neighbour on its side of the first exact column. What is left lies wholly on the
        // exact columns: the whole frame's components there, however the band was laid out.
        let components = parts.components.saturating_sub(self.cut.len());
        self.edges
            .resolve_pixels(h, p.max_edge_pixels.max(n_pixels));
        let selection = select(&self.cands, &mut self.edges, raw.saturated_runs(), p);
        Some(BandFrame {
            selection,
            place,
            components,
            pixels: exact_pixels,
            cut_in_search,
        })
    }
}

/// One pass over `frame` (`p`'s window): each row's raw statistics into `raw` (with `focus`,
/// the detector's own code), then the row's band (`place`) into `push` with the row's index,
/// while the row is in the L1 cache. `None` as soon as `push` gives `None`.
fn band_rows(
    frame: &[u8],
    place: &Placement,
    p: &Params,
    (raw, focus): (&mut RawSums, &mut FrameFocus),
    mut push: impl FnMut(usize, &[u8]) -> Option<()>,
) -> Option<()> {
    let (w, h) = (p.width, p.height);
    let (x0, bw) = (place.x0, place.width);
    for y in 0..h {
        raw.add_row(focus, frame, (w, h), y);
        push(y, &frame[y * w + x0..y * w + x0 + bw])?;
    }
    Some(())
}

/// Where in `kept` (the last [`WIDTHS`] used, the latest last) the one that `is` is: moved to
/// the end, or made by `make` and pushed there (the least lately used dropped); `None` when
/// none is kept and `make` makes none.
fn kept<T>(
    kept: &mut Vec<T>,
    is: impl Fn(&T) -> bool,
    make: impl FnOnce() -> Option<T>,
) -> Option<usize> {
    let t = match kept.iter().position(is) {
        Some(k) => kept.remove(k),
        None => {
            let t = make()?;
            if kept.len() == WIDTHS {
                kept.remove(0);
            }
            t
        }
    };
    kept.push(t);
    Some(kept.len() - 1)
}

/// Component `c` of a band placed at `place`, in the columns of a frame `w` wide: every column
/// sum moved by the band's first column x0 (columns are in 1/32 px, c → c + 32·x0, so Σc,
/// Σr·c, Σr²·c and Σc² follow from the counts and sums already there), the first pixel's index
/// re-numbered. Exact integers: the sums the whole frame's labeller makes of the same pixels.
fn shifted(c: &Component, place: &Placement, w: usize) -> Component {
    let dx = 32 * place.x0 as i64;
    let n = c.pos_n as i64;
    Component {
        sum_col32_sq: c.sum_col32_sq
            + 2 * i128::from(dx) * i128::from(c.sum_col32)
            + i128::from(dx) * i128::from(dx) * i128::from(n),
        sum_col32: c.sum_col32 + dx * n,
        sum_row_col32: c.sum_row_col32 + dx * c.sum_row,
        sum_row2_col32: c.sum_row2_col32 + dx * c.sum_row2,
        min_col: c.min_col + place.x0 as u32,
        max_col: c.max_col + place.x0 as u32,
        first_index: place.frame_index(c.first_index, w),
        ..*c
    }
}

/// The parameters of the default optics with a window 640 px wide and `height` rows (the
/// tests' frames).
#[cfg(test)]
pub(super) fn window_640(height: u32) -> Params {
    crate::Optics {
        window_width_px: 640,
        window_height_px: height,
        ..crate::Optics::default()
    }
    .params()
    .expect("the default optics with a 640 px window")
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::label::component_of;

    #[test]
    fn a_shifted_component_is_the_sums_of_the_shifted_pixels() {
        let (w, x0) = (1440usize, 517usize);
        let place = Placement {
            x0,
            width: 192,
            exact: (0, 0),
        };
        let mut px: Vec<EdgePixel> = (0..40u16)
            .map(|k| EdgePixel {
                row: 3 + k * 7 % 31,
                col: 20 + (k * 13) % 50,
                class: 2,
                dir: (k * 5) as u8,
                sub: (k as i8 % 31) - 15,
                mag: 100 + k,
                comp: 0,
            })
            .collect();
        px.sort_by_key(|e| (e.row, e.col));
        px.dedup_by_key(|e| (e.row, e.col));
        let moved: Vec<EdgePixel> = px
            .iter()
            .map(|e| EdgePixel {
                col: e.col + x0 as u16,
                ..*e
            })
            .collect();
        assert_eq!(
            shifted(&component_of(&px, place.width), &place, w),
            component_of(&moved, w)
        );
    }

    /// The band in strips side by side and the band's rows as they are give the same result:
    /// the same selection, components, pixels and cut components, on frames of lines and noise
    /// with bands all across the frame (those at its sides run as they are either way).
    #[test]
    fn the_strips_select_what_the_band_selects() {
        let p = window_640(320);
        let frame = lines_and_noise(p.width, p.height, 0x2545_f491_4f6c_dd1d);
        let (mut strips, mut plain) = (Band::default(), Band::default());
        let mut stats = (RawSums::default(), FrameFocus::default());
        let mut laid_out = 0;
        for k in 0..30 {
            let first = -20.0 + 23.7 * k as f64;
            let search = (first, first + 25.0 + (k % 4) as f64 * 16.0);
            let (a, b) = (
                strips.select_laid_out(&frame, search, 3.0, (&mut stats.0, &mut stats.1), &p, true),
                plain.select_laid_out(&frame, search, 3.0, (&mut stats.0, &mut stats.1), &p, false),
            );
            let (Some(a), Some(b)) = (a, b) else {
                panic!("band {search:?}: the band is the whole frame");
            };
            assert_eq!(
                (
                    &a.selection,
                    a.place,
                    a.components,
                    a.pixels,
                    a.cut_in_search
                ),
                (
                    &b.selection,
                    b.place,
                    b.components,
                    b.pixels,
                    b.cut_in_search
                ),
                "band {search:?}"
            );
            // The pixels handed to the selection: the same, with the same components but
            // where a cut side touches them (their ids then come from the cut margin).
            let cut = |band: &Band, c: u32| band.cut.binary_search(&c).is_ok();
            let (pa, pb) = (
                strips.edges.pixels().unwrap().to_vec(),
                plain.edges.pixels().unwrap().to_vec(),
            );
            assert_eq!(pa.len(), pb.len(), "band {search:?}");
            for (x, y) in pa.iter().zip(&pb) {
                let same_comp = x.comp == y.comp || (cut(&strips, x.comp) && cut(&plain, y.comp));
                assert!(
                    same_comp && EdgePixel { comp: 0, ..*x } == EdgePixel { comp: 0, ..*y },
                    "band {search:?}: {x:?} / {y:?}"
                );
            }
            laid_out += usize::from(a.place.cuts(p.width) == (true, true));
        }
        assert!(
            !strips.strips.is_empty() && laid_out >= 20,
            "{laid_out} bands in strips"
        );
    }

    /// A frame `w` × `h` of dark lines 37 px apart, a wider one at column 300, and noise.
    fn lines_and_noise(w: usize, h: usize, seed: u64) -> Vec<u8> {
        let mut s = seed;
        (0..w * h)
            .map(|i| {
                s ^= s << 13;
                s ^= s >> 7;
                s ^= s << 17;
                let x = (i % w) as f64 + 0.05 * (i / w) as f64;
                let dark = (x % 37.0) < 6.0 + (s % 3) as f64 || (x - 300.0).abs() < 5.5;
                (if dark { 60 } else { 150 }) + (s >> 58) as u8
            })
            .collect()
    }

    /// On the exact columns the band's edge pixels are the whole frame's, bit for bit: for a
    /// band inside the frame and one at each of its sides.
    #[test]
    fn the_exact_columns_hold_the_whole_frames_edges() {
        let p = window_640(160);
        let (w, h) = (p.width, p.height);
        let frame = lines_and_noise(w, h, 0x9e37_79b9_7f4a_7c15);
        let pixels_of = |det: &mut Detector, x0: usize, bw: usize| -> Vec<EdgePixel> {
            for row in frame.chunks_exact(w) {
                det.push_row(&row[x0..x0 + bw]).unwrap();
            }
            let parts = det.finish_parts().unwrap();
            let px = parts.edges.pixels().unwrap();
            px.iter()
                .map(|e| EdgePixel {
                    col: e.col + x0 as u16,
                    comp: 0,
                    ..*e
                })
                .collect()
        };
        let all = pixels_of(&mut Detector::from_params(p.clone()), 0, w);
        let mut bands = vec![(3.0, 40.0), (600.0, 630.0)];
        bands.extend((0..40).map(|k| (40.0 + 11.3 * k as f64, 80.0 + 11.3 * k as f64)));
        for (first, last) in bands {
            let place = Placement::of(first, last, &p).unwrap();
            let (e0, e1) = place.exact;
            assert!(e0 as f64 <= first.max(0.0) && e1 as f64 >= last.min(w as f64 - 1.0));
            let mut det = Detector::from_params(Params {
                width: place.width,
                ..p.clone()
            });
            let band = pixels_of(&mut det, place.x0, place.width);
            let on =
                |lo: usize, hi: usize| move |e: &&EdgePixel| (lo..=hi).contains(&(e.col as usize));
            let whole: Vec<_> = all.iter().filter(on(e0, e1)).collect();
            assert!(whole.len() > 100, "{} edge pixels", whole.len());
            let got: Vec<_> = band.iter().filter(on(e0, e1)).collect();
            assert_eq!(got, whole, "band for columns {first} … {last}");
        }
    }
}
