//! A band's stages after the morphology over strips of its rows side by side: the same edges
//! from fewer, wider rows.
//!
//! A band is two 64-byte steps wide, and a row of two steps pays each stage's fixed cost per
//! row (the row's ends, the ring slots, the calls) over little work. The morphology's kernels
//! keep their state in registers over batches of rows and cost by the step, so the top-hat and
//! the opening run over the band's rows as they are. The blur, Sobel, the segmentation and the
//! filling, which cost by the row as much as by the step, run over [`STRIPS`] strips side by
//! side. Strip j holds t = ⌈h/n⌉ rows of the band and R = [`EDGE_STAGES_REACH_PX`] more on
//! either side (those stages read rows as far as they read columns): the opened rows from
//! j·t − R on (0 for the first, h − t − 2R at most for the last). Its columns are only the
//! band's exact columns and R more on either side (the band's sides are both cut, so those
//! are its columns [`stage_reach_px`] − R … width − 1 − (`stage_reach_px` − R): 76 of 128 on
//! the station's window): the opened rows are exact there, and those stages give exact
//! edges on the exact columns from them; the band's own stages would give nothing exact
//! beyond. Each strip's sides, top and bottom are treated as the frame's, so its rows
//! j·t … (j + 1)·t − 1, R or more from a cut end or at the frame's own, are the band's own,
//! bit for bit, on every exact column: a seam between two strips is a cut side of each,
//! like the band's own sides, and reaches no further into it than they do; the R columns
//! beside the exact ones are a cut margin, as the band's wider one is. The labeller then
//! takes the band's rows in order ([`Labeller::push_pixels`], which numbers the rows itself),
//! the first strip's as they come and the others' held until then, their columns made the
//! band's: it sees what the band's own stages give on every exact column, so
//! [`super::band`]'s reasoning about exact and cut columns holds unchanged. Only a band with
//! both sides cut can use it (a frame side must be a row's end), in a window of at least 4nR
//! rows. On the station's window (540 rows) five strips of 118 rows and 76 columns (rows of
//! 380 columns, where the band's own rows are 540 of 128) take ≈ 20 % off a tracked frame
//! (BENCHMARKS.md).
//!
//! Components: a component on the exact columns that touches neither cut side's first exact
//! column is the same here as in the band's own stages (its pixels and their 8-neighbours are
//! exact), and one that does is cut in both: a path of pixels from the exact columns into a
//! margin passes through the first exact column, so [`super::band`] finds the same cut
//! components and the same components on the exact columns, from a narrower margin.
//!
//! Units: rows and columns are the band's pixels. Allocates its rings and a copy of the
//! band's opened rows when made, and its held rows' pixel lists on the first frames.

use crate::buffer::Aligned;
use crate::fill::EdgeFill;
use crate::label::{EdgePixel, Labeller};
use crate::optics::Params;
use crate::pipeline::{EdgeStages, Morphology, edge_stages, labeller, morphology, take_row};
use crate::rows::{LastSink, RowBlock, RowSink, StageObserver, Then};
use crate::segment::SparseEdgeRow;

use super::band::{EDGE_STAGES_REACH_PX, stage_reach_px};

/// Strips side by side: with a row's fixed cost in those stages about that of one and a half
/// 64-byte steps, (1.5 + ⌈76n/64⌉)·(h/n + 2R) steps on the station's window is least near
/// n = 5 (885, against 942 for four and 950 for six); four, five and eight measured within
/// the machine's noise of each other.
pub(crate) const STRIPS: usize = 5;

/// The band's morphology, the stages after it over strips of the band's rows side by side,
/// and the band's labeller (see the module documentation).
#[derive(Debug, Clone)]
pub(crate) struct Strips {
    line: Morphology<Lay>,
    layout: Layout,
    invert: bool,
}

/// Where the strips lie in the band.
#[derive(Debug, Clone, Copy)]
struct Layout {
    /// Each strip's first band row.
    starts: [usize; STRIPS],
    /// The band's rows each strip gives, t = ⌈h/n⌉ (the last strip may give fewer).
    share: usize,
    /// The band's height, rows.
    height: usize,
    /// The band's width, px.
    width: usize,
    /// The band's first column the strips hold: R left of its first exact column.
    first: usize,
}

impl Layout {
    /// Whether band row `y`, in strip `j`, is one the strip gives: j·t … (j + 1)·t − 1, R or
    /// more from a cut end of the strip, or at the frame's.
    fn gives(&self, j: usize, y: usize) -> bool {
        (j * self.share..((j + 1) * self.share).min(self.height)).contains(&y)
    }

    /// A strip's width, px: the band's exact columns and R more on either side (as many
    /// columns in from each of the band's sides).
    fn strip(&self) -> usize {
        self.width - 2 * self.first
    }

    /// The last strip's first band row: row k of the strips is complete with band row
    /// last_start + k.
    fn last_start(&self) -> usize {
        self.starts[STRIPS - 1]
    }
}

impl Strips {
    /// The stages for bands of `band_width` columns (a multiple of 64), both sides cut, of
    /// frames with `p`; `None` for a window shorter than 4nR rows (n = [`STRIPS`]), where the
    /// strips' overlap would cost much of what they save, or a width not a multiple of 64 or
    /// with no exact column.
    pub(crate) fn new(band_width: usize, p: &Params) -> Option<Strips> {
        let (h, n, reach) = (p.height, STRIPS, EDGE_STAGES_REACH_PX);
        let t = h.div_ceil(n);
        let strip_rows = t + 2 * reach;
        // Both sides cut: the exact columns lie `stage_reach_px` in from each.
        let first = stage_reach_px(p) - reach;
        if !band_width.is_multiple_of(64) || h < 4 * n * reach || band_width <= 2 * (first + reach)
        {
            return None;
        }
        // Strip j: the opened rows from starts[j] on.
        let layout = Layout {
            starts: std::array::from_fn(|j| (j * t).saturating_sub(reach).min(h - strip_rows)),
            share: t,
            height: h,
            width: band_width,
            first,
        };
        let strip = layout.strip();
        let wide = Params {
            width: n * strip,
            height: strip_rows,
            ..p.clone()
        };
        let band = Params {
            width: band_width,
            ..p.clone()
        };
        let rejoin = Rejoin {
            input: SparseEdgeRow::new(n * strip),
            labeller: labeller(&band, false),
            held: vec![Vec::new(); h - t],
            k: 0,
            layout,
            scratch: Vec::new(),
        };
        let lay = Lay {
            rows: Aligned::new(h * band_width, 0),
            y: 0,
            layout,
            edges: edge_stages(
                &wide,
                Then {
                    stage: EdgeFill::new(n * strip),
                    next: rejoin,
                },
            ),
        };
        Some(Strips {
            line: morphology(&band, lay),
            layout,
            invert: p.invert,
        })
    }

    /// The band's width, px.
    pub(crate) fn width(&self) -> usize {
        self.layout.width
    }

    /// Pushes the band's row `y` (`width()` pixels); row 0 starts a frame.
    pub(crate) fn push(&mut self, y: usize, row: &[u8]) {
        if y == 0 {
            self.line.reset();
        }
        take_row(self.line.input(), row, self.invert);
        self.line.pushed(&mut ());
    }

    /// Ends the frame once every row is in: the labeller has the band's rows.
    pub(crate) fn finish(&mut self) -> &mut Labeller {
        self.line.finish(&mut ());
        self.line.last_sink()
    }
}

/// The band's opened rows into the stages after the morphology as the strips' rows: row k of
/// the strips is the opened rows `starts[j]` + k side by side.
#[derive(Debug, Clone)]
struct Lay {
    /// The frame's opened rows, `width` each (the opening writes its batches of rows here).
    rows: Aligned<u8>,
    /// Opened rows received in this frame.
    y: usize,
    layout: Layout,
    edges: EdgeStages<Then<EdgeFill, Rejoin>>,
}

impl LastSink for Lay {
    type Sink = Labeller;
    fn last_sink(&mut self) -> &mut Labeller {
        self.edges.last_sink()
    }
}

impl RowSink for Lay {
    type Row = [u8];
    fn input(&mut self) -> &mut [u8] {
        let bw = self.layout.width;
        &mut self.rows[self.y * bw..(self.y + 1) * bw]
    }
    fn input_block(&mut self, n: usize) -> Option<RowBlock<'_>> {
        let bw = self.layout.width;
        (self.y + n <= self.layout.height).then(|| RowBlock {
            first: self.y * bw,
            stride: bw,
            buf: &mut self.rows[..],
        })
    }
    fn pushed<O: StageObserver + ?Sized>(&mut self, obs: &mut O) {
        let (y, l) = (self.y, self.layout);
        self.y += 1;
        let Some(k) = y.checked_sub(l.last_start()) else {
            return;
        };
        let (row, bw, sw) = (self.edges.input(), l.width, l.strip());
        for (j, &a) in l.starts.iter().enumerate() {
            let r = a + k;
            let from = r * bw + l.first;
            row[j * sw..(j + 1) * sw].copy_from_slice(&self.rows[from..from + sw]);
        }
        self.edges.pushed(obs);
    }
    fn finish<O: StageObserver + ?Sized>(&mut self, obs: &mut O) {
        self.edges.finish(obs);
    }
    fn reset(&mut self) {
        self.y = 0;
        self.edges.reset();
    }
    fn lag(&self) -> usize {
        self.layout.last_start() + self.edges.lag()
    }
}

/// The filled rows of the strips into the band's labeller, in the band's row order.
#[derive(Debug, Clone)]
struct Rejoin {
    /// The strips' filled row.
    input: SparseEdgeRow,
    labeller: Labeller,
    /// The pixels of the band's rows t … h − 1, held until rows 0 … t − 1 are in.
    held: Vec<Vec<EdgePixel>>,
    /// Rows of the strips received in this frame.
    k: usize,
    layout: Layout,
    /// The first strip's row in the band's columns.
    scratch: Vec<EdgePixel>,
}

impl LastSink for Rejoin {
    type Sink = Labeller;
    fn last_sink(&mut self) -> &mut Labeller {
        &mut self.labeller
    }
}

impl RowSink for Rejoin {
    type Row = SparseEdgeRow;
    fn input(&mut self) -> &mut SparseEdgeRow {
        &mut self.input
    }
    fn pushed<O: StageObserver + ?Sized>(&mut self, _: &mut O) {
        let (k, l) = (self.k, self.layout);
        self.k += 1;
        let pixels = &self.input.pixels[..];
        // The pixels are in column order: each strip's are the next ones left of its end.
        let (mut lo, sw) = (0, l.strip());
        for (j, &a) in l.starts.iter().enumerate() {
            let x0 = j * sw;
            let end = (x0 + sw) as u16;
            let hi = lo + pixels[lo..].iter().take_while(|p| p.col < end).count();
            let px = &pixels[lo..hi];
            lo = hi;
            let y = a + k;
            if !l.gives(j, y) {
                continue;
            }
            // The band's column of strip j's column c is c − j·strip + first.
            let to_band = |p: &EdgePixel| EdgePixel {
                col: p.col + l.first as u16 - x0 as u16,
                ..*p
            };
            if j == 0 {
                // The first strip's rows come in order.
                self.scratch.clear();
                self.scratch.extend(px.iter().map(to_band));
                self.labeller.push_pixels(&self.scratch);
            } else {
                let row = &mut self.held[y - l.share];
                row.clear();
                row.extend(px.iter().map(to_band));
            }
        }
    }
    fn finish<O: StageObserver + ?Sized>(&mut self, _: &mut O) {
        for row in &self.held {
            self.labeller.push_pixels(row);
        }
        self.labeller.finish();
    }
    fn reset(&mut self) {
        self.k = 0;
        self.labeller.reset();
    }
    fn lag(&self) -> usize {
        0
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::track::band::window_640;

    /// Strips need a window of 4nR rows (each strip's share of rows at least four times the
    /// rows it shares with its neighbours) and a band a whole number of 64-byte steps wide
    /// with exact columns.
    #[test]
    fn strips_need_a_tall_enough_window_and_whole_steps() {
        let params = |h: usize| window_640(h as u32);
        let r = EDGE_STAGES_REACH_PX;
        assert!(Strips::new(128, &params(4 * STRIPS * r - 1)).is_none());
        assert!(Strips::new(128, &params(4 * STRIPS * r)).is_some());
        assert!(Strips::new(96, &params(540)).is_none());
        // The stages' reach is 62 of a band's columns: 64 leaves two exact ones.
        let reach = stage_reach_px(&params(540));
        assert_eq!(reach, 31);
        assert!(Strips::new(64, &params(540)).is_some());
        let s = Strips::new(128, &params(540)).unwrap();
        assert_eq!((s.layout.first, s.layout.strip()), (26, 76));
    }
}
