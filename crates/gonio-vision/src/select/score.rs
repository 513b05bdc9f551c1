//! The scoring: ring candidates from pairs of long tracks (separation, parallel, alike, a flat
//! inside), their score and the margin over the runner-up, or why there is none.

use super::candidate::{Candidate, Selection};
use super::line::{Curve, curve, window_mean};
use super::pair::{PairFit, RefitScratch, joint_fit, refit_pair_with};
use super::tracks::{Scratch, Track, merged, shared, tracks_with};
use crate::label::{Component, EdgeList};
use crate::optics::Params;
use crate::result::{InvalidReason, SaturatedRun};

/// First, last and count of the rows where both edges have pixels.
pub(super) fn rows_in_both(
    a: &Component,
    b: &Component,
    pa: &[bool],
    pb: &[bool],
) -> (u32, u32, u32) {
    let lo = a.min_row.max(b.min_row) as usize;
    let hi = a.max_row.min(b.max_row) as usize;
    let (mut n, mut first, mut last) = (0, u32::MAX, 0);
    for y in lo..=hi.min(pa.len().saturating_sub(1)) {
        if pa[y] && pb[y] {
            n += 1;
            first = first.min(y as u32);
            last = y as u32;
        }
    }
    (first, last, n)
}

thread_local! {
    /// The selection's buffers ([`Scratch`], [`RefitScratch`]), kept from frame to frame on
    /// each thread: every use clears them first, only their capacity carries over (no
    /// allocations to grow them again every frame).
    static BUFFERS: std::cell::Cell<(Scratch, RefitScratch)> = Default::default();
}

/// Chooses the ring among the frame's candidate components (see the module documentation);
/// `edges` holds the frame's edge pixels for the robust steps (an incomplete list disables them:
/// contaminated components are then dropped), `saturated` the frame's saturated runs.
pub fn select(
    cands: &[Component],
    edges: &mut EdgeList,
    saturated: &[SaturatedRun],
    p: &Params,
) -> Selection {
    let h = p.height;
    let (mut scratch, mut refit_scratch) = BUFFERS.take();
    let (tracks, q_frame) = tracks_with(cands, edges, p, &mut scratch);
    // Each track's rows as disjoint intervals in row order (`spans[span_of[k].0..span_of[k].1]`),
    // once: every pair and the interior check intersect them without sorting.
    let mut spans: Vec<(u32, u32)> = Vec::new();
    let mut span_of: Vec<(usize, usize)> = Vec::with_capacity(tracks.len());
    for t in &tracks {
        let a = spans.len();
        spans.extend(merged(&t.rows));
        span_of.push((a, spans.len()));
    }
    let rows_of = |k: usize| &spans[span_of[k].0..span_of[k].1];
    let mut skip: Vec<bool> = Vec::new();
    let long: Vec<usize> = (0..tracks.len())
        .filter(|&i| 2 * tracks[i].coverage as usize >= p.min_edge_pixels)
        .collect();
    let d = p.baseline_width_px as f64;
    let (sep_lo, sep_hi) = p.separation_px;
    let mut pairs: Vec<Candidate> = Vec::new();
    // Each candidate's edge curves (`curve` of its refitted edges), computed once.
    let mut pair_curves: Vec<(Curve, Curve)> = Vec::new();
    let mut clipped_out = false;
    let mut coarse_found = false;
    let mut at_side = false;
    for &i in &long {
        let l = &tracks[i];
        if l.polarity != 1 {
            continue;
        }
        for &j in &long {
            let r = &tracks[j];
            if r.polarity != -1 {
                continue;
            }
            // The rows both cover lie within the overlap of their row ranges: without enough
            // of that, no need to intersect their fragments' rows.
            let hull = (l.comp.max_row.min(r.comp.max_row) + 1)
                .saturating_sub(l.comp.min_row.max(r.comp.min_row));
            if 2 * (hull as usize) < p.min_edge_pixels {
                continue;
            }
            // Coarse: the tracks as linked (their curves may still carry a crossing's pull).
            let (n, first, last) = shared(rows_of(i), rows_of(j));
            if 2 * (n as usize) < p.min_edge_pixels {
                continue;
            }
            let (y0, y1) = (first as f64, last as f64);
            let sep0 = r.curve.at(y0, h) - l.curve.at(y0, h);
            let sep1 = r.curve.at(y1, h) - l.curve.at(y1, h);
            let sepm = r.curve.at(0.5 * (y0 + y1), h) - l.curve.at(0.5 * (y0 + y1), h);
            if sepm < sep_lo - 1.0
                || sepm > sep_hi + 1.0
                || (sep1 - sep0).abs() > 3.0 * p.parallel_px
                || l.gradient.min(r.gradient) < 0.4 * l.gradient.max(r.gradient)
            {
                continue;
            }
            // Rows where saturation reaches the ring or its edges' profiles are left out.
            skip.clear();
            skip.resize(h, false);
            for s in saturated {
                let y = s.row as f64;
                let (a, b) = (l.curve.at(y, h) - 3.0, r.curve.at(y, h) + 3.0);
                if (s.last as f64) >= a && (s.first as f64) <= b {
                    skip[s.row as usize] = true;
                }
            }
            if h - skip.iter().filter(|&&c| c).count() < p.min_edge_pixels {
                clipped_out = true;
                continue;
            }
            // Fine: both edges from their own pixels (without the frame's pixels: the tracks'
            // sums, which only clean fragments make).
            let fit = if edges.pixels().is_some() {
                refit_pair_with(l, r, edges, &skip, q_frame, p, &mut refit_scratch)
            } else {
                let rows = |t: &Track| {
                    let mut v = vec![false; h];
                    for &(a, b) in &t.rows {
                        for y in a..=b {
                            v[y as usize] = !skip[y as usize];
                        }
                    }
                    v
                };
                joint_fit(&l.comp, &r.comp, h, None).map(|(a_left, a_right, b, q, c_sigma_px)| {
                    PairFit {
                        left: l.comp,
                        right: r.comp,
                        left_rows: rows(l),
                        right_rows: rows(r),
                        a_left,
                        a_right,
                        b,
                        q,
                        c_sigma_px,
                        width_change_px: 0.0,
                    }
                })
            };
            let Some(fit) = fit else {
                continue;
            };
            let (lc, rc) = (fit.left, fit.right);
            let (Some(lcv), Some(rcv)) = (curve(&lc, h), curve(&rc, h)) else {
                continue;
            };
            // The refit leaves out rows where something else touches the ring; what is left
            // must still hold the ring on a good part of the window (with the ring's own
            // curvature, c needs no more).
            if (sep_lo..=sep_hi).contains(&sepm) {
                coarse_found = true;
                let side = |c: &Component| c.min_col <= 1 || c.max_col as usize + 2 >= p.width;
                at_side |= side(&l.comp) || side(&r.comp);
            }
            let (first, last, n) = rows_in_both(&lc, &rc, &fit.left_rows, &fit.right_rows);
            if 5 * (n as usize) < 3 * p.min_edge_pixels {
                continue;
            }
            let rows = [first as f64, 0.5 * (first + last) as f64, last as f64];
            let seps = rows.map(|y| rcv.at(y, h) - lcv.at(y, h));
            let (smin, smax) = seps
                .iter()
                .fold((f64::MAX, f64::MIN), |(a, b), &s| (a.min(s), b.max(s)));
            if smin < sep_lo || smax > sep_hi || smax - smin > p.parallel_px {
                continue;
            }
            let gl = lc.sum_mag as f64 / lc.pos_n.max(1) as f64;
            let gr = rc.sum_mag as f64 / rc.pos_n.max(1) as f64;
            let (g_lo, g_hi) = (gl.min(gr), gl.max(gr));
            if g_lo < 0.5 * g_hi {
                continue;
            }
            let share = |c: &Component| c.strong as f64 / c.pixels.max(1) as f64;
            pair_curves.push((lcv, rcv));
            pairs.push(Candidate {
                left: i,
                right: j,
                separation_px: fit.a_right - fit.a_left,
                shared_rows: n,
                gradient: g_lo,
                strong_share: share(&lc).min(share(&rc)),
                balance: g_lo / g_hi,
                score: 0.0,
                c_px: fit.c_px(h),
                fit,
            });
        }
    }
    BUFFERS.set((scratch, refit_scratch));
    // A ring's inside is flat: drop candidates with a track as strong as their edges running
    // between them, parallel to them, over 30 % of their shared rows (two neighbouring lines,
    // not a ring). A scratch crossing the ring at an angle does not count.
    let mut curves = pair_curves.iter();
    pairs.retain(|c| {
        let &(lcv, rcv) = curves.next().expect("one pair of curves per candidate");
        let lrows = [(c.fit.left.min_row, c.fit.left.max_row)];
        !tracks.iter().enumerate().any(|(k, t)| {
            if k == c.left || k == c.right || t.gradient < p.interior_fraction * c.gradient {
                return false;
            }
            let (n, first, last) = shared(rows_of(k), &lrows);
            if (n as f64) < 0.3 * c.shared_rows as f64 {
                return false;
            }
            let (y0, y1) = (first as f64, last as f64);
            let drift = (t.curve.at(y1, h) - lcv.at(y1, h)) - (t.curve.at(y0, h) - lcv.at(y0, h));
            if drift.abs() > 2.0 * p.parallel_px {
                return false;
            }
            let y = 0.5 * (y0 + y1);
            let x = t.curve.at(y, h);
            x > lcv.at(y, h) + 1.5 && x < rcv.at(y, h) - 1.5
        })
    });
    // Frame-relative strength: against the strongest candidate.
    let g_top = pairs.iter().map(|c| c.gradient).fold(0.0, f64::max);
    for c in pairs.iter_mut() {
        let strength = (c.gradient / g_top) * (0.5 + 0.5 * c.strong_share);
        let coverage = c.shared_rows as f64 / h as f64;
        let x = (c.separation_px - d) / (p.width_tolerance * d);
        let width = (1.0 - 0.5 * x * x).max(0.0);
        c.score = strength * coverage.min(1.0) * width * c.balance;
    }
    pairs.sort_by(|a, b| {
        b.score
            .total_cmp(&a.score)
            .then(a.fit.left.first_index.cmp(&b.fit.left.first_index))
            .then(a.fit.right.first_index.cmp(&b.fit.right.first_index))
    });
    let best = pairs.first().cloned();
    let mut reason = None;
    let margin = best.as_ref().map(|b| {
        let runner = pairs
            .iter()
            .skip(1)
            .filter(|c| (c.c_px - b.c_px).abs() > d / 2.0)
            .map(|c| c.score)
            .next()
            .unwrap_or(0.0);
        if b.score > 0.0 {
            (1.0 - runner / b.score).clamp(0.0, 1.0)
        } else {
            0.0
        }
    });
    if margin.is_some_and(|m| m < p.min_margin) {
        reason = Some(InvalidReason::Ambiguous);
    }
    if best.is_none() {
        reason = Some(if clipped_out {
            InvalidReason::Saturated
        } else if at_side {
            InvalidReason::RingOutsideWindow
        } else if coarse_found {
            // Edges that look like the ring's, but not once re-fitted from their own pixels.
            InvalidReason::InconsistentEdges
        } else {
            no_candidate_reason(&tracks, &long, p)
        });
    }
    Selection {
        tracks,
        best,
        margin,
        reason,
    }
}

/// Why no candidate: a lone edge whose partner would lie beyond the window's side, one long
/// edge, two that are not a ring's, or none that fits the model at all.
pub(super) fn no_candidate_reason(tracks: &[Track], long: &[usize], p: &Params) -> InvalidReason {
    let h = p.height;
    let reach = p.separation_px.1 + 2.0;
    let w = p.width as f64;
    let beyond_side = long.iter().any(|&i| {
        let t = &tracks[i];
        let c = window_mean(&t.curve, h);
        (t.polarity == 1 && c + reach > w - 1.0) || (t.polarity == -1 && c - reach < 0.0)
    });
    if beyond_side {
        return InvalidReason::RingOutsideWindow;
    }
    match long.len() {
        0 => InvalidReason::NoRing,
        1 => InvalidReason::OneEdge,
        2 => InvalidReason::InconsistentEdges,
        _ => InvalidReason::NoRing,
    }
}
