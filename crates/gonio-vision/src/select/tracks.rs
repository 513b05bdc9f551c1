//! The fragment tracks: a frame's candidate components as fragments of one polarity (a mixed
//! or scattered component split into its smooth pieces), linked top to bottom into tracks; the
//! row intervals the tracks cover; the sums that follow a pixel set's change.

use super::line::{Curve, curve, curve_with, median, parabola, ransac};
use crate::label::{Component, EdgeList, EdgePixel, component_of};
use crate::optics::Params;

/// The disjoint row intervals covered by intervals `[first, last]` given in order of their first
/// rows (a track's fragments, top to bottom): overlapping and adjacent ones merged, in row order.
/// One sweep, no sort.
pub(super) fn merged(iv: &[(u32, u32)]) -> impl Iterator<Item = (u32, u32)> + '_ {
    let mut it = iv.iter().copied().peekable();
    std::iter::from_fn(move || {
        let (a, mut b) = it.next()?;
        while let Some(&(a2, b2)) = it.peek() {
            debug_assert!(a2 >= a, "intervals in order of their first rows");
            if a2 > b + 1 {
                break;
            }
            b = b.max(b2);
            it.next();
        }
        Some((a, b))
    })
}

/// Rows covered by intervals given in order of their first rows (overlaps counted once).
pub(super) fn union_len(iv: &[(u32, u32)]) -> u32 {
    merged(iv).map(|(a, b)| b - a + 1).sum()
}

/// Rows covered by both of two sets of disjoint intervals in row order ([`merged`]), and the
/// first and last of them (0, 0, 0 when none): one merge-like sweep. The same integers as the
/// union of the pairwise overlaps of the unmerged intervals (a row lies in both unions exactly
/// when it lies in an overlap of one interval of each).
pub(super) fn shared(a: &[(u32, u32)], b: &[(u32, u32)]) -> (u32, u32, u32) {
    let (mut i, mut j) = (0, 0);
    let (mut n, mut first, mut last) = (0, 0, 0);
    while i < a.len() && j < b.len() {
        let (lo, hi) = (a[i].0.max(b[j].0), a[i].1.min(b[j].1));
        if lo <= hi {
            if n == 0 {
                first = lo;
            }
            n += hi - lo + 1;
            last = hi;
        }
        if a[i].1 < b[j].1 {
            i += 1;
        } else {
            j += 1;
        }
    }
    (n, first, last)
}

/// One edge of the window seen as a ring edge: linked fragments with their summed statistics.
#[derive(Debug, Clone, PartialEq)]
pub struct Track {
    /// The fragments' sums, added.
    pub comp: Component,
    /// Row ranges of the fragments.
    pub rows: Vec<(u32, u32)>,
    /// Rows covered.
    pub coverage: u32,
    /// +1 rising (Gx > 0), −1 falling.
    pub polarity: i8,
    /// The curve of all the fragments' pixels.
    pub curve: Curve,
    /// Mean gradient magnitude of the positioned pixels (Sobel L1 units).
    pub gradient: f64,
    /// Strong pixels over all pixels.
    pub strong_share: f64,
}

/// A fragment of an edge: a clean candidate component, or a smooth piece of one, of one
/// polarity, with its curve (`curve_with` with the frame's curvature). Tracks start from
/// fragments and absorb them; only the tracks are [`Track`]s (no row list per fragment).
#[derive(Debug, Clone, Copy)]
pub(super) struct Frag {
    comp: Component,
    polarity: i8,
    curve: Curve,
}

impl Track {
    /// A track of one fragment.
    fn start(f: &Frag) -> Track {
        let comp = f.comp;
        let mut t = Track {
            comp,
            rows: vec![(comp.min_row, comp.max_row)],
            coverage: comp.row_span(),
            polarity: f.polarity,
            curve: f.curve,
            gradient: 0.0,
            strong_share: 0.0,
        };
        t.update_stats();
        t
    }

    fn update_stats(&mut self) {
        self.gradient = self.comp.sum_mag as f64 / self.comp.pos_n.max(1) as f64;
        self.strong_share = self.comp.strong as f64 / self.comp.pixels.max(1) as f64;
    }

    /// Adds a fragment that starts no higher than the track's fragments (they come top to
    /// bottom: `rows` stays in order of first rows, see [`merged`]).
    fn absorb(&mut self, f: &Frag, height: usize, q: Option<f64>) {
        let mut c = self.comp;
        c.merge(&f.comp);
        if let Some(cv) = curve_with(&c, height, q) {
            self.comp = c;
            self.curve = cv;
            self.rows.push((f.comp.min_row, f.comp.max_row));
            self.coverage = union_len(&self.rows);
            self.update_stats();
        }
    }

    /// Last row covered.
    fn last_row(&self) -> u32 {
        self.rows.iter().map(|r| r.1).max().unwrap_or(0)
    }

    /// Mean row of the positioned pixels.
    fn mean_row(&self) -> f64 {
        self.comp.sum_row as f64 / self.comp.pos_n.max(1) as f64
    }
}

pub(super) fn polarity(c: &Component) -> Option<i8> {
    if 10 * c.gx_pos >= 9 * c.pixels {
        Some(1)
    } else if 10 * c.gx_pos <= c.pixels {
        Some(-1)
    } else {
        None
    }
}

/// The pixels of `old` not in `new` into `gone` and those of `new` not in `old` into `came`
/// (both cleared first), for two subsets of one pixel list in raster order (no two pixels at
/// one position): one merge-like sweep. True when the two are the same set.
pub(super) fn diff(
    old: &[EdgePixel],
    new: &[EdgePixel],
    gone: &mut Vec<EdgePixel>,
    came: &mut Vec<EdgePixel>,
) -> bool {
    let key = |e: &EdgePixel| (e.row as u32) << 16 | e.col as u32;
    gone.clear();
    came.clear();
    let (mut i, mut j) = (0, 0);
    while i < old.len() && j < new.len() {
        let (a, b) = (key(&old[i]), key(&new[j]));
        debug_assert!(i == 0 || key(&old[i - 1]) < a, "raster order");
        debug_assert!(j == 0 || key(&new[j - 1]) < b, "raster order");
        if a == b {
            i += 1;
            j += 1;
        } else if a < b {
            gone.push(old[i]);
            i += 1;
        } else {
            came.push(new[j]);
            j += 1;
        }
    }
    gone.extend_from_slice(&old[i..]);
    came.extend_from_slice(&new[j..]);
    gone.is_empty() && came.is_empty()
}

/// `component_of(new, w)` from the sums `old` of a pixel set that became `new` (in raster
/// order) by losing the pixels `gone` and gaining `came`: the counts and sums are integers, so
/// adding what came and taking away what went gives the same values as summing `new` afresh
/// (in any order); the first and last row and pixel are `new`'s first and last (raster order),
/// the column range a pass over `new`'s columns. Summed afresh when the change is not smaller
/// than `new`.
pub(super) fn resum(
    old: &Component,
    gone: &[EdgePixel],
    came: &[EdgePixel],
    new: &[EdgePixel],
    w: usize,
) -> Component {
    let (Some(first), Some(last)) = (new.first(), new.last()) else {
        return component_of(new, w);
    };
    if gone.len() + came.len() >= new.len() {
        return component_of(new, w);
    }
    let mut c = *old;
    if !came.is_empty() {
        c.merge(&component_of(came, w));
    }
    if !gone.is_empty() {
        c.remove(&component_of(gone, w));
    }
    c.min_row = first.row as u32;
    c.max_row = last.row as u32;
    c.first_index = first.row as u64 * w as u64 + first.col as u64;
    (c.min_col, c.max_col) = new.iter().fold((u32::MAX, 0), |(lo, hi), e| {
        (lo.min(e.col as u32), hi.max(e.col as u32))
    });
    c
}

/// The smooth pieces of a set of same-polarity pixels, strongest first: a deterministic RANSAC
/// line bent with the frame's curvature `q` (pairs of pixels from the upper and lower halves;
/// inliers within 1.5 px; slope within the baseline filter's tolerance), its pixels within
/// 1.5 px, then a curve re-fitted to those within 1 px of it, twice. Pieces spanning fewer than
/// `min_fragment_rows` rows end the search.
///
/// Each piece comes with its curve (`curve_with` with `q`) when the re-fits reached it (the last
/// re-fit kept the same pixels), else `None`. A re-fit that keeps the same pixels as the one
/// before ends the re-fits: the same pixels give the same sums and the same curve, so the
/// remaining one would change nothing (no component summed twice).
pub(super) fn split(
    s: &mut Scratch,
    p: &Params,
    q: Option<f64>,
    out: &mut Vec<(Component, Option<Curve>)>,
) {
    let (h, w) = (p.height, p.width);
    let qq = q.unwrap_or(0.0);
    // Columns less the frame's curvature: a concentric edge is straight in these.
    let col = |e: &EdgePixel| {
        let u = 2.0 * e.row as f64 - (h as f64 - 1.0);
        e.col32() as f64 / 32.0 - qq * u * u
    };
    let col_px = |e: &EdgePixel| e.col32() as f64 / 32.0;
    for _ in 0..4 {
        if s.part.len() < p.min_fragment_rows as usize {
            break;
        }
        let Some((r0, c0, slope)) = ransac(&s.part, qq, 1.5, p, &mut s.rows, &mut s.cols) else {
            break;
        };
        let near = |q: &EdgePixel| (col(q) - c0 - slope * (q.row as f64 - r0)).abs() <= 1.5;
        s.taken.clear();
        s.rest.clear();
        for e in &s.part {
            if near(e) {
                s.taken.push(*e);
            } else {
                s.rest.push(*e);
            }
        }
        std::mem::swap(&mut s.part, &mut s.rest);
        s.piece.clear();
        s.piece.extend_from_slice(&s.taken);
        // `c` is always the sums of `s.piece`; `known` its curve once fitted.
        let mut c = component_of(&s.piece, w);
        let mut known = None;
        for _ in 0..2 {
            let Some(cv) = curve_with(&c, h, q) else {
                break;
            };
            s.next.clear();
            s.next.extend(
                s.taken
                    .iter()
                    .filter(|e| (col_px(e) - cv.at(e.row as f64, h)).abs() <= 1.0),
            );
            // Both are subsets of `taken` (raster order): the new sums from the change.
            if diff(&s.piece, &s.next, &mut s.gone, &mut s.came) {
                known = Some(cv);
                break;
            }
            c = resum(&c, &s.gone, &s.came, &s.next, w);
            std::mem::swap(&mut s.piece, &mut s.next);
        }
        if c.pixels == 0 || c.row_span() < p.min_fragment_rows {
            break;
        }
        out.push((c, known));
    }
}

/// Pixel and value buffers the selection reuses within a frame: no allocation per component
/// split or pair refitted.
#[derive(Debug, Default)]
pub(super) struct Scratch {
    /// A component's pixels.
    comp: Vec<EdgePixel>,
    /// The pixels of one polarity still to split.
    part: Vec<EdgePixel>,
    rest: Vec<EdgePixel>,
    taken: Vec<EdgePixel>,
    piece: Vec<EdgePixel>,
    next: Vec<EdgePixel>,
    /// The pixels a re-fit dropped and took in ([`diff`]).
    gone: Vec<EdgePixel>,
    came: Vec<EdgePixel>,
    /// The long candidates' curves fitted for the frame's curvature, by sorted candidate.
    fitted: Vec<Option<Curve>>,
    /// RANSAC's rows and reduced columns.
    rows: Vec<f64>,
    cols: Vec<f64>,
}

/// The fragments of the frame and its curvature: clean candidate components as they are; a
/// component that mixes polarities or scatters about its curve (an edge that took in a
/// crossing scratch's or a speck's edge) split into its smooth pieces from its own pixels. The
/// frame's curvature (px per u²) is the median of the clean fragments spanning half the window
/// or more (`None` without one): every edge in the window is concentric with the ring, and a
/// shorter piece bends with it.
///
/// Each curve is fitted once: a component fitted with a parabola for the frame's curvature
/// ([`parabola`]: the curvature prior is not used) keeps that curve for its cleanliness test,
/// and a clean fragment or a converged piece keeps the curve it was tested with.
pub(super) fn fragments(
    cands: &[Component],
    edges: &mut EdgeList,
    p: &Params,
    s: &mut Scratch,
) -> (Vec<Frag>, Option<f64>) {
    let h = p.height;
    let mut sorted: Vec<&Component> = cands
        .iter()
        .filter(|c| c.row_span() >= p.min_fragment_rows)
        .collect();
    sorted.sort_by_key(|c| c.first_index);
    s.fitted.clear();
    let mut qs: Vec<f64> = Vec::new();
    for c in &sorted {
        let mut fitted = None;
        if 2 * c.row_span() as usize > h && polarity(c).is_some() {
            let cv = curve(c, h);
            if let Some(cv) = cv.filter(|cv| cv.rms_px <= p.max_fragment_rms_px) {
                qs.push(cv.q);
            }
            if parabola(c, h) {
                fitted = cv;
            }
        }
        s.fitted.push(fitted);
    }
    let q = (!qs.is_empty()).then(|| median(&mut qs));
    let mut out = Vec::with_capacity(sorted.len());
    let mut pieces = Vec::new();
    for (k, c) in sorted.into_iter().enumerate() {
        // `curve_with(c, h, q)`: for a parabola the curve already fitted without the prior.
        let cv = match s.fitted[k] {
            Some(cv) => Some(cv),
            None => curve_with(c, h, q),
        };
        let clean = cv.filter(|cv| cv.rms_px <= p.max_fragment_rms_px);
        // A clean fragment keeps the curve just fitted (the same `curve_with`).
        if let (Some(pol), Some(cv)) = (polarity(c), clean) {
            out.push(Frag {
                comp: *c,
                polarity: pol,
                curve: cv,
            });
            continue;
        }
        edges.component_pixels_into(c, &mut s.comp);
        for rising in [true, false] {
            s.part.clear();
            s.part
                .extend(s.comp.iter().filter(|e| e.rising() == rising).copied());
            pieces.clear();
            split(s, p, q, &mut pieces);
            for &(comp, known) in &pieces {
                let polarity = if rising { 1 } else { -1 };
                out.extend(known.or_else(|| curve_with(&comp, h, q)).map(|curve| Frag {
                    comp,
                    polarity,
                    curve,
                }));
            }
        }
    }
    (out, q)
}

/// Tracks from the frame's candidate components: fragments of one polarity linked top to bottom.
pub fn tracks(cands: &[Component], edges: &mut EdgeList, p: &Params) -> (Vec<Track>, Option<f64>) {
    tracks_with(cands, edges, p, &mut Scratch::default())
}

/// [`tracks`] with the selection's buffers.
pub(super) fn tracks_with(
    cands: &[Component],
    edges: &mut EdgeList,
    p: &Params,
    s: &mut Scratch,
) -> (Vec<Track>, Option<f64>) {
    let h = p.height;
    let (frags, q) = fragments(cands, edges, p, s);
    // Without the frame's curvature, pieces are straight: allow for the ring's own bending
    // (1/radius) over the distance a piece is extrapolated.
    let bend = if q.is_some() {
        0.0
    } else {
        0.5 / p.ring_radius_px
    };
    // Top to bottom, ties by the unique first pixel: the same order whatever the input order
    // (a stable sort of indices: the fragments themselves are not moved).
    let mut order: Vec<u32> = (0..frags.len() as u32).collect();
    order.sort_by_key(|&k| {
        let c = &frags[k as usize].comp;
        (c.min_row, c.first_index)
    });
    let mut out: Vec<Track> = Vec::with_capacity(frags.len());
    // What the scan below reads of each track, one list per polarity (rising, falling), each
    // in the order the tracks started: most tracks are rejected on their last row alone,
    // without touching the tracks themselves.
    let mut open: [Vec<Link>; 2] = Default::default();
    for &k in &order {
        let f = &frags[k as usize];
        let f_first = f.comp.min_row as f64;
        let f_mean = f.comp.sum_row as f64 / f.comp.pos_n.max(1) as f64;
        let f_at_first = f.curve.at(f_first, h);
        let links = &mut open[usize::from(f.polarity != 1)];
        // (position in `links`, distance)
        let mut best: Option<(usize, f64)> = None;
        for (j, l) in links.iter().enumerate() {
            if l.last > f.comp.min_row + 12 {
                continue;
            }
            // Where they meet: the track continued down to the fragment's first row, and the
            // fragment continued up to the track's last row.
            let t_last = l.last as f64;
            let gap = (f_first - t_last).max(0.0);
            let reach = (f_first - l.mean).max(f_mean - t_last);
            let tol = 1.5 + 0.01 * gap + bend * reach * reach;
            let d1 = (l.curve.at(f_first, h) - f_at_first).abs();
            let d2 = (l.at_last - f.curve.at(t_last, h)).abs();
            let d = d1.max(d2);
            if d <= tol && best.is_none_or(|(_, bd)| d < bd) {
                best = Some((j, d));
            }
        }
        match best {
            Some((j, _)) => {
                let i = links[j].track;
                out[i].absorb(f, h, q);
                links[j] = Link::of(&out[i], i, h);
            }
            None => {
                out.push(Track::start(f));
                links.push(Link::of(&out[out.len() - 1], out.len() - 1, h));
            }
        }
    }
    (out, q)
}

/// What the linking scan of [`tracks_with`] reads of a track, kept apart from it: its index,
/// last row, mean row, curve and the curve's column at the last row (the same values the
/// scan would compute from the track).
#[derive(Debug, Clone, Copy)]
pub(super) struct Link {
    track: usize,
    last: u32,
    mean: f64,
    curve: Curve,
    at_last: f64,
}

impl Link {
    fn of(t: &Track, track: usize, h: usize) -> Link {
        let last = t.last_row();
        Link {
            track,
            last,
            mean: t.mean_row(),
            curve: t.curve,
            at_last: t.curve.at(last as f64, h),
        }
    }
}
